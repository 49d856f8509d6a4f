//! The default estimator on flights beyond the paper's: a busy AP, and a run without the
//! barometer.

use wins::Config;
use wins::sim::{Scenario, simulate, write_dataset};

use crate::pipeline_run::{median, metrics_over_seeds, worst};

/// One AP heard at 10 packets/s (it is busy with other clients), from the ground, 60 s, seeds
/// 1–3. The tracks learn the translation part of the angle's change, so the PAoA window keeps on
/// the AP between packets 0.1 s apart (without it a third of the packets fell outside the window
/// and no seed converged). Today, with the built-ins' rotor vibration: every seed converges at
/// 10.5–12.9 s, position mean 0.52–0.75 m (median 0.72). Bounds: every seed converges, the
/// median +20 %, the worst run +50 %, the latest convergence +20 %.
#[test]
fn nonlinear_busy_ap_converges_over_three_seeds() {
    let runs = metrics_over_seeds("busy-ap", 60.0, &[1, 2, 3], false, &Config::default());
    let position = median(&runs, |m| m.position_error_mean_m);
    assert!(position <= 0.87, "median position {position} m");
    let worst_position = worst(&runs, |m| m.position_error_mean_m);
    assert!(worst_position <= 1.12, "worst position {worst_position} m");
    let converged = worst(&runs, |m| m.convergence_time_s);
    assert!(converged <= 15.5, "latest convergence {converged} s");
}

/// `use_barometer = false` runs on the cones and the IMU alone and says so in the warnings; the
/// paper's flight still converges without it (today position mean 1.41 m on seed 1, 40 s, with
/// the built-ins' rotor vibration; bound +20 %).
#[test]
fn without_the_barometer_the_run_says_so_and_converges() {
    let dir = std::env::temp_dir().join(format!("wins-it-no-baro-{}", std::process::id()));
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.duration_s = 40.0;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    let mut config = Config::default();
    config.pipeline.use_barometer = false;
    let without = wins::run_dataset(&dir, &config).unwrap();
    let with = wins::run_dataset(&dir, &Config::default()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        without
            .warnings
            .iter()
            .any(|w| w.contains("barometer") && w.contains("not used")),
        "{:?}",
        without.warnings
    );
    assert!(!with.warnings.iter().any(|w| w.contains("barometer")));
    let error = without.metrics.as_ref().map(|m| m.position_error_mean_m);
    assert!(error.is_some_and(|e| e < 1.69), "{error:?}");
}

/// Room flights 36 and 40 (three APs, bearings within 2.3°) are accepted with one AP placed.
/// With the other two triangulated only from the bearings that have left the window, they ran
/// on the one alone while the others were fed at 30 bearings per second, and were lost when its
/// bearings were gated: 0 poses sent on both. The default triangulates them from the window's
/// own bearings too (docs/ESTIMATOR.md, "APs placed from the window's own bearings").
/// Bounds: at least 1000 poses on 36 at most 0.47 m (0.39 m today, +20 %; the bound was 0.35 m
/// before the simulator carried the Intel 5300's measured response), and poses sent on 40.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn aps_the_start_left_out_are_placed_from_the_windows_bearings() {
    let sent = |seed: u64| {
        let dir =
            std::env::temp_dir().join(format!("wins-it-late-ap-{seed}-{}", std::process::id()));
        let draw = wins::sim::family::Family::Room.draw(seed).unwrap();
        let s = draw.with_overrides(Some(60.0), false).unwrap().scenario;
        let out = simulate(&s, &mut |_| {}).unwrap();
        write_dataset(&dir, &s, &out).unwrap();
        let config = Config::default();
        assert!(config.nonlinear.late_aps_from_window, "the default");
        let run = wins::run_dataset(&dir, &config).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let m = run.metrics.expect("the flight has its truth");
        (m.sent.poses, m.sent.ate_rmse_m)
    };
    let (poses, ate) = sent(36);
    assert!(
        poses >= 1000 && ate.is_some_and(|a| a <= 0.47),
        "seed 36: {poses} poses, {ate:?}"
    );
    let (poses, _) = sent(40);
    assert!(poses > 0, "seed 40: no pose sent");
}

/// Room flight 3 carries a consumer IMU whose accelerometer reads 0.30 m/s² more than gravity
/// on the ground (its turn-on bias along gravity, 1.5 σ of the datasheet's 0.2 m/s²). The rest
/// test compared the means with an ideal sensor's, so the 3 s on the ground were never a rest:
/// motion was declared at the first sample and the start was left to the airborne solver,
/// which never converged. The rest test now allows the biases the datasheet states, and the
/// motion is found at the take-off (3 s).
#[test]
fn a_consumer_imus_biased_rest_is_found_before_its_take_off() {
    let dir = std::env::temp_dir().join(format!("wins-it-biased-rest-{}", std::process::id()));
    let draw = wins::sim::family::Family::Room.draw(3).unwrap();
    let s = draw.with_overrides(Some(20.0), false).unwrap().scenario;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(&dir, &s, &out).unwrap();
    let biases = std::fs::read_to_string(dir.join("truth/imu_biases.csv")).unwrap();
    let first: Vec<f64> = biases
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    // The flight is still the one described: its bias along gravity (z, level on the ground).
    assert!(
        first[6] > 0.25,
        "accelerometer bias along gravity {}",
        first[6]
    );
    let motion = run
        .phases
        .iter()
        .find(|p| p.reason == wins::fusion::nonlinear::Reason::Motion)
        .and_then(|p| p.t_s);
    assert!(
        motion.is_some_and(|t| (2.9..3.5).contains(&t)),
        "motion declared at {motion:?} s"
    );
}
