use std::path::PathBuf;

use nalgebra::{Isometry3, Matrix3, UnitQuaternion, Vector3};

use super::*;
use crate::dataset::truth::{read_tum, write_tum};
use crate::eval::evaluate::evaluate_direct;
use crate::eval::records::RecordWriter;
use crate::eval::scan::TrajectoryScan;
use crate::eval::{evaluate, position_nees};

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-stream-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("folder");
    dir
}

/// `seconds` of a wobbling circle at `rate_hz`, from `t0_ms`.
fn circle(seconds: f64, rate_hz: f64, t0_ms: i64) -> Vec<Pose> {
    let n = (seconds * rate_hz) as i64;
    let period_ns = (1e9 / rate_hz).round() as i64;
    (0..n)
        .map(|k| {
            let t = Timestamp(t0_ms * 1_000_000 + k * period_ns);
            let s = t.as_secs_f64();
            let a = 0.3 * s;
            Pose {
                t,
                p_b_in_w: Vector3::new(3.0 * a.cos(), 2.0 * a.sin(), 1.5 + 0.2 * (0.7 * s).sin()),
                world_from_body: UnitQuaternion::from_euler_angles(0.1 * s.sin(), 0.05, a + 1.0),
            }
        })
        .collect()
}

/// The truth moved into another world, with a slow drift, noise-like wiggles and jumps, every
/// third pose without a covariance.
fn estimate(truth: &[Pose]) -> Vec<EstRecord> {
    let est_from_truth = Isometry3::from_parts(
        Vector3::new(-2.0, 5.0, 0.3).into(),
        UnitQuaternion::from_euler_angles(0.02, -0.01, 0.8),
    );
    truth
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let s = p.t.as_secs_f64();
            let wiggle = Vector3::new((7.1 * s).sin(), (5.3 * s).cos(), (3.7 * s).sin()) * 0.05;
            let drift =
                Vector3::new(0.002 * s, 0.0, 0.0) + if k == 40 { Vector3::x() } else { wiggle };
            let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, 1e-3 * s);
            EstRecord {
                pose: Pose {
                    t: Timestamp(p.t.0 + (k as i64 % 5) * 1_000_000),
                    p_b_in_w: est_from_truth
                        .transform_point(&(p.p_b_in_w + drift).into())
                        .coords,
                    world_from_body: est_from_truth.rotation * yaw * p.world_from_body,
                },
                position_covariance: (k % 3 != 0)
                    .then(|| Matrix3::from_diagonal(&Vector3::new(4e-3, 2e-3, 1e-3))),
            }
        })
        .collect()
}

/// The streamed evaluation of `est` against `truth` (written to files as a run does), and the
/// truth as the in-memory evaluation reads it back.
fn streamed(
    dir: &Path,
    est: &[EstRecord],
    truth: &[Pose],
    options: &EvalOptions,
) -> (Result<Streamed, StreamedError>, Vec<Pose>, TrajectoryScan) {
    let (est_path, truth_path) = (dir.join("est.bin"), dir.join("poses.tum"));
    let mut w = RecordWriter::new(std::fs::File::create(&est_path).expect("est"));
    let mut est_scan = TrajectoryScan::default();
    for r in est {
        est_scan.push(&r.pose);
        w.push(r).expect("written");
    }
    w.flush().expect("flushed");
    let mut text = Vec::new();
    write_tum(&mut text, truth).expect("tum");
    std::fs::write(&truth_path, &text).expect("truth");
    let truth = read_tum(text.as_slice()).expect("read back");
    let mut truth_scan = TrajectoryScan::default();
    truth.iter().for_each(|p| truth_scan.push(p));
    let eval = StreamedEval {
        est: EstSource::File(&est_path),
        est_scan: &est_scan,
        truth: TruthSource::File(&truth_path),
        truth_scan: &truth_scan,
        options,
    };
    let aps = [EstimatedAp {
        name: "a".into(),
        x_m: 1.0,
        y_m: 2.0,
        z_m: 3.0,
        ..Default::default()
    }];
    let truth_aps = [ApRow {
        name: "a".into(),
        x_m: -1.0,
        y_m: 0.5,
        z_m: 2.0,
    }];
    let out = eval.evaluate(&aps, &truth_aps);
    (out, truth, truth_scan)
}

/// The evaluation read from files equals the direct formulas bit for bit, and the evaluation
/// of the same trajectories in memory.
fn check_same(name: &str, est: &[EstRecord], truth: &[Pose], options: &EvalOptions) -> usize {
    let dir = folder(name);
    let (out, truth, truth_scan) = streamed(&dir, est, truth, options);
    let poses: Vec<Pose> = est.iter().map(|r| r.pose).collect();
    let cov: Vec<_> = est.iter().map(|r| r.position_covariance).collect();
    let aps = [EstimatedAp {
        name: "a".into(),
        x_m: 1.0,
        y_m: 2.0,
        z_m: 3.0,
        ..Default::default()
    }];
    let truth_aps = [ApRow {
        name: "a".into(),
        x_m: -1.0,
        y_m: 0.5,
        z_m: 2.0,
    }];
    let expected = evaluate_direct(&poses, &truth, &aps, &truth_aps, options);
    let in_memory = evaluate(&poses, &truth, &aps, &truth_aps, options);
    match (&expected, in_memory) {
        (Ok(a), Ok(b)) => assert_eq!(*a, b, "{name}"),
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{name}"),
        (a, b) => panic!("{name}: {a:?} against {b:?}"),
    }
    match (out, expected) {
        (Ok(s), Ok(m)) => {
            assert_eq!(s.metrics, m, "{name}");
            let nees = position_nees(&poses, &cov, &truth, options).expect("nees");
            assert_eq!(s.nees, nees, "{name}");
        }
        (Err(StreamedError::Eval(a)), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
        (a, b) => panic!("{name}: {:?} against {b:?}", a.map(|s| s.metrics)),
    }
    let _ = std::fs::remove_dir_all(&dir);
    truth_scan.most_poses_held()
}

#[test]
fn the_evaluation_in_passes_is_the_direct_formulas_bit_for_bit() {
    let options = EvalOptions::default();
    // Truth at 200 Hz, the estimate at 50 Hz from 3 s on: over two minutes, so the drift from
    // the first minute is scored.
    let truth = circle(150.0, 200.0, 0);
    let est = estimate(&circle(140.0, 50.0, 3_000));
    check_same("est-drives", &est, &truth, &options);
    // RPE over 7 frames.
    let delta = EvalOptions {
        rpe_delta_frames: 7,
        ..options.clone()
    };
    check_same("delta", &est, &truth, &delta);
    // A truth sparser than the estimate drives the association.
    let sparse = EvalOptions {
        max_time_diff_s: 0.06,
        ..options.clone()
    };
    check_same("truth-drives", &est, &circle(150.0, 10.0, 0), &sparse);
    // A first minute climbing straight up: its alignment's heading comes from the attitudes.
    let climb = |poses: Vec<Pose>| -> Vec<Pose> {
        poses
            .into_iter()
            .map(|mut p| {
                if p.t.as_secs_f64() < 70.0 {
                    p.p_b_in_w = Vector3::new(0.0, 3.0, 1.0 + 0.01 * p.t.as_secs_f64());
                }
                p
            })
            .collect()
    };
    let truth = climb(circle(150.0, 200.0, 0));
    let est = estimate(&climb(circle(140.0, 50.0, 3_000)));
    check_same("climb-first", &est, &truth, &options);
}

#[test]
fn the_streamed_evaluation_fails_as_the_in_memory_one() {
    let options = EvalOptions::default();
    let truth = circle(10.0, 200.0, 0);
    let est = estimate(&circle(8.0, 50.0, 1_000));
    check_same("empty", &[], &truth, &options);
    check_same("no-match", &est, &circle(5.0, 200.0, 100_000), &options);
    let mut unsorted = est.clone();
    unsorted.swap(10, 11);
    check_same("unsorted", &unsorted, &truth, &options);
    let mut bad = est.clone();
    bad[4].pose.p_b_in_w.x = f64::NAN;
    check_same("non-finite", &bad, &truth, &options);
    check_same("two", &est[..2], &truth, &options);
    check_same("rpe", &est[..3], &truth, &options);
}

#[test]
fn the_poses_held_do_not_grow_with_the_flight() {
    let options = EvalOptions::default();
    let short = check_same(
        "held-short",
        &estimate(&circle(20.0, 50.0, 0)),
        &circle(20.0, 200.0, 0),
        &options,
    );
    let long = check_same(
        "held-long",
        &estimate(&circle(200.0, 50.0, 0)),
        &circle(200.0, 200.0, 0),
        &options,
    );
    // The truth's poses of the last 20 ms (200 Hz), whatever the flight's length.
    assert!(long <= 5 && long == short, "{short} then {long}");
}
