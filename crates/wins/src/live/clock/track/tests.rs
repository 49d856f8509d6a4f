use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};

use super::*;

const MS: i64 = 1_000_000;
const S: i64 = 1_000_000_000;
/// Remote clock at the first sample, and the host clock then.
const REMOTE0: i64 = 7_200 * S + 123_456_789;
const HOST0: i64 = 32_400 * S + 987_654_321;
const DRIFT: f64 = 50e-6;
/// 200 Hz.
const PERIOD: i64 = 5 * MS;

/// True host time of remote time `r` (no delay).
fn true_host(r: i64) -> i64 {
    HOST0 + ((r - REMOTE0) as f64 * (1.0 + DRIFT)).round() as i64
}

/// Arrival delays: exponential of mean 1 ms and, one in 200, a 50 ms spike.
struct Delays {
    rng: ChaCha8Rng,
    exp: Exp<f64>,
}

impl Delays {
    fn new(seed: u64) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            exp: Exp::new(1.0 / MS as f64).unwrap(),
        }
    }

    fn next(&mut self) -> i64 {
        let spike = if self.rng.random::<f64>() < 0.005 {
            50 * MS
        } else {
            0
        };
        self.exp.sample(&mut self.rng) as i64 + spike
    }
}

/// A clock tracked over `seconds` of 200 Hz samples from `REMOTE0`: (clock, next remote time).
fn tracked(seconds: i64, delays: &mut Delays) -> (ClockTrack, i64) {
    let mut track = ClockTrack::default();
    let mut r = REMOTE0;
    while r < REMOTE0 + seconds * S {
        track.push(r, true_host(r) + delays.next());
        r += PERIOD;
    }
    (track, r)
}

/// The line's mapping at a few remote times (compared exactly before and after a fault).
fn mapping(track: &ClockTrack) -> Vec<Option<i64>> {
    [0, 10 * S, 20 * S, 100 * S]
        .iter()
        .map(|dt| track.to_host(REMOTE0 + dt))
        .collect()
}

#[test]
fn the_first_lock_waits_for_five_samples_that_agree() {
    let mut track = ClockTrack::default();
    // The first two arrive 24 and 41 ms late (a connection's set-up), the rest within 1 ms.
    let late = [24 * MS, 41 * MS, 0, MS / 2, 0, MS, 0, 0, 0, 0, 0, 0, 0];
    let mut placed = vec![];
    let mut dropped = 0;
    for (k, delay) in late.iter().enumerate() {
        let r = REMOTE0 + k as i64 * 20 * MS;
        let p = track.push(r, true_host(r) + delay);
        dropped += p.dropped_unlocked;
        assert!(!p.relocked);
        placed.push(p.t_ns.is_some());
    }
    // Samples 2..=6 lock (five spanning 80 ms); the first two were dropped, not outliers.
    assert_eq!(placed.iter().position(|&p| p), Some(6), "{placed:?}");
    assert!(placed[6..].iter().all(|&p| p));
    assert_eq!(dropped, 2);
    assert_eq!((track.outliers(), track.relocks()), (0, 0));
    let r = REMOTE0 + 12 * 20 * MS;
    assert!((track.to_host(r).unwrap() - true_host(r)).abs() <= MS);
}

/// A wrong remote reading made from the right one.
type Fault = fn(i64) -> i64;

#[test]
fn a_lone_outlier_is_refused_counted_and_leaves_the_line_unchanged() {
    let mut delays = Delays::new(5);
    let faults: [(&str, Fault); 5] = [
        ("+4.5 s", |r| r + 4_500 * MS),
        ("+1000 s", |r| r + 1000 * S),
        ("-1000 s", |r| r - 1000 * S),
        ("garbage", |_| 0x5A5A_5A5A_5A5A),
        ("i64::MIN", |_| i64::MIN),
    ];
    for (name, fault) in faults {
        let (mut track, mut r) = tracked(30, &mut delays);
        // The same clock without the fault.
        let mut clean = track.clone();
        let bad = track.push(fault(r), true_host(r) + delays.next());
        assert_eq!(bad.t_ns, None, "{name}: the outlier was placed");
        r += PERIOD;
        // The next good sample refuses it (one whose difference overflows is refused at once).
        let delay = delays.next();
        let p = track.push(r, true_host(r) + delay);
        clean.push(r, true_host(r) + delay);
        assert!(p.t_ns.is_some(), "{name}");
        assert_eq!(bad.outliers + p.outliers, 1, "{name}: {bad:?} {p:?}");
        assert!(!p.relocked, "{name}");
        assert_eq!((track.outliers(), track.relocks()), (1, 0), "{name}");
        assert_eq!(mapping(&track), mapping(&clean), "{name}: the line moved");
    }
}

#[test]
fn scattered_garbage_never_locks_and_each_piece_is_an_outlier() {
    let mut delays = Delays::new(9);
    let (mut track, mut r) = tracked(20, &mut delays);
    let mut clean = track.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // Eight garbage times in a row (a corrupt stretch of a stream), then good samples.
    for _ in 0..8 {
        let garbage = i64::from(rng.random::<u32>()) * 1000;
        assert_eq!(track.push(garbage, true_host(r)).t_ns, None);
    }
    for _ in 0..10 {
        r += PERIOD;
        let delay = delays.next();
        assert!(track.push(r, true_host(r) + delay).t_ns.is_some());
        clean.push(r, true_host(r) + delay);
    }
    assert_eq!((track.outliers(), track.relocks()), (8, 0));
    assert_eq!(mapping(&track), mapping(&clean));
}

#[test]
fn a_restart_at_zero_relocks_within_a_few_samples_and_the_timeline_goes_on() {
    let mut delays = Delays::new(1);
    let (mut track, r) = tracked(40, &mut delays);
    // The remote clock restarts at 0 after 3 s of silence (a reboot); the host goes on.
    let host_restart = true_host(r) + 3 * S;
    let mut placed_at = None;
    for k in 0..200 {
        let remote = k * PERIOD;
        let host = host_restart + k * PERIOD + delays.next();
        let p = track.push(remote, host);
        if let Some(t) = p.t_ns {
            placed_at.get_or_insert(k);
            // On the timeline, the time the old clock would read at that host time.
            let want =
                REMOTE0 + ((host_restart + k * PERIOD - HOST0) as f64 / (1.0 + DRIFT)) as i64;
            assert!(
                (t - want).abs() <= 2 * MS,
                "sample {k}: {} ms off",
                (t - want) / MS
            );
        }
    }
    // 50 ms of 200 Hz samples, the eleventh completes the span.
    assert_eq!(placed_at, Some(10));
    assert_eq!((track.relocks(), track.outliers()), (1, 0));
    assert!(track.epoch_offset_ns() > 40 * S);
}

#[test]
fn a_12_s_silence_then_resumption_is_placed_at_once_or_relocked() {
    let mut delays = Delays::new(2);
    let (mut track, r) = tracked(30, &mut delays);
    // The same clock 12 s on: the line still holds (50 ppm over 12 s is 0.6 ms).
    let r = r + 12 * S;
    let p = track.push(r, true_host(r) + delays.next());
    assert!(p.t_ns.is_some());
    assert_eq!((track.relocks(), track.outliers()), (0, 0));
    // A clock that stepped 0.5 s during the silence (the line is stale): re-locked.
    let (mut track, r) = tracked(30, &mut delays);
    let mut placed = vec![];
    for k in 0..20 {
        let remote = r + 12 * S + k * PERIOD;
        let p = track.push(remote, true_host(remote) - 500 * MS + delays.next());
        placed.push(p.t_ns.is_some());
    }
    assert_eq!(placed.iter().position(|&p| p), Some(10), "{placed:?}");
    assert_eq!((track.relocks(), track.outliers()), (1, 0));
    // The timeline goes on through the host: the new readings are 0.5 s ahead of it.
    let remote = r + 12 * S + 19 * PERIOD;
    let t = track.to_timeline(true_host(remote) - 500 * MS).unwrap();
    assert!((t - (remote - 500 * MS)).abs() <= 2 * MS, "{t} vs {remote}");
}

#[test]
fn drift_is_estimated_as_before_with_no_outlier_nor_relock() {
    let mut delays = Delays::new(7);
    let (track, r) = tracked(300, &mut delays);
    let drift = track.drift_ppm().unwrap();
    assert!((drift - 50.0).abs() < 2.0, "drift {drift} ppm");
    let err = (track.to_host(r).unwrap() - true_host(r)).abs();
    assert!(err <= MS, "error {err} ns");
    assert_eq!((track.outliers(), track.relocks()), (0, 0));
}

#[test]
fn a_burst_queued_by_a_stalled_link_does_not_relock() {
    let mut delays = Delays::new(4);
    let (mut track, r) = tracked(30, &mut delays);
    // 8 s of samples held by the link, then delivered at once.
    let release = true_host(r + 8 * S);
    let mut refused_or_held = 0;
    for k in 0..(8 * S / PERIOD) {
        let p = track.push(r + k * PERIOD, release + k * 1000);
        refused_or_held += u64::from(p.t_ns.is_none());
    }
    // Those more than 5 s late are not taken; none locked a new line, and the line still
    // maps within a millisecond.
    assert!(refused_or_held > 500, "{refused_or_held}");
    assert_eq!(track.relocks(), 0);
    let r = r + 10 * S;
    assert!((track.to_host(r).unwrap() - true_host(r)).abs() <= MS);
}
