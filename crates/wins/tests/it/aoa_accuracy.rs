//! Per-packet direct-path AoA against the simulator's truth.

use std::f64::consts::{PI, TAU};
use wins::aoa::{AoaConfig, AoaEstimator, AoaPrediction, calibrate, calibrate_with};
use wins::rig::array::CHANNEL_64_HZ;
use wins::rig::{ArrayGeometry, ChainCalibration};
use wins::sim::radio::ReceiverResponse;
use wins::sim::trajectory::TrajectoryConfig;
use wins::sim::{Scenario, SimOutput, simulate};

/// Per-packet absolute AoA errors (degrees) of full-range MUSIC (lowest-ToF credible peak) for the
/// packets `keep` selects; packets without a credible peak are counted in the second value.
fn music_errors_deg(
    out: &SimOutput,
    ap: usize,
    estimator: &AoaEstimator,
    keep: impl Fn(&wins::sim::csi::PacketTruth) -> bool,
) -> (Vec<f64>, usize) {
    let mut errors = Vec::new();
    let mut none = 0;
    for (p, record) in out.aps[ap].received() {
        if !keep(&p.truth) {
            continue;
        }
        match estimator
            .direct_path(record)
            .expect("simulated packets are valid")
        {
            Some(peak) => errors.push((peak.aoa_rad - p.truth.aoa_rad).abs().to_degrees()),
            None => none += 1,
        }
    }
    (errors, none)
}

fn percentile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

fn truth_calibration(out: &SimOutput) -> ChainCalibration {
    let mut c = ChainCalibration::identity(3);
    c.phase_offsets_rad = out.chain_phase_offsets_rad.clone();
    c
}

fn broadside_unobstructed(t: &wins::sim::csi::PacketTruth) -> bool {
    t.in_front && !t.direct_obstructed && t.aoa_rad.abs() <= 60f64.to_radians()
}

fn estimator(calibration: Option<ChainCalibration>) -> AoaEstimator {
    AoaEstimator::new(
        &AoaConfig::default(),
        ArrayGeometry::default(),
        CHANNEL_64_HZ,
        calibration,
    )
    .unwrap()
}

/// The built-in `name`, airborne, cut to `seconds`.
fn scenario(name: &str, seconds: f64) -> Scenario {
    let mut s = Scenario::built_in(name).unwrap().airborne();
    s.duration_s = seconds;
    s
}

fn flight(name: &str, seconds: f64) -> SimOutput {
    simulate(&scenario(name, seconds), &mut |_| {}).unwrap()
}

/// [`flight`] with an ideal receiver: no response over the band (`receiver_response = "flat"`),
/// the timing offsets over 100 ns.
fn ideal_receiver_flight(name: &str, seconds: f64) -> SimOutput {
    let mut s = scenario(name, seconds);
    s.radio.receiver_response = ReceiverResponse::Flat;
    s.radio.sto_max_s = 100e-9;
    simulate(&s, &mut |_| {}).unwrap()
}

fn report(label: &str, errors: &[f64], none: usize) -> (f64, f64) {
    let (median, p90) = (percentile(errors, 0.5), percentile(errors, 0.9));
    println!(
        "{label}: {} packets, {none} without a credible peak, median {median:.2}°, p90 {p90:.2}°",
        errors.len()
    );
    (median, p90)
}

/// The paper's accuracy (2° median) on an unobstructed AP within ±60° of broadside: on an ideal
/// receiver, and within 15 % of it with the Intel 5300's measured response over the band (the
/// simulator's default).
#[test]
fn music_direct_path_meets_two_degrees_median_on_simulated_multipath() {
    let out = ideal_receiver_flight("paper-circle", 20.0);
    let est = estimator(Some(truth_calibration(&out)));
    let (e, none) = music_errors_deg(&out, 0, &est, broadside_unobstructed);
    let (median, p90) = report("paper-circle, an ideal receiver", &e, none);
    // Measured 1.67° / 5.52°, 0 misses (seed 1, 20 s).
    assert!(e.len() > 900 && none <= 10);
    assert!(median <= 2.0 && p90 <= 7.0, "{median} {p90}");

    let out = flight("paper-circle", 20.0);
    let est = estimator(Some(truth_calibration(&out)));
    let (e, none) = music_errors_deg(&out, 0, &est, broadside_unobstructed);
    let (median, p90) = report("paper-circle", &e, none);
    // Measured 2.06° / 5.95°, 0 misses: the response's bow differs from chain to chain by up to
    // 8° over the band, which no chain offset removes.
    assert!(e.len() > 900 && none <= 10);
    assert!(median <= 2.3 && p90 <= 7.0, "{median} {p90}");

    // The other flights, for the record, with bounds around what was measured.
    let out = flight("paper-circle-obstacle", 30.0);
    let est = estimator(Some(truth_calibration(&out)));
    // The obstacle attenuates the direct path for the whole flight: measured 4.42° with the
    // receiver's response (2.81° / 15.4° on an ideal receiver); the bound is +20 %.
    let (e, none) = music_errors_deg(&out, 0, &est, |t| {
        t.in_front && t.direct_obstructed && t.aoa_rad.abs() <= 60f64.to_radians()
    });
    let (median, _) = report("paper-circle-obstacle (direct path obstructed)", &e, none);
    assert!(e.len() > 1000 && median <= 5.3, "{median}");
    let out = flight("figure8-yaw", 20.0);
    let est = estimator(Some(truth_calibration(&out)));
    let (e, none) = music_errors_deg(&out, 0, &est, broadside_unobstructed);
    let (median, _) = report("figure8-yaw, in front", &e, none);
    // Measured 2.98° / 8.10° with the receiver's response (2.24° / 6.14° on an ideal receiver).
    assert!(median <= 3.6, "{median}");
}

/// PAoA with a prediction from the truth ± 5° finds the same peak as the full search.
#[test]
fn paoa_with_a_prediction_within_five_degrees_matches_the_full_search() {
    use rand::{RngExt, SeedableRng};
    let out = flight("paper-circle", 20.0);
    let est = estimator(Some(truth_calibration(&out)));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let (mut same, mut comparable, mut errors, mut no_peak) = (0, 0, Vec::new(), 0);
    for (p, record) in out.aps[0].received() {
        if !broadside_unobstructed(&p.truth) {
            continue;
        }
        let prediction = AoaPrediction {
            previous_aoa_rad: p.truth.aoa_rad + rng.random_range(-5.0f64..5.0).to_radians(),
            rotation_part_rad: 0.0,
            translation_part_rad: 0.0,
            in_front_after: true,
        };
        let r = est.paoa(record, &prediction).unwrap();
        assert!(r.window.max_rad - r.window.min_rad <= 40f64.to_radians() + 1e-12);
        if let Some(full) = est.direct_path(record).unwrap()
            && full.aoa_rad >= r.window.min_rad
            && full.aoa_rad <= r.window.max_rad
        {
            comparable += 1;
            if r.peak
                .is_some_and(|q| (q.aoa_rad - full.aoa_rad).abs() < 1e-6)
            {
                same += 1;
            }
        }
        match r.peak {
            Some(q) => errors.push((q.aoa_rad - p.truth.aoa_rad).abs().to_degrees()),
            None => no_peak += 1,
        }
    }
    let (median, _) = report("PAoA, truth ± 5°", &errors, no_peak);
    println!("PAoA equals the full search on {same} of {comparable} packets");
    // Measured 945 of 950 (the rest: a lower-ToF peak just outside the window edge), 2.02° (the
    // full search's median, 2.06°, with the receiver's response).
    assert!(
        same as f64 >= 0.98 * comparable as f64,
        "{same}/{comparable}"
    );
    assert!(median <= 2.3 && no_peak <= 10, "{median} {no_peak}");
}

/// A window pointed away from every path reports no credible peak instead of noise, on an ideal
/// receiver. (With the 5300's measured response every packet of this hover finds a peak there,
/// over 20° from the AP: the response's bow, which differs from chain to chain, makes spurious
/// peaks away from the paths, and a window that holds no path reports one of them.)
#[test]
fn paoa_reports_an_empty_window() {
    let out = ideal_receiver_flight("hover", 2.0);
    let est = estimator(Some(truth_calibration(&out)));
    let (mut empty, mut total) = (0, 0);
    for (p, record) in out.aps[0].received() {
        let away = AoaPrediction {
            previous_aoa_rad: if p.truth.aoa_rad > 0.0 { -1.2 } else { 1.2 },
            rotation_part_rad: 0.0,
            translation_part_rad: 0.0,
            in_front_after: true,
        };
        let r = est.paoa(record, &away).unwrap();
        total += 1;
        if r.peak.is_none() {
            empty += 1;
        } else if let Some(q) = r.peak {
            assert!((q.aoa_rad - p.truth.aoa_rad).abs() > 20f64.to_radians());
        }
    }
    println!("hover, window 70° off the AP: {empty} of {total} packets report no credible peak");
    assert!(empty as f64 >= 0.9 * total as f64, "{empty}/{total}");
}

/// Uncalibrated chains are tens of degrees off; calibrating on a moving capture with known
/// angles recovers the offsets and the accuracy.
#[test]
fn calibration_from_a_simulated_capture_removes_the_chain_offsets() {
    let out = flight("paper-circle", 20.0);
    let (e, none) = music_errors_deg(&out, 0, &estimator(None), broadside_unobstructed);
    let (uncalibrated, _) = report("uncalibrated", &e, none);
    assert!(uncalibrated > 20.0, "{uncalibrated}");

    let (cal, used) = calibrate_with(
        out.aps[0].received().map(|(p, r)| (r, p.truth.aoa_rad)),
        ArrayGeometry::default(),
        CHANNEL_64_HZ,
        &AoaConfig::default(),
    )
    .unwrap();
    assert_eq!(used.skipped.len(), 0);
    let truth = &out.chain_phase_offsets_rad;
    for m in 1..3 {
        let want = truth[m] - truth[0];
        let err = (cal.phase_offsets_rad[m] - want + PI).rem_euclid(TAU) - PI;
        // Measured 0.6° and 0.9°.
        assert!(err.abs() < 2f64.to_radians(), "chain {m}: {err}");
    }
    let (e, none) = music_errors_deg(&out, 0, &estimator(Some(cal)), broadside_unobstructed);
    let (median, _) = report("calibrated on the moving capture", &e, none);
    // Measured 2.05° (1.67° on an ideal receiver).
    assert!(median <= 2.3, "{median}");

    // A static capture at a known angle, off the room's symmetry axes.
    let mut h = Scenario::built_in("hover").unwrap().airborne();
    h.seed = Scenario::built_in("paper-circle").unwrap().airborne().seed;
    h.duration_s = 10.0;
    h.trajectory = TrajectoryConfig::Hover {
        position_m: [5.0, 2.6, 1.2],
    };
    h.yaw.offset_deg = 17.0;
    let hover = simulate(&h, &mut |_| {}).unwrap();
    assert_eq!(hover.chain_phase_offsets_rad, out.chain_phase_offsets_rad);
    let known = hover.aps[0].packets[0].truth.aoa_rad;
    let (cal, _) = calibrate(
        hover.aps[0].received().map(|(_, r)| r),
        known,
        ArrayGeometry::default(),
        CHANNEL_64_HZ,
        &AoaConfig::default(),
    )
    .unwrap();
    let (e, none) = music_errors_deg(&out, 0, &estimator(Some(cal)), broadside_unobstructed);
    let (median, _) = report("calibrated on a static capture at -17°", &e, none);
    // Measured 2.03°: static reflections bias the offsets a little (see calibrate.rs).
    assert!(median <= 2.5, "{median}");
}

/// SpotFi over groups of 10 packets picks the direct path.
#[test]
fn spotfi_groups_find_the_direct_path() {
    let out = flight("paper-circle", 20.0);
    let est = estimator(Some(truth_calibration(&out)));
    let received: Vec<_> = out.aps[0].received().collect();
    let mut errors = Vec::new();
    let mut failed = 0;
    for group in received.chunks_exact(10) {
        let truth = group[5].0.truth;
        if !broadside_unobstructed(&truth) {
            continue;
        }
        let r = est.spotfi(group.iter().map(|(_, rec)| *rec));
        assert!(r.skipped.is_empty());
        match r.direct {
            Ok(d) => errors.push((d.aoa_rad - truth.aoa_rad).abs().to_degrees()),
            Err(_) => failed += 1,
        }
    }
    let (median, p90) = report("SpotFi, groups of 10", &errors, failed);
    assert!(
        median <= 2.5 && p90 <= 8.0 && failed <= 2,
        "{median} {p90} {failed}"
    );
}
