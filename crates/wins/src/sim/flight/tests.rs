//! Tests of `flight` and `waypoints`.

use super::*;
use crate::sim::kinematics::{septic, smooth_step};
use crate::sim::trajectory::TrajectoryConfig;

fn loop_config() -> TrajectoryConfig {
    crate::sim::waypoints::example_loop()
}

fn phased_circle() -> Flight {
    let phases = PhasesConfig::default();
    Flight::with_phases(TrajectoryConfig::default().build(0, 60.0), &phases, 60.0)
}

/// Central differences of p, v, a against v, a, j of `at` at `t`.
fn assert_exact_derivatives(at: &dyn Fn(f64) -> Translation, t: f64, tol: f64) {
    let h = 1e-5;
    let (lo, mid, hi) = (at(t - h), at(t), at(t + h));
    let fd = |a: Vector3<f64>, b: Vector3<f64>| (b - a) / (2.0 * h);
    for (name, numeric, exact) in [
        ("v", fd(lo.p_b_in_w, hi.p_b_in_w), mid.v_b_in_w),
        ("a", fd(lo.v_b_in_w, hi.v_b_in_w), mid.a_b_in_w),
        ("j", fd(lo.a_b_in_w, hi.a_b_in_w), mid.j_b_in_w),
    ] {
        let err = (numeric - exact).norm();
        assert!(err < tol, "t={t}: {name} {numeric:?} vs {exact:?} ({err})");
    }
}

#[test]
fn polynomials_have_their_stated_derivatives_and_end_values() {
    let h = 1e-6;
    for i in 1..100 {
        let x = i as f64 / 100.0;
        for f in [septic, smooth_step] {
            let (lo, mid, hi) = (f(x - h), f(x), f(x + h));
            for k in 0..3 {
                let numeric = (hi[k] - lo[k]) / (2.0 * h);
                assert!((numeric - mid[k + 1]).abs() < 1e-6, "x={x} k={k}");
            }
        }
    }
    assert_eq!(septic(0.0), [0.0; 4]);
    let end = septic(1.0);
    assert!((end[0] - 1.0).abs() < 1e-12 && end[1..].iter().all(|d| d.abs() < 1e-12));
    assert_eq!(smooth_step(0.0), [0.0; 4]);
    assert_eq!(smooth_step(1.0), [0.5, 1.0, 0.0, 0.0]);
    // Inside, the step's integral reaches 1/2 at 1 continuously.
    assert!((smooth_step(1.0 - 1e-9)[0] - 0.5).abs() < 1e-8);
}

#[test]
fn phased_flight_is_continuous_to_the_jerk_at_every_join() {
    let flight = phased_circle();
    let at = |t: f64| flight.at(t).translation;
    // Joins: take-off 3 s, mission 7 s, cruise 10 s and 51 s, landing 54 s, rest 58 s.
    for join in [3.0, 7.0, 10.0, 51.0, 54.0, 58.0] {
        let (before, after) = (at(join - 1e-9), at(join + 1e-9));
        for (a, b) in [
            (before.p_b_in_w, after.p_b_in_w),
            (before.v_b_in_w, after.v_b_in_w),
            (before.a_b_in_w, after.a_b_in_w),
            (before.j_b_in_w, after.j_b_in_w),
        ] {
            assert!((a - b).norm() < 1e-6, "join {join}: {a:?} vs {b:?}");
        }
    }
    for i in 0..600 {
        assert_exact_derivatives(&at, 0.1 * i as f64 + 0.013, 1e-4);
    }
}

#[test]
fn phases_start_and_end_on_the_ground_below_the_mission() {
    let flight = phased_circle();
    let start = flight.at(0.0);
    // The circle starts at angle 0: (8.5, 4, 1.5); the ground is 0.1 m.
    assert!((start.translation.p_b_in_w - Vector3::new(8.5, 4.0, 0.1)).norm() < 1e-12);
    assert!((flight.at(7.0).translation.p_b_in_w - Vector3::new(8.5, 4.0, 1.5)).norm() < 1e-12);
    let end = flight.at(60.0).translation;
    let s_end = flight.mission_end_s().unwrap();
    assert!(
        (s_end - 44.0).abs() < 1e-12,
        "mission 47 s minus one ramp: {s_end}"
    );
    let last = TrajectoryConfig::default()
        .build(0, 60.0)
        .at(s_end)
        .p_b_in_w;
    assert!((end.p_b_in_w - Vector3::new(last.x, last.y, 0.1)).norm() < 1e-12);
    assert_eq!(end.v_b_in_w, Vector3::zeros());
    // The cruise flies the mission at its own speed.
    let cruise = flight.at(30.0);
    assert_eq!(cruise.mission_rate, 1.0);
    assert!((cruise.translation.v_b_in_w.norm() - 1.27).abs() < 1e-12);
}

#[test]
fn validation_names_the_field() {
    let ok = PhasesConfig::default();
    assert!(ok.validate("phases", 60.0).is_ok());
    let e = ok.validate("phases", 15.0).unwrap_err();
    assert_eq!(e.field, "phases.ramp_s");
    let bad = PhasesConfig {
        takeoff_s: 0.0,
        ..PhasesConfig::default()
    };
    assert_eq!(
        bad.validate("phases", 60.0).unwrap_err().field,
        "phases.takeoff_s"
    );
    let nan = PhasesConfig {
        rest_s: f64::NAN,
        ..PhasesConfig::default()
    };
    assert_eq!(
        nan.validate("phases", 60.0).unwrap_err().field,
        "phases.rest_s"
    );
}

#[test]
fn waypoint_loop_has_exact_derivatives_and_rejoins_the_polyline() {
    let config = loop_config();
    config.validate("trajectory").unwrap();
    let path = config.build(0, 200.0);
    let at = |s: f64| path.at(s);
    for i in 0..400 {
        assert_exact_derivatives(&at, 0.37 * i as f64 + 0.01, 1e-4);
    }
    // Corners of 2 s at 1.5 m/s start 1.5 m before a waypoint: midway along the 7 m first leg
    // (s = 2.339 s) the path is on the polyline at cruise speed.
    let leg0 = Vector3::new(7.0, 0.0, 0.5);
    let s_mid = leg0.norm() / 1.5 / 2.0;
    let mid = path.at(s_mid);
    assert!((mid.p_b_in_w - (Vector3::new(2.0, 2.0, 1.5) + leg0 / 2.0)).norm() < 1e-12);
    assert!((mid.v_b_in_w.norm() - 1.5).abs() < 1e-12);
    // One loop later it is there again.
    let TrajectoryConfig::Waypoints { points_m, .. } = &config else {
        unreachable!()
    };
    let perimeter_m: f64 = (0..4)
        .map(|k| (Vector3::from(points_m[(k + 1) % 4]) - Vector3::from(points_m[k])).norm())
        .sum();
    let again = path.at(s_mid + perimeter_m / 1.5);
    assert!(
        (again.p_b_in_w - mid.p_b_in_w).norm() < 1e-9,
        "{:?}",
        again.p_b_in_w
    );
    // Corners slow down and never exceed the cruise speed.
    for i in 0..2000 {
        assert!(path.at(0.1 * i as f64).v_b_in_w.norm() <= 1.5 + 1e-12);
    }
    assert!(path.acceleration_bound_m_s2() > 0.0);
}

#[test]
fn waypoint_validation_rejects_what_cannot_be_flown() {
    let check = |points: Vec<[f64; 3]>, speed: f64, corner: f64| {
        TrajectoryConfig::Waypoints {
            points_m: points,
            speed_m_s: speed,
            corner_s: corner,
        }
        .validate("trajectory")
    };
    let square = vec![
        [1.0, 1.0, 1.0],
        [5.0, 1.0, 1.0],
        [5.0, 5.0, 1.0],
        [1.0, 5.0, 1.0],
    ];
    assert!(check(square.clone(), 1.0, 2.0).is_ok());
    assert_eq!(
        check(square[..2].to_vec(), 1.0, 2.0).unwrap_err().field,
        "trajectory.points_m"
    );
    // 4 m legs at 1 m/s cannot hold 5 s corners.
    let e = check(square.clone(), 1.0, 5.0).unwrap_err();
    assert!(e.reason.contains("corners would overlap"), "{e}");
    assert_eq!(
        check(square.clone(), 0.0, 2.0).unwrap_err().field,
        "trajectory.speed_m_s"
    );
    let mut nan = square;
    nan[2][1] = f64::NAN;
    assert_eq!(
        check(nan, 1.0, 2.0).unwrap_err().field,
        "trajectory.points_m"
    );
}
