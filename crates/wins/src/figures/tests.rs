use std::path::PathBuf;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::*;
use crate::dataset::truth::{ApRow, PacketRow, write_tum};
use crate::time::Timestamp;

fn pose(t_s: f64, x: f64, y: f64, yaw_deg: f64) -> Pose {
    Pose {
        t: Timestamp((t_s * 1e9).round() as i64),
        p_b_in_w: Vector3::new(x, y, 1.5),
        world_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians()),
    }
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-figures-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A run folder by hand: poses every 0.1 s on a circle with a 3 s hole, one AP with a
/// covariance, four packets, and the phases of a run lost and accepted again.
fn run_folder(name: &str) -> (PathBuf, Vec<Pose>) {
    let dir = temp_dir(name);
    let poses: Vec<Pose> = (0..100)
        .filter(|i| !(40..70).contains(i))
        .map(|i| {
            let a = i as f64 * 0.1;
            pose(
                10.0 + i as f64 * 0.1,
                a.cos(),
                a.sin(),
                170.0 + 2.0 * i as f64,
            )
        })
        .collect();
    let mut tum = Vec::new();
    write_tum(&mut tum, &poses).unwrap();
    std::fs::write(dir.join("trajectory.tum"), tum).unwrap();
    let mut cov = String::from("t_s,c_x_x,c_x_y,c_x_z,c_y_y,c_y_z,c_z_z\n");
    for p in &poses {
        cov.push_str(&format!("{:.9},0.04,0,0,0.01,0,0.09\n", p.t.as_secs_f64()));
    }
    std::fs::write(dir.join("covariance.csv"), cov).unwrap();
    std::fs::write(
        dir.join("aps.csv"),
        "name,x_m,y_m,z_m,c_x_x,c_x_y,c_x_z,c_y_y,c_y_z,c_z_z\nap0,5,0,1.5,4,0,0,1,0,1\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("aoa.csv"),
        "ap,t_ns,status,reason,predicted_aoa_deg,aoa_deg\n\
         0,10000000000,acquisition,,,\n\
         0,10100000000,fed,,1.0,2.0\n\
         0,10200000000,gated,,1.0,30.0\n\
         0,10300000000,no_credible_peak,,3.0,\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("stats.json"),
        r#"{"converged_at_s": 10.0, "packets": {"per_ap": [{"name": "ap0"}]},
            "phases": [{"phase": "at_rest", "t_s": null}, {"phase": "starting", "t_s": 3.0},
                       {"phase": "tracking", "t_s": 10.0}, {"phase": "recovering", "t_s": 14.0},
                       {"phase": "tracking", "t_s": 17.0}]}"#,
    )
    .unwrap();
    (dir, poses)
}

fn finite(points: &[(f64, f64)]) -> usize {
    points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .count()
}

#[test]
fn a_run_without_truth_has_its_gaps_aps_packets_and_events() {
    let (dir, poses) = run_folder("alone");
    let fig = RunFigures::from_files(
        &dir.join("trajectory.tum"),
        None,
        None,
        &EvalOptions::default(),
    )
    .unwrap();
    // The 3 s hole is one gap in each series over time, and on the map.
    for series in [
        &fig.track_xy,
        &fig.height,
        &fig.attitude_deg[0],
        &fig.sigma_m[0],
    ] {
        assert_eq!(finite(series), poses.len());
        assert_eq!(series.len() - poses.len(), 1, "one gap");
    }
    // σ is the square root of the covariance's diagonal.
    let sigmas: Vec<f64> = (0..3).map(|k| fig.sigma_m[k][0].1).collect();
    assert!((sigmas[0] - 0.2).abs() < 1e-12 && (sigmas[1] - 0.1).abs() < 1e-12);
    assert!((sigmas[2] - 0.3).abs() < 1e-12);
    // Yaw from 170° turns past 180°: broken where it wraps, besides the hole.
    assert!(fig.attitude_deg[2].len() >= poses.len() + 2);
    // The AP's 2σ ellipse reaches 2σ = 4 m along x and 2 m along y.
    let ap = &fig.aps[0];
    assert_eq!((ap.name.as_str(), ap.xy), ("ap0", (5.0, 0.0)));
    let reach = |f: fn(&(f64, f64)) -> f64| {
        ap.ellipse_2sigma
            .iter()
            .map(f)
            .fold(0.0_f64, |m, v| m.max(v.abs()))
    };
    assert!((reach(|p| p.0 - 5.0) - 4.0).abs() < 1e-9);
    assert!((reach(|p| p.1) - 2.0).abs() < 0.01);
    // Fed and dropped packets; the acquisition's packet is neither.
    let aoa = &fig.aoa[0];
    assert_eq!(aoa.name, "ap0");
    let s = |ns: i64| ns as f64 * 1e-9;
    assert_eq!(aoa.fed, vec![(s(10_100_000_000), 2.0)]);
    assert_eq!(aoa.dropped, vec![(s(10_200_000_000), 30.0)]);
    assert_eq!(aoa.dropped_without_aoa, vec![(s(10_300_000_000), 3.0)]);
    let kinds: Vec<(f64, EventKind)> = fig.events.iter().map(|e| (e.t_s, e.kind)).collect();
    assert_eq!(
        kinds,
        [
            (10.0, EventKind::Converged),
            (14.0, EventKind::Lost),
            (17.0, EventKind::Recovered)
        ]
    );
    assert!(fig.truth.is_none() && fig.baro_height.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn with_a_truth_the_estimate_is_aligned_and_its_error_is_per_axis() {
    let (dir, poses) = run_folder("truth");
    // The truth is the estimate moved by 2 m along x and turned by 90° about z, plus 5 cm on y.
    let turn = nalgebra::Isometry3::new(
        Vector3::new(2.0, 0.0, 0.0),
        Vector3::z() * 90f64.to_radians(),
    );
    let truth_poses: Vec<Pose> = poses
        .iter()
        .map(|p| Pose {
            t: p.t,
            p_b_in_w: turn.transform_point(&p.p_b_in_w.into()).coords
                + Vector3::new(0.0, 0.05, 0.0),
            world_from_body: turn.rotation * p.world_from_body,
        })
        .collect();
    let truth = Truth {
        poses: truth_poses,
        aps: vec![ApRow {
            name: "ap0".into(),
            x_m: 2.0,
            y_m: 5.0,
            z_m: 1.5,
        }],
        packets: vec![vec![PacketRow {
            t_ns: 10_100_000_000,
            received: true,
            bfee_count: 0,
            aoa_rad: 0.0,
            aoa_deg: 1.5,
            elevation_rad: 0.0,
            in_front: true,
            tof_s: 0.0,
            range_m: 5.0,
            direct_obstructed: false,
            snr_db: 30.0,
            k_factor_db: 10.0,
            sto_s: 0.0,
            common_phase_rad: 0.0,
            clipped: 0,
        }]],
        imu_biases: Vec::new(),
        info: None,
    };
    let fig = RunFigures::from_files(
        &dir.join("trajectory.tum"),
        None,
        Some(&truth),
        &EvalOptions::default(),
    )
    .unwrap();
    let t = fig.truth.as_ref().unwrap();
    // A rigid move: aligned, the error is nil.
    for k in 0..3 {
        assert_eq!(finite(&t.error_m[k]), poses.len());
        let worst = t.error_m[k]
            .iter()
            .filter(|p| p.1.is_finite())
            .fold(0.0_f64, |m, p| m.max(p.1.abs()));
        assert!(worst < 1e-6, "axis {k}: {worst}");
    }
    // The AP on the map is in the truth's frame: (5, 0) turned by 90° and moved: (2, 5) + 5 cm.
    let (x, y) = fig.aps[0].xy;
    assert!((x - 2.0).abs() < 1e-6 && (y - 5.05).abs() < 1e-6, "{x} {y}");
    // Its ellipse is turned too: 4 m along y now.
    let reach_y = fig.aps[0]
        .ellipse_2sigma
        .iter()
        .fold(0.0_f64, |m, p| m.max((p.1 - y).abs()));
    assert!((reach_y - 4.0).abs() < 1e-6);
    // And so is the σ: σx of the estimate is σy in the truth's frame.
    assert!((fig.sigma_m[1][0].1 - 0.2).abs() < 1e-9);
    assert_eq!(fig.aoa[0].truth, vec![(10_100_000_000_f64 * 1e-9, 1.5)]);
    assert_eq!(t.aps_xy, vec![("ap0".to_string(), (2.0, 5.0))]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_malformed_file_beside_the_trajectory_is_named() {
    let (dir, _) = run_folder("bad");
    std::fs::write(dir.join("aps.csv"), "name,x_m,y_m,z_m\nap0,not,a,number\n").unwrap();
    let err = RunFigures::from_files(
        &dir.join("trajectory.tum"),
        None,
        None,
        &EvalOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("aps.csv"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_ellipse_needs_a_covariance() {
    let c = Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0); // eigenvalues 3 and −1
    assert!(ellipse(0.0, 0.0, &c, 2.0).is_empty());
    let c = Matrix3::from_diagonal_element(f64::INFINITY);
    assert!(ellipse(0.0, 0.0, &c, 2.0).is_empty());
}

#[test]
fn the_barometer_is_shifted_onto_the_estimated_height() {
    let poses: Vec<Pose> = (0..10).map(|i| pose(i as f64, 0.0, 0.0, 0.0)).collect();
    let baro: Vec<(f64, f64)> = (0..20).map(|i| (i as f64 * 0.5, -8.0)).collect();
    let shifted = baro_shifted(&baro, &poses);
    assert_eq!(shifted.len(), baro.len());
    assert!(shifted.iter().all(|p| (p.1 - 1.5).abs() < 1e-12));
}
