//! The estimator across a gap in the IMU stream (no pose from inside it, counted, and a restart
//! after it) and across a CSI outage (the AP's track starts over): after either, the error comes
//! back to within twice the undamaged flight's.

use nalgebra::Vector3;
use wins::Config;
use wins::csi::intel5300::{CODE_CSI, LEN_FIELD};
use wins::dataset::Manifest;
use wins::dataset::truth::{Pose, read_tum};
use wins::eval::{EvalOptions, position_error_rms_from, umeyama};
use wins::fusion::nonlinear::{PhaseKind, Reason};
use wins::sim::{Scenario, simulate, write_dataset};
use wins::time::Timestamp;

use super::pipeline_run::temp_dir;

#[test]
fn no_pose_comes_from_inside_an_imu_gap_and_the_estimate_starts_again_after_it() {
    let dir = temp_dir("imu-gap-run");
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.seed = 2;
    s.duration_s = 40.0;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    // Two seconds of IMU lost in the middle of the circle.
    let (gap_from_ns, gap_to_ns) = (20_000_000_000_i64, 22_000_000_000_i64);
    cut_imu(&dir, gap_from_ns, gap_to_ns);

    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    assert_eq!(run.wins.imu_gaps, 1, "{:?}", run.wins);
    assert!(run.wins.frames_in_imu_gap >= 50, "{:?}", run.wins);
    assert!(run.wins.restarts >= 1, "{:?}", run.wins);
    let inside: Vec<f64> = run
        .frames
        .iter()
        .filter(|f| f.t.0 > gap_from_ns && f.t.0 < gap_to_ns)
        .map(|f| f.t.0 as f64 * 1e-9)
        .collect();
    assert!(inside.is_empty(), "poses inside the gap at {inside:?} s");
    assert!(run.converged_at.is_some_and(|t| t.0 < gap_from_ns));
    // The run says so, and that its poses do not cover the flight after convergence.
    let w = run.warnings.join("\n");
    assert!(w.contains("IMU gap"), "{w}");
    assert!(run.coverage.gaps >= 1, "{:?}", run.coverage);
    assert!(run.coverage.longest_gap_s >= 2.0, "{:?}", run.coverage);
    assert!(
        run.coverage.share.is_some_and(|s| s < 0.95),
        "{:?}",
        run.coverage
    );
    assert!(w.contains("gap(s) without a pose"), "{w}");
    // The phases say it: at rest, starting, tracking, and recovering from the first frame after
    // the gap; each change after the one before.
    let phases: Vec<(PhaseKind, Reason)> = run.phases.iter().map(|c| (c.phase, c.reason)).collect();
    assert_eq!(
        phases[..3],
        [
            (PhaseKind::AtRest, Reason::Created),
            (PhaseKind::Starting, Reason::Motion),
            (PhaseKind::Tracking, Reason::Accepted),
        ],
        "{phases:?}"
    );
    let gap = run
        .phases
        .iter()
        .position(|c| c.phase == PhaseKind::Recovering && c.reason == Reason::ImuGap)
        .expect("a recovery after the IMU gap");
    assert!(
        run.phases[gap].t_s.is_some_and(|t| t >= 22.0),
        "{:?}",
        run.phases
    );
    let times: Vec<f64> = run.phases.iter().filter_map(|c| c.t_s).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    // stats.json carries them.
    let stats = serde_json::to_value(run.run_stats()).unwrap();
    assert_eq!(
        stats["phases"][2]["phase"], "tracking",
        "{}",
        stats["phases"]
    );
    assert_eq!(
        stats["phases"][gap]["reason"], "imu_gap",
        "{}",
        stats["phases"]
    );
}

/// What is cut out of the flight.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Damage {
    None,
    /// The IMU from 30 to 32 s.
    ImuGap,
    /// The IMU from 30 to 35 s.
    LongImuGap,
    /// The AP's CSI from 30 to 36 s.
    CsiOutage,
}

/// A 60 s `paper-circle` flight (seed `seed`) with `damage`, run: its poses after convergence
/// and the truth.
fn run_damaged(seed: u64, damage: Damage) -> (Vec<Pose>, Vec<Pose>) {
    let dir = temp_dir(&format!("imu-gap-reconverge-{seed}-{damage:?}"));
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.seed = seed;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    match damage {
        Damage::None => {}
        Damage::ImuGap => cut_imu(&dir, 30_000_000_000, 32_000_000_000),
        Damage::LongImuGap => cut_imu(&dir, 30_000_000_000, 35_000_000_000),
        Damage::CsiOutage => cut_csi(&dir, 30_000_000_000, 36_000_000_000),
    }
    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    match damage {
        Damage::None => {}
        Damage::ImuGap | Damage::LongImuGap => {
            assert_eq!(run.wins.imu_gaps, 1, "{:?}", run.wins);
            assert_eq!(run.stats.per_ap[0].imu_gap_restarts, 1, "{:?}", run.stats);
        }
        Damage::CsiOutage => {
            assert_eq!(run.inputs.aps[0].silences, 1, "{:?}", run.inputs);
            assert!(run.inputs.aps[0].longest_silence_s > 5.9);
            assert_eq!(run.stats.per_ap[0].silences, 1, "{:?}", run.stats);
            let w = run.warnings.join("\n");
            assert!(w.contains("AP ap0: silent for longer than 1 s"), "{w}");
        }
    }
    let truth_text = std::fs::read_to_string(dir.join("truth/poses.tum")).unwrap();
    let truth = read_tum(truth_text.as_bytes()).unwrap();
    (run.converged_poses(), truth)
}

/// The position error after 45 s of a 60 s `paper-circle` flight (seed `seed`), RMS after one
/// alignment of the whole trajectory to the truth (as the ATE), with `damage`: the restart's
/// placement, not just its shape, is scored.
fn error_after_45_s(seed: u64, damage: Damage) -> f64 {
    let (poses, truth) = run_damaged(seed, damage);
    let (rms, n) = position_error_rms_from(
        &poses,
        &truth,
        &EvalOptions::default(),
        Timestamp(45_000_000_000),
    )
    .unwrap()
    .unwrap_or((f64::INFINITY, 0));
    assert!(n > 100, "{n} poses after 45 s");
    rms
}

/// Drops the rows of `imu.csv` strictly inside (from, to), ns.
fn cut_imu(dir: &std::path::Path, from_ns: i64, to_ns: i64) {
    let path = dir.join("imu.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.starts_with('#')
                || l.split(',')
                    .next()
                    .and_then(|t| t.parse::<i64>().ok())
                    .is_none_or(|t| t <= from_ns || t >= to_ns)
        })
        .collect();
    std::fs::write(&path, kept.join("\n") + "\n").unwrap();
}

/// Drops the CSI records of every AP log whose time on the IMU clock is strictly inside
/// (from, to), ns; the other records are kept byte for byte.
fn cut_csi(dir: &std::path::Path, from_ns: i64, to_ns: i64) {
    let manifest: Manifest =
        toml::from_str(&std::fs::read_to_string(dir.join("dataset.toml")).unwrap()).unwrap();
    for ap in &manifest.aps {
        let path = dir.join(&ap.log);
        let data = std::fs::read(&path).unwrap();
        let (mut kept, mut i) = (Vec::new(), 0);
        while i + LEN_FIELD < data.len() {
            let len = usize::from(u16::from_be_bytes([data[i], data[i + 1]]));
            let record = &data[i..i + LEN_FIELD + len];
            let nic_us = u32::from_le_bytes(record[3..7].try_into().unwrap());
            let t = i64::from(nic_us) * 1000 + ap.imu_minus_nic_ns;
            if record[2] != CODE_CSI || t <= from_ns || t >= to_ns {
                kept.extend_from_slice(record);
            }
            i += LEN_FIELD + len;
        }
        std::fs::write(&path, kept).unwrap();
    }
}

/// On each of `seeds`, the error after 45 s with `damage` is within twice the undamaged
/// flight's.
fn comes_back_to_within_twice_the_undamaged(damage: Damage, seeds: &[u64]) {
    comes_back_to_within(damage, seeds, 2.0);
}

/// On each of `seeds`, the error after 45 s with `damage` is within `factor` times the
/// undamaged flight's.
fn comes_back_to_within(damage: Damage, seeds: &[u64], factor: f64) {
    for &seed in seeds {
        let undamaged = error_after_45_s(seed, Damage::None);
        let damaged = error_after_45_s(seed, damage);
        assert!(
            damaged <= factor * undamaged,
            "seed {seed}: {damaged:.3} m after the {damage:?} against {undamaged:.3} m undamaged"
        );
    }
}

/// After a 2 s IMU gap in the middle of the circle (the heading carried across it 30° or more
/// off) the restart is placed by the lost window's AP and the bridge across the gap, and the
/// tracks start over: the error after it comes back to within twice the undamaged flight's
/// (docs/VALIDATION.md has the 32-seed table: 32 of 32 do).
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn after_an_imu_gap_the_error_comes_back_to_within_twice_the_undamaged() {
    comes_back_to_within_twice_the_undamaged(Damage::ImuGap, &[1, 4]);
}

/// After a 5 s IMU gap (the drone flies 150° of the circle unseen) the bridge's jerk terms
/// place the restart, a restarted window whose AP's range disagrees with the lost window's is
/// refused, the new window keeps the AP where the lost one had it and its range to the AP is
/// anchored to the lost window's: of seeds 1–8, at least six come back to within twice the
/// undamaged flight's error. Today six do (seed 5 at 2.3×, seed 6 at 23× do not), with the
/// Intel 5300's measured response; on an ideal receiver 26 of 32 seeds did (docs/VALIDATION.md).
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn after_a_five_second_imu_gap_most_flights_come_back() {
    let mut back = Vec::new();
    for seed in 1..=8 {
        let undamaged = error_after_45_s(seed, Damage::None);
        let damaged = error_after_45_s(seed, Damage::LongImuGap);
        println!("seed {seed}: {damaged:.3} m after the gap against {undamaged:.3} m undamaged");
        if damaged <= 2.0 * undamaged {
            back.push(seed);
        }
    }
    assert!(back.len() >= 6, "back within twice on seeds {back:?}");
}

/// After a 5 s IMU gap the restart's height is placed by the barometer, which ran on through
/// the gap: on seeds 3 and 4 (0.51 and 0.69 m off when the AP's weakly seen height placed it)
/// the mean height error after 45 s, under the alignment of the poses before the gap, is
/// within 0.3 m (the undamaged flights' 90th percentile over 32 seeds is 0.32 m).
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn after_a_five_second_imu_gap_the_barometer_places_the_height() {
    for seed in [3, 4] {
        let (poses, truth) = run_damaged(seed, Damage::LongImuGap);
        let pairs = |keep: &dyn Fn(f64) -> bool| -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
            poses
                .iter()
                .filter(|p| keep(p.t.0 as f64 * 1e-9))
                .filter_map(|p| {
                    let j = truth.partition_point(|q| q.t < p.t).min(truth.len() - 1);
                    Some((p.p_b_in_w, truth.get(j)?.p_b_in_w))
                })
                .unzip()
        };
        let (est, tru) = pairs(&|t| t < 30.0);
        let before = umeyama(&est, &tru).unwrap();
        let (est, tru) = pairs(&|t| t >= 45.0);
        assert!(
            est.len() > 100,
            "seed {seed}: {} poses after 45 s",
            est.len()
        );
        let dz = est
            .iter()
            .zip(&tru)
            .map(|(e, t)| (before.apply_point(e).z - t.z).abs())
            .sum::<f64>()
            / est.len() as f64;
        assert!(dz < 0.3, "seed {seed}: height {dz:.3} m off after the gap");
    }
}

/// After a 6 s CSI outage the track starts over from SpotFi and the state's gate waits for a
/// bearing that agrees with it: without either, the dead-reckoned state's prediction steers the
/// track off the AP and gates the bearings that would correct it, and 5 of 8 flights drift to
/// 4–7 m (docs/VALIDATION.md has the eight-seed table).
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn after_a_csi_outage_the_error_comes_back_to_within_twice_the_undamaged() {
    comes_back_to_within_twice_the_undamaged(Damage::CsiOutage, &[1, 4]);
}

/// A run that ends lost (an IMU gap 7 s before the end leaves no time to be accepted again)
/// keeps the APs of its last converged pose, and says so: before, it kept none.
#[test]
fn a_run_that_ends_lost_keeps_the_aps_of_its_last_converged_pose() {
    let dir = temp_dir("ends-lost");
    let mut s = Scenario::built_in("paper-circle").unwrap().airborne();
    s.duration_s = 45.0;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    cut_imu(&dir, 38_000_000_000, 44_000_000_000);
    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    let truth_text = std::fs::read_to_string(dir.join("truth/poses.tum")).unwrap();
    let truth = read_tum(truth_text.as_bytes()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let warnings = run.warnings.join("\n");
    assert!(
        warnings.contains("the run ends lost: aps.csv holds the APs of the last converged pose"),
        "{warnings}"
    );
    assert_eq!(run.aps.len(), 1, "{:?}", run.aps);
    // The AP is about as far from the last converged pose as the truth's AP from the truth there.
    let last = run.converged_poses().last().copied().unwrap();
    let at = truth.partition_point(|p| p.t < last.t).min(truth.len() - 1);
    let truth_range = (Vector3::from(s.aps[0].position_m) - truth[at].p_b_in_w).norm();
    let range = (run.aps[0].p_in_w - last.p_b_in_w).norm();
    assert!(
        (range - truth_range).abs() < 1.0,
        "{range} m against {truth_range} m"
    );
}
