use super::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};

const MS: i64 = 1_000_000;
const S: i64 = 1_000_000_000;
const HOUR: i64 = 3600 * S;
/// Remote clock at the first sample, and the host clock then (7 h apart).
const REMOTE0: i64 = 2 * HOUR + 123_456_789;
const HOST0: i64 = 9 * HOUR + 987_654_321;
const DRIFT: f64 = 50e-6;

/// True host time of remote time `r` (no delay).
fn true_host(r: i64) -> i64 {
    HOST0 + ((r - REMOTE0) as f64 * (1.0 + DRIFT)).round() as i64
}

/// 100 Hz remote readings with their arrival times: exponential delay of mean 2 ms and, one in
/// 200, a 50 ms spike.
fn arrivals(seed: u64, duration_ns: i64) -> Vec<(i64, i64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let exp = Exp::new(1.0 / (2.0 * MS as f64)).unwrap();
    (0..duration_ns / (10 * MS))
        .map(|k| {
            let r = REMOTE0 + k * 10 * MS;
            let mut delay = exp.sample(&mut rng) as i64;
            if rng.random::<f64>() < 0.005 {
                delay += 50 * MS;
            }
            (r, true_host(r) + delay)
        })
        .collect()
}

#[test]
fn first_sample_gives_an_estimate() {
    let mut sync = ClockSync::default();
    assert_eq!(sync.to_host(REMOTE0), None);
    assert!(sync.push(REMOTE0, HOST0 + 3 * MS));
    assert_eq!(sync.to_host(REMOTE0), Some(HOST0 + 3 * MS));
    assert_eq!(sync.to_remote(HOST0 + 3 * MS), Some(REMOTE0));
    assert_eq!(sync.offset_ns(), Some(HOST0 - REMOTE0 + 3 * MS));
    assert_eq!(sync.drift_ppm(), Some(0.0));
    assert_eq!(sync.samples(), 1);
}

#[test]
fn mapping_within_1ms_after_2s_with_drift_jitter_and_spikes() {
    let mut sync = ClockSync::default();
    let mut worst_ns = 0;
    for &(r, h) in &arrivals(7, 600 * S) {
        assert!(sync.push(r, h));
        if r - REMOTE0 >= 2 * S {
            let err = (sync.to_host(r).unwrap() - true_host(r)).abs();
            worst_ns = worst_ns.max(err);
            let back = (sync.to_remote(true_host(r)).unwrap() - r).abs();
            assert!(back <= MS, "to_remote off by {back} ns at {r}");
        }
    }
    assert!(worst_ns <= MS, "worst mapping error {worst_ns} ns");
    // Over the whole last window, not only at the newest reading.
    for k in 0..60_00 {
        let r = REMOTE0 + 540 * S + k * 10 * MS;
        let err = (sync.to_host(r).unwrap() - true_host(r)).abs();
        assert!(err <= MS, "error {err} ns at {r}");
    }
    let drift = sync.drift_ppm().unwrap();
    assert!((drift - 50.0).abs() < 2.0, "drift {drift} ppm");
    assert_eq!(sync.samples(), 60_000);
}

#[test]
fn drift_is_needed_to_map_10_min_ahead() {
    let mut sync = ClockSync::default();
    for &(r, h) in &arrivals(11, 60 * S) {
        sync.push(r, h);
    }
    let r = REMOTE0 + 600 * S;
    let err = (sync.to_host(r).unwrap() - true_host(r)).abs();
    assert!(err <= MS, "error {err} ns 10 min on");
    // A clock relation without drift would be 30 ms off there.
    let offset_only = r + sync.offset_ns().unwrap();
    let err_no_drift = (offset_only - true_host(r)).abs();
    assert!(err_no_drift > 25 * MS, "{err_no_drift}");
}

#[test]
fn a_stalled_second_does_not_move_the_line() {
    let mut sync = ClockSync::default();
    for &(r, h) in &arrivals(3, 30 * S) {
        let t = r - REMOTE0;
        let stall = if (10 * S..12 * S).contains(&t) {
            80 * MS
        } else {
            0
        };
        sync.push(r, h + stall);
    }
    for t in [5 * S, 11 * S, 29 * S] {
        let r = REMOTE0 + t;
        let err = (sync.to_host(r).unwrap() - true_host(r)).abs();
        assert!(err <= MS / 2, "error {err} ns at {t}");
    }
}

#[test]
fn a_remote_clock_going_back_is_refused_until_reset() {
    let mut sync = ClockSync::default();
    assert!(sync.push(10 * S, 20 * S));
    assert!(sync.push(11 * S, 21 * S));
    assert!(!sync.push(S, 22 * S));
    assert_eq!(sync.refused(), 1);
    assert!(!sync.push(0, i64::MIN));
    sync.reset();
    assert_eq!(sync.samples(), 0);
    assert_eq!(sync.to_host(S), None);
    assert!(sync.push(S, 22 * S));
    assert_eq!(sync.to_host(S), Some(22 * S));
}

const US: i64 = 1_000;
const LAP_NS: i64 = (1 << 32) * US;

#[test]
fn unwrap32_crosses_wraps_and_long_gaps() {
    let mut unwrap = Unwrap32::new(10 * S);
    let start = u32::MAX - 5_000;
    assert_eq!(unwrap.push(start, 0).t_ns, i64::from(start) * US);
    // 10 ms later, past the wrap.
    let out = unwrap.push(start.wrapping_add(10_000), 10 * MS);
    assert_eq!(
        out,
        Unwrapped {
            t_ns: (i64::from(start) + 10_000) * US,
            reset: false
        }
    );
    // Off for two laps and a bit (the host saw 2 laps + 1 s).
    let out = unwrap.push(start.wrapping_add(1_010_000), 10 * MS + 2 * LAP_NS + S);
    assert_eq!(out.t_ns, (i64::from(start) + 1_010_000) * US + 2 * LAP_NS);
    assert!(!out.reset);
    assert_eq!(unwrap.resets(), 0);
}

#[test]
fn unwrap32_keeps_late_readings_and_counts_resets() {
    let mut unwrap = Unwrap32::new(10 * S);
    let base = 3_000_000_000_u32;
    unwrap.push(base, 0);
    unwrap.push(base + 20_000, 20 * MS);
    // A reading 5 ms older arrives late.
    let late = unwrap.push(base + 15_000, 21 * MS);
    assert_eq!(
        late,
        Unwrapped {
            t_ns: (i64::from(base) + 15_000) * US,
            reset: false
        }
    );
    // The counter restarts from 0: as a wrap it would mean 21 min, the host saw 10 ms.
    let out = unwrap.push(0, 31 * MS);
    assert!(out.reset);
    assert_eq!(out.t_ns, (i64::from(base) + 20_000) * US + 11 * MS);
    assert_eq!(unwrap.resets(), 1);
    // And goes on from the new epoch.
    let next = unwrap.push(10_000, 41 * MS);
    assert_eq!(next.t_ns, out.t_ns + 10 * MS);
    assert!(!next.reset);
}

/// One sample in 15 misdated (drawn anew, far off, a few seconds off, or 0) and now and then
/// a stall of the host (what came meanwhile read at once, up to 3 s late): the line never
/// re-locks. A late or misdated-as-late sample placed but not taken into the line is what
/// holds it; taken in, the young line tilted and re-locked within 4 s on 2 of these 20 seeds.
#[test]
fn misdated_samples_and_host_stalls_never_relock_the_line() {
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut track = ClockTrack::default();
        let mut stalled = 0i64;
        let mut placed = 0;
        for k in 0..(30 * 200) {
            let r = REMOTE0 + k * 5 * MS;
            let on_time = true_host(r) + MS / 5;
            if rng.random_range(0..2000) == 0 {
                stalled = on_time + rng.random_range(0..3 * S);
            }
            let h = on_time.max(stalled);
            let (rr, good) = match rng.random_range(0..60) {
                0 => (rng.random::<i64>(), false),
                1 => (
                    r.saturating_add(rng.random_range(-2_000 * S..2_000 * S)),
                    false,
                ),
                2 => (r.saturating_add(rng.random_range(-5 * S..5 * S)), false),
                3 => (0, false),
                _ => (r, true),
            };
            let p = track.push(rr, h);
            assert!(!p.relocked, "seed {seed}: re-locked at sample {k}");
            if good && p.t_ns == Some(r) {
                placed += 1;
            }
        }
        assert!(placed > 5_500, "seed {seed}: {placed} good samples placed");
    }
}
