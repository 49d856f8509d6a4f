//! Tests of `trajectory`.

use super::*;

fn paper_circle() -> TrajectoryConfig {
    TrajectoryConfig::Circle {
        center_m: [6.0, 4.0, 1.5],
        radius_m: 2.5,
        speed_m_s: 1.27,
        start_angle_deg: 30.0,
        clockwise: true,
    }
}

fn figure_eight() -> TrajectoryConfig {
    TrajectoryConfig::FigureEight {
        center_m: [5.0, 5.0, 1.2],
        half_length_m: 3.0,
        half_width_m: 1.5,
        period_s: 20.0,
    }
}

fn random() -> TrajectoryConfig {
    TrajectoryConfig::RandomSmooth {
        bounds_min_m: [1.0, 2.0, 0.5],
        bounds_max_m: [9.0, 8.0, 2.5],
        max_speed_m_s: 1.5,
        num_harmonics: 5,
        min_period_s: 5.0,
        max_period_s: 40.0,
    }
}

fn all_kinds() -> Vec<TrajectoryConfig> {
    vec![
        paper_circle(),
        figure_eight(),
        random(),
        TrajectoryConfig::Hover {
            position_m: [1.0, 2.0, 3.0],
        },
    ]
}

#[test]
fn derivatives_match_central_differences() {
    let h = 1e-4;
    for config in all_kinds() {
        config.validate("trajectory").unwrap();
        let traj = config.build(7, 200.0);
        for &t in &[0.0, 0.37, 3.1, 17.9, 123.4] {
            let (lo, mid, hi) = (traj.at(t - h), traj.at(t), traj.at(t + h));
            let fd = |a: Vector3<f64>, b: Vector3<f64>| (b - a) / (2.0 * h);
            let pairs = [
                (fd(lo.p_b_in_w, hi.p_b_in_w), mid.v_b_in_w),
                (fd(lo.v_b_in_w, hi.v_b_in_w), mid.a_b_in_w),
                (fd(lo.a_b_in_w, hi.a_b_in_w), mid.j_b_in_w),
            ];
            for (i, (numeric, exact)) in pairs.iter().enumerate() {
                let err = (numeric - exact).norm();
                assert!(err < 1e-7, "{config:?} t={t} derivative {i}: error {err}");
            }
        }
    }
}

#[test]
fn circle_keeps_radius_speed_height_and_direction() {
    let traj = paper_circle().build(0, 200.0);
    let center = Vector3::new(6.0, 4.0, 1.5);
    let start = traj.at(0.0).p_b_in_w - center;
    assert!((start.y.atan2(start.x) - 30f64.to_radians()).abs() < 1e-12);
    for i in 0..500 {
        let t = 0.1 * i as f64;
        let tr = traj.at(t);
        let d = tr.p_b_in_w - center;
        assert!((d.xy().norm() - 2.5).abs() < 1e-12);
        assert!(d.z.abs() < 1e-12);
        assert!((tr.v_b_in_w.norm() - 1.27).abs() < 1e-12);
        assert!(tr.v_b_in_w.z.abs() < 1e-12);
        // Centripetal acceleration v²/r toward the centre.
        let a_expected = -d * (1.27 * 1.27 / 2.5 / 2.5);
        assert!((tr.a_b_in_w - a_expected).norm() < 1e-12);
        // Clockwise from above: angular momentum along −z.
        assert!(d.cross(&tr.v_b_in_w).z < 0.0);
    }
}

#[test]
fn figure_eight_shape() {
    let traj = figure_eight().build(0, 200.0);
    assert!((traj.at(0.0).p_b_in_w - Vector3::new(5.0, 5.0, 1.2)).norm() < 1e-12);
    assert!((traj.at(5.0).p_b_in_w - Vector3::new(8.0, 5.0, 1.2)).norm() < 1e-12);
    assert!((traj.at(2.5).p_b_in_w.y - 6.5).abs() < 1e-12);
    assert!((traj.at(20.0).p_b_in_w - traj.at(0.0).p_b_in_w).norm() < 1e-12);
    let min_speed = (0..2000)
        .map(|i| traj.at(0.01 * i as f64).v_b_in_w.norm())
        .fold(f64::INFINITY, f64::min);
    assert!(min_speed > 0.1, "speed dips to {min_speed}");
}

#[test]
fn random_flight_stays_in_bounds_and_below_max_speed() {
    let config = random();
    for seed in [1, 2, 3] {
        let traj = config.build(seed, 200.0);
        let mut max_speed = 0.0_f64;
        for i in 0..=300_000 {
            let tr = traj.at(1e-3 * i as f64);
            let p = tr.p_b_in_w;
            assert!((1.0..=9.0).contains(&p.x), "seed {seed}: {p:?}");
            assert!((2.0..=8.0).contains(&p.y), "seed {seed}: {p:?}");
            assert!((0.5..=2.5).contains(&p.z), "seed {seed}: {p:?}");
            max_speed = max_speed.max(tr.v_b_in_w.norm());
        }
        assert!(max_speed <= 1.5, "seed {seed}: speed {max_speed}");
        // Not degenerate: it actually moves.
        assert!(max_speed > 0.3, "seed {seed}: speed {max_speed}");
        assert!(traj.speed_bound_m_s() <= 1.5 + 1e-12);
    }
}

#[test]
fn random_flight_is_reproducible_and_seed_dependent() {
    let config = random();
    let (a, b, c) = (
        config.build(42, 200.0),
        config.build(42, 200.0),
        config.build(43, 200.0),
    );
    for &t in &[0.0, 1.0, 77.7] {
        assert_eq!(a.at(t), b.at(t));
        assert!((a.at(t).p_b_in_w - c.at(t).p_b_in_w).norm() > 1e-3);
    }
}

#[test]
fn planar_random_flight_keeps_height() {
    let config = TrajectoryConfig::RandomSmooth {
        bounds_min_m: [0.0, 0.0, 1.5],
        bounds_max_m: [4.0, 4.0, 1.5],
        max_speed_m_s: 1.0,
        num_harmonics: 3,
        min_period_s: 10.0,
        max_period_s: 10.0,
    };
    config.validate("trajectory").unwrap();
    let traj = config.build(5, 200.0);
    for i in 0..100 {
        let tr = traj.at(i as f64 * 0.77);
        assert_eq!(tr.p_b_in_w.z, 1.5);
        assert_eq!(tr.v_b_in_w.z, 0.0);
    }
}

#[test]
fn hover_has_zero_derivatives() {
    let traj = TrajectoryConfig::Hover {
        position_m: [1.0, 2.0, 3.0],
    }
    .build(0, 200.0);
    for &t in &[0.0, 5.0, 1e4] {
        let tr = traj.at(t);
        assert_eq!(tr.p_b_in_w, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(tr.v_b_in_w, Vector3::zeros());
        assert_eq!(tr.a_b_in_w, Vector3::zeros());
        assert_eq!(tr.j_b_in_w, Vector3::zeros());
    }
    assert_eq!(traj.speed_bound_m_s(), 0.0);
}

#[test]
fn bounds_hold() {
    for config in all_kinds() {
        let traj = config.build(3, 200.0);
        let (vb, ab) = (traj.speed_bound_m_s(), traj.acceleration_bound_m_s2());
        for i in 0..5000 {
            let tr = traj.at(0.05 * i as f64);
            assert!(tr.v_b_in_w.norm() <= vb + 1e-12);
            assert!(tr.a_b_in_w.norm() <= ab + 1e-12);
        }
    }
}

#[test]
fn validate_rejects_bad_values() {
    let bad = [
        TrajectoryConfig::Circle {
            center_m: [0.0, 0.0, f64::NAN],
            radius_m: 1.0,
            speed_m_s: 1.0,
            start_angle_deg: 0.0,
            clockwise: false,
        },
        TrajectoryConfig::Circle {
            center_m: [0.0; 3],
            radius_m: 0.0,
            speed_m_s: 1.0,
            start_angle_deg: 0.0,
            clockwise: false,
        },
        TrajectoryConfig::FigureEight {
            center_m: [0.0; 3],
            half_length_m: 1.0,
            half_width_m: 1.0,
            period_s: -1.0,
        },
        TrajectoryConfig::RandomSmooth {
            bounds_min_m: [0.0; 3],
            bounds_max_m: [1.0, -1.0, 1.0],
            max_speed_m_s: 1.0,
            num_harmonics: 3,
            min_period_s: 1.0,
            max_period_s: 2.0,
        },
        TrajectoryConfig::RandomSmooth {
            bounds_min_m: [0.0; 3],
            bounds_max_m: [1.0; 3],
            max_speed_m_s: 1.0,
            num_harmonics: 0,
            min_period_s: 1.0,
            max_period_s: 2.0,
        },
        TrajectoryConfig::RandomSmooth {
            bounds_min_m: [0.0; 3],
            bounds_max_m: [1.0; 3],
            max_speed_m_s: 1.0,
            num_harmonics: 3,
            min_period_s: 3.0,
            max_period_s: 2.0,
        },
        TrajectoryConfig::Hover {
            position_m: [f64::INFINITY, 0.0, 0.0],
        },
    ];
    for config in bad {
        let err = config.validate("trajectory").unwrap_err();
        assert!(err.field.starts_with("trajectory."), "{err}");
    }
    for config in all_kinds() {
        config.validate("trajectory").unwrap();
    }
    TrajectoryConfig::default().validate("t").unwrap();
}

#[test]
fn toml_round_trip_and_unknown_fields_rejected() {
    let text = r#"
        kind = "figure-eight"
        center_m = [5.0, 5.0, 1.2]
        half_length_m = 3.0
        half_width_m = 1.5
        period_s = 20.0
    "#;
    let parsed: TrajectoryConfig = toml::from_str(text).unwrap();
    assert_eq!(parsed, figure_eight());
    for config in all_kinds() {
        let back: TrajectoryConfig = toml::from_str(&toml::to_string(&config).unwrap()).unwrap();
        assert_eq!(back, config);
    }
    let misspelt = text.replace("period_s", "periode_s");
    assert!(toml::from_str::<TrajectoryConfig>(&misspelt).is_err());
    let extra = format!("{text}\nspeed_m_s = 1.0\n");
    assert!(toml::from_str::<TrajectoryConfig>(&extra).is_err());
}
