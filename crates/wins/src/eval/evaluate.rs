//! The whole evaluation: association, alignment, statistics.

use nalgebra::Vector3;

use super::associate::associate_and_align;
use super::records::EstRecord;
use super::scan::TrajectoryScan;
use super::stream::{EstSource, StreamedError, StreamedEval, TruthSource};
use super::{Alignment, Association, EstimatedAp, EvalError, EvalOptions, Metrics};
#[cfg(test)]
use super::{SentMetrics, aps, drift, metrics, relative_pose_errors};
use crate::dataset::truth::{ApRow, Pose};
use crate::time::Timestamp;

/// Scores `est` against `truth` (both time-sorted, on the same clock): association, alignment
/// and every statistic of [`Metrics`]; `aps` are moved by the same alignment and compared by name
/// with `truth_aps`. The run-only fields of [`Metrics`] are left `None` for the caller to fill.
/// The one evaluation (the passes a run read from files is scored by), over trajectories in
/// memory.
pub fn evaluate(
    est: &[Pose],
    truth: &[Pose],
    aps: &[EstimatedAp],
    truth_aps: &[ApRow],
    options: &EvalOptions,
) -> Result<Metrics, EvalError> {
    let records: Vec<EstRecord> = est
        .iter()
        .map(|&pose| EstRecord {
            pose,
            position_covariance: None,
        })
        .collect();
    let (est_scan, truth_scan) = (TrajectoryScan::of(est), TrajectoryScan::of(truth));
    let eval = StreamedEval {
        est: EstSource::Records(&records),
        est_scan: &est_scan,
        truth: TruthSource::Poses(truth),
        truth_scan: &truth_scan,
        options,
    };
    match eval.evaluate(aps, truth_aps) {
        Ok(s) => Ok(s.metrics),
        Err(StreamedError::Eval(e)) => Err(e),
        Err(StreamedError::Read(e)) => Err(EvalError::Read(e.to_string())),
    }
}

/// [`evaluate`] by the direct formulas on whole trajectories (association, Umeyama, RPE, drift
/// as their definitions state them): the reference the evaluation in passes is checked against,
/// bit for bit.
#[cfg(test)]
pub(crate) fn evaluate_direct(
    est: &[Pose],
    truth: &[Pose],
    aps: &[EstimatedAp],
    truth_aps: &[ApRow],
    options: &EvalOptions,
) -> Result<Metrics, EvalError> {
    let (association, alignment) = associate_and_align(est, truth, options)?;
    let pairs = &association.pairs;
    let errors = aligned_errors(est, truth, &association, &alignment);
    let norms: Vec<f64> = errors.iter().map(|e| e.norm()).collect();
    let position = metrics::summarize(&norms);
    let std_xyz = [0, 1, 2].map(|k| metrics::std_dev(errors.iter().map(move |e| e[k])));
    let attitude_deg: Vec<f64> = pairs
        .iter()
        .map(|&(i, j)| {
            let est_in_truth_w = alignment.apply_pose(&est[i]);
            (truth[j].world_from_body.inverse() * est_in_truth_w.world_from_body)
                .angle()
                .to_degrees()
        })
        .collect();
    let attitude = metrics::summarize(&attitude_deg);
    let rpe = relative_pose_errors(est, truth, pairs, options.rpe_delta_frames)?;
    let rpe_trans = metrics::summarize(&rpe.iter().map(|e| e.translation_m).collect::<Vec<_>>());
    let rpe_rot = metrics::summarize(&rpe.iter().map(|e| e.rotation_deg).collect::<Vec<_>>());
    let drift = drift::drift_metrics(est, truth, pairs, &alignment, &norms, options.align);
    let first_est = est[pairs[0].0].t;
    let last_est = est[pairs[pairs.len() - 1].0].t;
    Ok(Metrics {
        ate_rmse_m: position.rmse,
        position_error_mean_m: position.mean,
        position_error_rmse_m: position.rmse,
        position_error_median_m: position.median,
        position_error_max_m: position.max,
        position_error_std_xyz_m: std_xyz,
        attitude_error_mean_deg: attitude.mean,
        attitude_error_rmse_deg: attitude.rmse,
        position_error_last_60s_rmse_m: drift.position_error_last_60s_rmse_m,
        drift_last_60s_m: drift.drift_last_60s_m,
        heading_drift_deg_per_min: drift.heading_drift_deg_per_min,
        jumps: drift.jumps,
        rpe_trans_rmse_m: rpe_trans.rmse,
        rpe_rot_rmse_deg: rpe_rot.rmse,
        rpe_delta_frames: options.rpe_delta_frames,
        rpe_pairs: rpe.len(),
        convergence_time_s: est[0].t.secs_since(truth[0].t),
        duration_s: last_est.secs_since(first_est),
        max_speed_m_s: metrics::max_speed(truth),
        poses_evaluated: pairs.len(),
        poses_unmatched: association.unmatched_est,
        max_time_diff_s: options.max_time_diff_s,
        ap_position_error_m: aps::ap_errors(aps, truth_aps, &alignment)?,
        aoa_error_median_deg: None,
        position_nees_mean: None,
        position_nees_within_95: None,
        packets_used: None,
        packets_dropped: None,
        realtime_factor: None,
        sent: SentMetrics::default(),
        alignment,
    })
}

/// The aligned position error `‖R·p_est + t − p_truth‖` (m) of every associated estimated pose,
/// at the estimated pose's time, in time order: the curve behind [`Metrics::ate_rmse_m`].
pub fn position_error_series(
    est: &[Pose],
    truth: &[Pose],
    options: &EvalOptions,
) -> Result<Vec<(Timestamp, f64)>, EvalError> {
    let (association, alignment) = associate_and_align(est, truth, options)?;
    let errors = aligned_errors(est, truth, &association, &alignment);
    Ok(association
        .pairs
        .iter()
        .zip(errors)
        .map(|(&(i, _), e)| (est[i].t, e.norm()))
        .collect())
}

/// The RMS of the aligned position error (m) over the associated estimated poses at or after
/// `from`, and their count, under the alignment of the whole trajectory
/// ([`position_error_series`]): the error after a restart, its placement scored and not only
/// its shape. `None` when no associated pose is that late.
pub fn position_error_rms_from(
    est: &[Pose],
    truth: &[Pose],
    options: &EvalOptions,
    from: Timestamp,
) -> Result<Option<(f64, usize)>, EvalError> {
    let late: Vec<f64> = position_error_series(est, truth, options)?
        .into_iter()
        .filter(|(t, _)| *t >= from)
        .map(|(_, e)| e * e)
        .collect();
    Ok((!late.is_empty()).then(|| {
        let n = late.len();
        ((late.iter().sum::<f64>() / n as f64).sqrt(), n)
    }))
}

/// `R·p_est + t − p_truth` per associated pair, m.
fn aligned_errors(
    est: &[Pose],
    truth: &[Pose],
    association: &Association,
    alignment: &Alignment,
) -> Vec<Vector3<f64>> {
    let iso = alignment.isometry();
    association
        .pairs
        .iter()
        .map(|&(i, j)| iso.transform_point(&est[i].p_b_in_w.into()).coords - truth[j].p_b_in_w)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Matrix3, UnitQuaternion};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    const OMEGA_RAD_S: f64 = 0.5;

    /// A 20 s circle with a height oscillation, 200 Hz, yaw along the circle plus a roll wobble.
    fn truth() -> Vec<Pose> {
        (0..4000)
            .map(|k| {
                let (s, a) = (k as f64 * 0.005, OMEGA_RAD_S * k as f64 * 0.005);
                Pose {
                    t: Timestamp(k * 5_000_000),
                    p_b_in_w: Vector3::new(
                        2.5 * a.cos(),
                        2.5 * a.sin(),
                        1.5 + 0.3 * (2.0 * a).sin(),
                    ),
                    world_from_body: UnitQuaternion::from_euler_angles(0.1 * s.sin(), 0.0, a),
                }
            })
            .collect()
    }

    /// Every 4th pose (50 Hz), moved into the estimate's world (`est_from_truth`).
    fn moved(poses: &[Pose]) -> Vec<Pose> {
        let est_from_truth = Alignment::from_isometry(&est_from_truth());
        poses
            .iter()
            .step_by(4)
            .map(|p| est_from_truth.apply_pose(p))
            .collect()
    }

    fn est_from_truth() -> Isometry3<f64> {
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, 1.2);
        Isometry3::from_parts(Vector3::new(-3.0, 7.0, 0.4).into(), q)
    }

    fn run(est: &[Pose], truth: &[Pose]) -> Metrics {
        evaluate(est, truth, &[], &[], &EvalOptions::default()).expect("metrics")
    }

    #[test]
    fn a_rigidly_moved_truth_has_zero_error() {
        let truth = truth();
        let m = run(&moved(&truth), &truth);
        assert!(m.ate_rmse_m < 1e-12, "{}", m.ate_rmse_m);
        assert!(m.attitude_error_rmse_deg < 1e-9 && m.rpe_rot_rmse_deg < 1e-9);
        assert!(m.rpe_trans_rmse_m < 1e-12);
        let (found, expected) = (m.alignment.isometry(), est_from_truth().inverse());
        assert!(found.rotation.angle_to(&expected.rotation) < 1e-12);
        assert!((found.translation.vector - expected.translation.vector).norm() < 1e-11);
        assert_eq!((m.poses_evaluated, m.poses_unmatched), (1000, 0));
        assert_eq!((m.rpe_pairs, m.rpe_delta_frames), (999, 1));
        assert_eq!((m.convergence_time_s, m.duration_s), (0.0, 19.98));
        // |v| = ω·√(2.5² + 0.6²) at the height oscillation's steepest points.
        let v_max = OMEGA_RAD_S * (2.5f64.powi(2) + 0.6f64.powi(2)).sqrt();
        assert!(
            (m.max_speed_m_s - v_max).abs() < 1e-4,
            "{}",
            m.max_speed_m_s
        );
        // One schema: run-only fields are null, and the JSON reads back.
        let v = serde_json::to_value(&m).expect("json");
        assert!(v["packets_used"].is_null() && v["realtime_factor"].is_null());
        assert_eq!(v["ap_position_error_m"], serde_json::json!({}));
        assert_eq!(serde_json::from_value::<Metrics>(v).expect("parsed"), m);
    }

    /// The error after a time: zero for a moved truth; after a jump of 1 m in the last quarter,
    /// that quarter's error is what the whole trajectory's alignment leaves of the jump.
    #[test]
    fn the_error_from_a_time_on_is_scored_under_the_whole_alignment() {
        let truth = truth();
        let options = EvalOptions::default();
        let est = moved(&truth);
        let from = Timestamp(10_000_000_000);
        let (rms, n) = position_error_rms_from(&est, &truth, &options, from)
            .expect("scored")
            .expect("late poses");
        assert!(rms < 1e-12 && n == 500, "{rms} {n}");
        let late = Timestamp(30_000_000_000);
        assert_eq!(
            position_error_rms_from(&est, &truth, &options, late).expect("scored"),
            None
        );
        let jump = Timestamp(15_000_000_000);
        let jumped: Vec<_> = est
            .iter()
            .map(|p| Pose {
                p_b_in_w: p.p_b_in_w + Vector3::x() * if p.t >= jump { 1.0 } else { 0.0 },
                ..*p
            })
            .collect();
        let (rms, n) = position_error_rms_from(&jumped, &truth, &options, jump)
            .expect("scored")
            .expect("late poses");
        let ate = run(&jumped, &truth).ate_rmse_m;
        assert_eq!(n, 250);
        assert!(
            rms > 0.5 && rms < 1.0 && rms > ate,
            "{rms} against ATE {ate}"
        );
    }

    #[test]
    fn constant_offsets_are_aligned_away_and_attitude_errors_are_not() {
        let truth = truth();
        let (offset, delta) = (Vector3::new(0.5, -0.25, 1.0), 2f64.to_radians());
        let q_delta = UnitQuaternion::from_euler_angles(0.0, delta, 0.0);
        let shifted: Vec<_> = truth
            .iter()
            .map(|p| Pose {
                p_b_in_w: p.p_b_in_w + offset,
                world_from_body: p.world_from_body * q_delta,
                ..*p
            })
            .collect();
        let m = run(&shifted, &truth);
        assert!(m.ate_rmse_m < 1e-12 && m.position_error_max_m < 1e-12);
        assert!((Vector3::from(m.alignment.translation_m) + offset).norm() < 1e-12);
        assert!((m.attitude_error_mean_deg - 2.0).abs() < 1e-9);
        assert!((m.attitude_error_rmse_deg - 2.0).abs() < 1e-9);
    }

    #[test]
    fn zero_mean_uncorrelated_noise_gives_its_rms() {
        // Noise with zero mean and no correlation with the positions leaves the Umeyama
        // cross-covariance symmetric positive: the alignment is exact and ATE = RMS(‖n‖).
        let truth = truth();
        let sub: Vec<Pose> = truth.iter().step_by(4).copied().collect();
        let normal = Normal::new(0.0, 0.05).expect("σ");
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut noise: Vec<Vector3<f64>> = (0..sub.len())
            .map(|_| Vector3::from_fn(|_, _| normal.sample(&mut rng)))
            .collect();
        let n = sub.len() as f64;
        let mean_p = sub.iter().map(|p| p.p_b_in_w).sum::<Vector3<f64>>() / n;
        let centred: Vec<_> = sub.iter().map(|p| p.p_b_in_w - mean_p).collect();
        let c_pp: Matrix3<f64> = centred.iter().map(|c| c * c.transpose()).sum();
        let mean_n = noise.iter().sum::<Vector3<f64>>() / n;
        let c_np: Matrix3<f64> = noise
            .iter()
            .zip(&centred)
            .map(|(e, c)| e * c.transpose())
            .sum();
        let b = c_np * c_pp.try_inverse().expect("excited");
        for (e, c) in noise.iter_mut().zip(&centred) {
            *e -= mean_n + b * c;
        }
        let noisy: Vec<Pose> = (truth.iter().enumerate())
            .map(|(k, p)| Pose {
                p_b_in_w: p.p_b_in_w + noise[k / 4],
                ..*p
            })
            .collect();
        let est = moved(&noisy);
        let m = run(&est, &truth);
        let norms: Vec<f64> = noise.iter().map(|e| e.norm()).collect();
        let rms = (norms.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        assert!(
            (m.ate_rmse_m - rms).abs() < 1e-12 * rms,
            "{} vs {rms}",
            m.ate_rmse_m
        );
        assert!(m.ate_rmse_m > 0.05 * 3f64.sqrt() * 0.95, "{}", m.ate_rmse_m);
        assert_eq!(m.position_error_rmse_m, m.ate_rmse_m);
        let max = norms.iter().copied().fold(0.0, f64::max);
        assert!((m.position_error_max_m - max).abs() < 1e-12);
        for k in 0..3 {
            let axis_rms = (noise.iter().map(|e| e[k] * e[k]).sum::<f64>() / n).sqrt();
            assert!((m.position_error_std_xyz_m[k] - axis_rms).abs() < 1e-12);
        }
        let series = position_error_series(&est, &truth, &EvalOptions::default()).expect("series");
        assert_eq!(series.len(), m.poses_evaluated);
        assert!((series[7].1 - norms[7]).abs() < 1e-12 && series[7].0 == sub[7].t);
    }

    #[test]
    fn late_start_and_poses_outside_the_truth() {
        let truth = truth();
        let mut est = moved(&truth[300..]);
        for k in 1..=3 {
            let mut p = est[est.len() - 1];
            p.t = Timestamp(p.t.0 + k * 50_000_000);
            est.push(p);
        }
        let m = run(&est, &truth);
        assert_eq!((m.poses_unmatched, m.poses_evaluated), (3, 925));
        assert!((m.convergence_time_s - 1.5).abs() < 1e-12);
        assert!(
            m.report().contains("925 evaluated, 3 unmatched"),
            "{}",
            m.report()
        );
    }
}
