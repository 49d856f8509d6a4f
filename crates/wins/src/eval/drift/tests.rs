use super::*;
use crate::eval::{EvalOptions, Metrics, evaluate, test_pose};
use nalgebra::{Isometry3, Vector3};

/// Estimated (and truth) pose period, ms: 60 s is not a whole number of periods, so no pose
/// lies on a window's edge and each minute holds `MINUTE_POSES` poses.
const PERIOD_MS: i64 = 70;
/// Poses per turn of the circle (20.02 s); three turns make up `MINUTE_POSES`.
const TURN_POSES: usize = 286;
/// Poses in the first (`t ≤ 60 s`) and in the last (`t ≥ t_last − 60 s`) minute.
const MINUTE_POSES: usize = 858;

/// Three minutes of poses (180.11 s): a 3 m circle, the height oscillating three times per
/// turn, yaw along the circle with a roll wobble and a pitch. Every minute is three whole
/// turns, so each minute's mean position is the flight's mean.
fn truth(poses: usize) -> Vec<Pose> {
    (0..poses)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / TURN_POSES as f64;
            let t_s = (k as i64 * PERIOD_MS) as f64 * 1e-3;
            Pose {
                t: Timestamp(k as i64 * PERIOD_MS * 1_000_000),
                p_b_in_w: Vector3::new(3.0 * a.cos(), 3.0 * a.sin(), 1.5 + 0.4 * (3.0 * a).sin()),
                world_from_body: UnitQuaternion::from_euler_angles(
                    0.2 * (0.3 * t_s).sin(),
                    0.1,
                    a + std::f64::consts::FRAC_PI_2,
                ),
            }
        })
        .collect()
}

fn est_from_truth() -> Isometry3<f64> {
    let q = UnitQuaternion::from_euler_angles(0.0, 0.0, 2.0);
    Isometry3::from_parts(Vector3::new(4.0, -1.0, 0.5).into(), q)
}

/// `truth` with the position offset `offset(k)` and the attitude turned by
/// `Rz(yaw_rate·t)·Rx(roll_error)` in the world, then moved into the estimate's world.
fn estimate(
    truth: &[Pose],
    offset: impl Fn(usize) -> Vector3<f64>,
    yaw_rate_rad_s: f64,
    roll_error_rad: f64,
) -> Vec<Pose> {
    let est_from_truth = Alignment::from_isometry(&est_from_truth());
    (truth.iter().enumerate())
        .map(|(k, p)| {
            let turn = UnitQuaternion::from_euler_angles(
                roll_error_rad,
                0.0,
                yaw_rate_rad_s * p.t.as_secs_f64(),
            );
            est_from_truth.apply_pose(&Pose {
                t: p.t,
                p_b_in_w: p.p_b_in_w + offset(k),
                world_from_body: turn * p.world_from_body,
            })
        })
        .collect()
}

fn run(est: &[Pose], truth: &[Pose]) -> Metrics {
    evaluate(est, truth, &[], &[], &EvalOptions::default()).expect("metrics")
}

#[test]
fn drift_is_the_last_minutes_error_under_the_first_minutes_alignment() {
    // Offsets 0, a, d over the three minutes. Each minute's mean position is the flight's,
    // so the offsets are uncorrelated with the positions: the global alignment undoes the
    // rigid move and shifts by −ē, ē = (a + d)/3; the first minute's alignment undoes the
    // rigid move alone.
    let truth = truth(3 * MINUTE_POSES);
    let (a, d) = (Vector3::new(0.1, -0.1, 0.05), Vector3::new(0.5, 0.3, -0.2));
    let offset = |k: usize| match k / MINUTE_POSES {
        0 => Vector3::zeros(),
        1 => a,
        _ => d,
    };
    let m = run(&estimate(&truth, offset, 0.0, 0.0), &truth);
    let e_mean = (a + d) / 3.0;
    let minutes = [-e_mean, a - e_mean, d - e_mean];
    let ate = (minutes.iter().map(|e| e.norm_squared()).sum::<f64>() / 3.0).sqrt();
    assert!(
        (m.ate_rmse_m - ate).abs() < 1e-9,
        "{} vs {ate}",
        m.ate_rmse_m
    );
    let last = (d - e_mean).norm();
    let got = m.position_error_last_60s_rmse_m;
    assert!((got - last).abs() < 1e-9, "{got} vs {last}");
    let drift = m
        .drift_last_60s_m
        .expect("a three-minute flight has a drift");
    assert!((drift - d.norm()).abs() < 1e-9, "{drift} vs {}", d.norm());
    // A pose moves at most 1.01 m/s · 70 ms = 0.071 m: the step by a (0.15 m) stays under
    // 0.3 m, the step by d − a (0.62 m) does not.
    assert_eq!(m.jumps, 1);
    assert!(m.heading_drift_deg_per_min.abs() < 1e-9);
    let report = m.report();
    assert!(
        report.contains(&format!("first 60 s {drift:.4} m")),
        "{report}"
    );
    assert!(report.contains("1 jumps > 0.3 m"), "{report}");
}

#[test]
fn heading_drift_is_the_slope_of_the_unwrapped_yaw_error() {
    // 4°/s of yaw error about the world vertical turns twice in three minutes; a constant
    // 3° roll error about the world x does not change the heading error.
    let truth = truth(3 * MINUTE_POSES);
    let rate_deg_s: f64 = 4.0;
    let est = estimate(
        &truth,
        |_| Vector3::zeros(),
        rate_deg_s.to_radians(),
        3f64.to_radians(),
    );
    let m = run(&est, &truth);
    let expected = rate_deg_s * 60.0;
    let got = m.heading_drift_deg_per_min;
    assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
    // Positions untouched: no error, no drift, no jump.
    assert!(m.ate_rmse_m < 1e-9 && m.drift_last_60s_m.is_some_and(|d| d < 1e-9));
    assert_eq!(m.jumps, 0);
    // Turning the other way halves nothing: the sign follows the turn.
    let est = estimate(&truth, |_| Vector3::zeros(), -0.5f64.to_radians(), 0.0);
    let got = run(&est, &truth).heading_drift_deg_per_min;
    assert!((got + 30.0).abs() < 1e-9, "{got}");
}

#[test]
fn the_drift_needs_two_minutes_that_fix_an_alignment() {
    // 1700 poses span 118.93 s: the first and last minutes overlap.
    let short = truth(1700);
    let d = Vector3::new(0.2, 0.0, 0.0);
    let offset = |k: usize| {
        if k >= 1700 - MINUTE_POSES / 3 {
            d
        } else {
            Vector3::zeros()
        }
    };
    let m = run(&estimate(&short, offset, 0.0, 0.0), &short);
    assert_eq!(m.drift_last_60s_m, None);
    assert!(m.report().contains("n/a (under 120 s)"), "{}", m.report());
    // The last-minute error is still computed: larger than the ATE, whose other poses err less.
    assert!(m.position_error_last_60s_rmse_m > m.ate_rmse_m);
    // Three minutes whose first one climbs straight up (no heading in the positions): the
    // attitudes fix the first minute's alignment ...
    let mut line = truth(3 * MINUTE_POSES);
    for p in &mut line[..MINUTE_POSES + 10] {
        p.p_b_in_w = Vector3::new(0.0, 3.0, 1.0 + 0.01 * p.t.as_secs_f64());
    }
    let m = run(&estimate(&line, |_| Vector3::zeros(), 0.0, 0.0), &line);
    assert!(m.drift_last_60s_m.is_some_and(|d| d < 1e-9), "{m:?}");
    // ... unless they disagree too (every other one a half turn off): then nothing does.
    let mut torn = estimate(&line, |_| Vector3::zeros(), 0.0, 0.0);
    for (k, p) in torn[..MINUTE_POSES + 10].iter_mut().enumerate() {
        let half_turn = UnitQuaternion::from_axis_angle(
            &Vector3::z_axis(),
            std::f64::consts::PI * (k % 2) as f64,
        );
        p.world_from_body = half_turn * p.world_from_body;
    }
    let m = run(&torn, &line);
    assert_eq!(m.drift_last_60s_m, None);
    assert!(m.ate_rmse_m < 1e-9);
    assert!(
        m.report().contains("cannot fix an alignment"),
        "{}",
        m.report()
    );
    // Under a minute, the last minute is the whole flight.
    let tiny = truth(TURN_POSES);
    let m = run(&estimate(&tiny, |k| d * (k % 2) as f64, 0.0, 0.0), &tiny);
    assert_eq!(m.position_error_last_60s_rmse_m, m.ate_rmse_m);
}

#[test]
fn jumps_are_steps_of_more_than_0_3_m() {
    let at = |k: i64, x: f64, y: f64, z: f64| test_pose(10 * k, Vector3::new(x, y, z), 0.0);
    let est = [
        at(0, 0.0, 0.0, 0.0),
        at(1, 0.1, 0.0, 0.0),
        at(2, 0.1, 0.5, 0.0), // 0.5 m: a jump
        at(3, 0.2, 0.0, 0.0), // 0.51 m back: a jump
        at(4, 0.3, 0.0, 0.0),
        at(5, 0.6, 0.0, 0.0), // exactly 0.3 m: not more than the threshold
        at(6, 0.6, 0.25, 0.0),
        at(7, 0.6, 0.25, 0.4), // 0.4 m: a jump
    ];
    assert_eq!((est[5].p_b_in_w - est[4].p_b_in_w).norm(), JUMP_THRESHOLD_M);
    assert_eq!(count_jumps(&est), 3);
    assert_eq!(count_jumps(&est[..2]), 0);
    assert_eq!(count_jumps(&[]), 0);
}

#[test]
fn heading_error_is_the_yaw_about_the_world_vertical() {
    let truth_attitudes = [
        UnitQuaternion::identity(),
        UnitQuaternion::from_euler_angles(0.4, -0.3, 2.5),
        UnitQuaternion::from_euler_angles(-1.2, 0.8, -0.7),
    ];
    for q_truth in truth_attitudes {
        for delta_deg in [-179.0, -30.0, 0.0, 12.5, 179.0] {
            // Any roll and pitch of the error rotation about the world axes (ZYX order).
            for (roll, pitch) in [(0.0, 0.0), (0.1, 0.0), (0.0, -0.2), (0.3, 0.25)] {
                let delta = f64::to_radians(delta_deg);
                let err = UnitQuaternion::from_euler_angles(roll, pitch, delta);
                let got = heading_error_rad(&q_truth, &(err * q_truth));
                assert!((got - delta).abs() < 1e-12, "{got} vs {delta}");
            }
        }
    }
}

#[test]
fn unwrap_and_slope_recover_a_line() {
    // A heading error growing 0.3 rad per step to 20 rad, seen wrapped into (−π, π].
    let ramp: Vec<f64> = (0..70).map(|k| 0.5 + 0.3 * k as f64).collect();
    let wrapped: Vec<f64> = ramp.iter().map(|a| a.sin().atan2(a.cos())).collect();
    let unwrapped = unwrap_rad(&wrapped);
    for (u, r) in unwrapped.iter().zip(&ramp) {
        assert!((u - r).abs() < 1e-12, "{u} vs {r}");
    }
    // y = 2 + 3t plus residuals with zero mean and no correlation with t: slope 3.
    let t = [0.0, 1.0, 2.0, 3.0, 4.0];
    let residual = [1.0, -1.0, 0.0, -1.0, 1.0];
    let y: Vec<f64> = t
        .iter()
        .zip(residual)
        .map(|(t, r)| 2.0 + 3.0 * t + r)
        .collect();
    assert!((least_squares_slope(&t, &y) - 3.0).abs() < 1e-12);
    assert_eq!(least_squares_slope(&[1.0], &[5.0]), 0.0);
    assert_eq!(least_squares_slope(&[1.0, 1.0], &[5.0, 6.0]), 0.0);
}

#[test]
fn older_metrics_json_reads_with_defaults() {
    let truth = truth(3 * MINUTE_POSES);
    let est = estimate(
        &truth,
        |k| Vector3::new(0.0, 0.0, 0.4) * (k / 1000) as f64,
        0.01,
        0.0,
    );
    let m = run(&est, &truth);
    assert!(m.jumps == 2 && m.drift_last_60s_m.is_some() && m.heading_drift_deg_per_min != 0.0);
    let mut v = serde_json::to_value(&m).expect("json");
    let new_keys = [
        "position_error_last_60s_rmse_m",
        "drift_last_60s_m",
        "heading_drift_deg_per_min",
        "jumps",
    ];
    let object = v.as_object_mut().expect("an object");
    for key in new_keys {
        assert!(object.remove(key).is_some(), "{key} missing");
    }
    let old: Metrics = serde_json::from_value(v).expect("an older file reads");
    let expected = Metrics {
        position_error_last_60s_rmse_m: 0.0,
        drift_last_60s_m: None,
        heading_drift_deg_per_min: 0.0,
        jumps: 0,
        ..m
    };
    assert_eq!(old, expected);
}
