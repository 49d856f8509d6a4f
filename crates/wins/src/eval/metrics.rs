//! The numbers of an evaluation ([`Metrics`], the schema of `metrics.json`), the relative pose
//! error and the error statistics.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::align::Alignment;
use super::drift::{DRIFT_WINDOW_S, JUMP_THRESHOLD_M};
#[cfg(test)]
use crate::dataset::truth::Pose;

/// Truth positions closer in time than this are not differenced for the speed (noise), s.
pub const SPEED_MIN_INTERVAL_S: f64 = 0.02;

/// How well an estimated trajectory matches the truth (`metrics.json`).
///
/// "Aligned error" below is `e_i = R·p_est,i + t − p_truth,i` over the associated pairs, with
/// `(R, t)` = [`Metrics::alignment`]. Statistics follow evo: the RMSE is `√(Σ e²/n)`, the median
/// of an even count is the mean of the two middle values, standard deviations divide by `n`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Absolute trajectory error: RMSE of `‖e_i‖` over the associated poses after the alignment
    /// (`EvalOptions::align`: a heading and a translation, or SE(3) Umeyama), m. With SE(3),
    /// equal to `evo_ape tum TRUTH EST -a`'s RMSE.
    pub ate_rmse_m: f64,
    /// Mean of `‖e_i‖`, m.
    pub position_error_mean_m: f64,
    /// RMSE of `‖e_i‖`, m (the same number as `ate_rmse_m`).
    pub position_error_rmse_m: f64,
    /// Median of `‖e_i‖`, m.
    pub position_error_median_m: f64,
    /// Largest `‖e_i‖`, m: the largest error after convergence, since the pipeline writes only
    /// converged poses (for `wins eval`, over whichever estimated poses are associated).
    pub position_error_max_m: f64,
    /// Standard deviation of each component of `e_i` (x, y, z of the truth world) about its mean,
    /// m: the per-axis spread the paper reports.
    pub position_error_std_xyz_m: [f64; 3],
    /// Mean attitude error, deg: the angle of `R_truthᵀ · R · R_est` (`world_from_body`
    /// rotations; with SE(3), evo_ape `-r angle_deg -a`).
    pub attitude_error_mean_deg: f64,
    /// RMSE of the same attitude error angle, deg.
    pub attitude_error_rmse_deg: f64,
    /// Error in the last minute: RMSE of `‖e_i‖` (the ATE's global alignment) over the associated
    /// poses whose estimated time is `≥ t_last − 60 s`, `t_last` the time of the last associated
    /// estimated pose, m. Equals `ate_rmse_m` for a flight under a minute. Absent from older
    /// files (read as 0).
    #[serde(default)]
    pub position_error_last_60s_rmse_m: f64,
    /// Drift over the flight, m: the estimate aligned (SE(3) Umeyama, as for the ATE) on its
    /// associated poses of the first minute only (estimated time `≤ t_first + 60 s`, `t_first`
    /// the time of the first associated estimated pose), then the RMSE of
    /// `‖R₁·p_est,i + t₁ − p_truth,i‖` over the poses of the last minute (those of
    /// `position_error_last_60s_rmse_m`). Null when the associated estimate spans less than
    /// 120 s (the minutes would overlap), or when its first minute cannot fix an alignment
    /// (fewer than 3 poses, or positions still or along one line); absent from older files.
    #[serde(default)]
    pub drift_last_60s_m: Option<f64>,
    /// Heading error drift, deg/min: the least-squares slope against time of the heading error
    /// of the associated poses, unwrapped (each step between neighbours taken in [−180°, 180°)).
    /// Heading error: the yaw about the truth world's vertical z of the error rotation
    /// `R_err = R·R_est·R_truthᵀ` (`world_from_body` rotations, `R` the global alignment),
    /// `atan2(R_err[1,0], R_err[0,0])`; positive when the estimate is turned counter-clockwise
    /// seen from above, unaffected by roll and pitch errors about horizontal world axes. 0 for
    /// fewer than 2 poses; absent from older files (read as 0).
    #[serde(default)]
    pub heading_drift_deg_per_min: f64,
    /// Jumps: consecutive estimated poses (all those given, in time order, matched or not: after
    /// convergence, as the pipeline writes only converged poses) whose positions are more than
    /// [`JUMP_THRESHOLD_M`](super::JUMP_THRESHOLD_M) = 0.3 m apart; the distance needs no
    /// alignment. Absent from older files (read as 0).
    #[serde(default)]
    pub jumps: usize,
    /// Relative pose error, translation: RMSE over pose pairs `(i, i + Δ)` of `‖trans(E_i)‖`
    /// with `E_i = (Q_i⁻¹ Q_{i+Δ})⁻¹ (P_i⁻¹ P_{i+Δ})`, `Q` truth and `P` estimate (no alignment
    /// needed: `E_i` is invariant to it), m. `i` runs over the associated poses 0, Δ, 2Δ, … as in
    /// `evo_rpe tum TRUTH EST --delta Δ --delta_unit f`.
    pub rpe_trans_rmse_m: f64,
    /// Relative pose error, rotation: RMSE of the angle of `rot(E_i)`, deg
    /// (`evo_rpe … -r angle_deg`).
    pub rpe_rot_rmse_deg: f64,
    /// The RPE frame delta Δ, in associated poses.
    pub rpe_delta_frames: usize,
    /// Number of RPE pose pairs.
    pub rpe_pairs: usize,
    /// Time from the first truth pose to the first estimated pose, s. The pipeline writes only
    /// converged poses, so this is the estimator's convergence time from the start of the flight
    /// (negative if the estimate starts before the truth).
    pub convergence_time_s: f64,
    /// Time from the first to the last associated estimated pose, s.
    pub duration_s: f64,
    /// Largest truth speed over the whole truth trajectory, m/s, from finite differences of truth
    /// positions at least `SPEED_MIN_INTERVAL_S` apart (0 if the truth is shorter than that).
    pub max_speed_m_s: f64,
    /// Associated pose pairs the errors are computed over.
    pub poses_evaluated: usize,
    /// Estimated poses with no truth pose within `max_time_diff_s` (not in any statistic).
    pub poses_unmatched: usize,
    /// The association tolerance used, s (evo's `--t_max_diff`).
    pub max_time_diff_s: f64,
    /// Per AP name, `‖R·p_ap,est + t − p_ap,truth‖`, m: the estimated AP position moved by the
    /// same alignment as the trajectory. Empty when no AP estimates were given.
    pub ap_position_error_m: BTreeMap<String, f64>,
    /// Run only (null from `wins eval`): median `|AoA − true direct-path AoA|` over the packets
    /// the estimator used, deg.
    pub aoa_error_median_deg: Option<f64>,
    /// Run only: mean position NEES `eᵀ(RΣRᵀ)⁻¹e` over the associated poses, `Σ` the position
    /// covariance the estimator reported with the pose ([`super::nees`]); 3 when the covariance
    /// is honest, more when it is overconfident. Null when no pose carries a covariance.
    #[serde(default)]
    pub position_nees_mean: Option<f64>,
    /// Run only: share of those poses whose NEES is within χ²(3)'s 95 % point (0.95 when honest).
    #[serde(default)]
    pub position_nees_within_95: Option<f64>,
    /// Run only: received CSI packets whose AoA entered the estimator.
    pub packets_used: Option<u64>,
    /// Run only: received CSI packets not used (no AoA found, outside the predicted window,
    /// rejected by a gate).
    pub packets_dropped: Option<u64>,
    /// Run only: seconds of flight processed per second of wall-clock time (> 1: faster than
    /// real time).
    pub realtime_factor: Option<f64>,
    /// Run only: the poses a flight controller is sent, as `wins live` sends them (the causal
    /// estimate, `trajectory_sent.tum`), scored as a trajectory of their own. The other fields
    /// score every converged pose, including those made in hindsight.
    #[serde(default)]
    pub sent: SentMetrics,
    /// The alignment `truth_world_from_est_world` applied: `p_truth ≈ R·p_est + t`.
    pub alignment: Alignment,
}

/// The poses a run sends a flight controller, scored alone (its own alignment: what
/// `evo_ape tum truth/poses.tum trajectory_sent.tum -a` reports). Null fields: not a run, no pose
/// sent, or too few to score.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SentMetrics {
    /// Poses sent.
    pub poses: usize,
    /// From the truth's first pose to the first pose sent, s: what a flight controller waits.
    pub time_to_first_s: Option<f64>,
    /// ATE RMSE of the poses sent, m.
    pub ate_rmse_m: Option<f64>,
    /// Median aligned position error of the poses sent, m.
    pub position_error_median_m: Option<f64>,
    /// Largest aligned position error of the poses sent, m.
    pub position_error_max_m: Option<f64>,
    /// Attitude error RMSE of the poses sent, deg.
    pub attitude_error_rmse_deg: Option<f64>,
    /// Mean position NEES of the poses sent (3 when the covariance sent is honest).
    pub position_nees_mean: Option<f64>,
}

impl Metrics {
    /// A short human-readable report (a few lines, each ending in a newline).
    pub fn report(&self) -> String {
        let mut s = String::new();
        let [sx, sy, sz] = self.position_error_std_xyz_m;
        // Writing to a String cannot fail.
        let _ = writeln!(
            s,
            "poses      {} evaluated, {} unmatched (max Δt {} ms), over {:.2} s",
            self.poses_evaluated,
            self.poses_unmatched,
            self.max_time_diff_s * 1e3,
            self.duration_s
        );
        let _ = writeln!(
            s,
            "timing     first estimate {:.2} s after the truth starts; max truth speed {:.2} m/s",
            self.convergence_time_s, self.max_speed_m_s
        );
        let _ = writeln!(
            s,
            "ATE        RMSE {:.4} m, mean {:.4} m, median {:.4} m, max {:.4} m; σ xyz {:.4} {:.4} {:.4} m",
            self.ate_rmse_m,
            self.position_error_mean_m,
            self.position_error_median_m,
            self.position_error_max_m,
            sx,
            sy,
            sz
        );
        let _ = writeln!(
            s,
            "attitude   RMSE {:.3}°, mean {:.3}°",
            self.attitude_error_rmse_deg, self.attitude_error_mean_deg
        );
        let drift = match self.drift_last_60s_m {
            Some(d) => format!("{d:.4} m"),
            None if self.duration_s < 2.0 * DRIFT_WINDOW_S => "n/a (under 120 s)".to_string(),
            None => "n/a (first minute cannot fix an alignment)".to_string(),
        };
        let _ = writeln!(
            s,
            "drift      last 60 s RMSE {:.4} m, aligned on the first 60 s {}; heading {:+.3}°/min; \
             {} jumps > {} m",
            self.position_error_last_60s_rmse_m,
            drift,
            self.heading_drift_deg_per_min,
            self.jumps,
            JUMP_THRESHOLD_M
        );
        let _ = writeln!(
            s,
            "RPE        Δ {} frames: translation RMSE {:.4} m, rotation RMSE {:.3}° ({} pairs)",
            self.rpe_delta_frames, self.rpe_trans_rmse_m, self.rpe_rot_rmse_deg, self.rpe_pairs
        );
        if !self.ap_position_error_m.is_empty() {
            let aps: Vec<String> = self
                .ap_position_error_m
                .iter()
                .map(|(name, e)| format!("{name} {e:.3} m"))
                .collect();
            let _ = writeln!(s, "APs        {}", aps.join(", "));
        }
        if let (Some(mean), Some(within)) = (self.position_nees_mean, self.position_nees_within_95)
        {
            let _ = writeln!(
                s,
                "NEES       position: mean {mean:.2} (honest: 3), {:.0} % within χ²(3) 95 % (honest: 95 %)",
                100.0 * within
            );
        }
        let mut run = Vec::new();
        if let Some(a) = self.aoa_error_median_deg {
            run.push(format!("AoA median error {a:.2}°"));
        }
        if let (Some(u), Some(d)) = (self.packets_used, self.packets_dropped) {
            run.push(format!("packets {u} used, {d} dropped"));
        }
        if let Some(r) = self.realtime_factor {
            run.push(format!("{r:.1}× real time"));
        }
        if !run.is_empty() {
            let _ = writeln!(s, "run        {}", run.join("; "));
        }
        let sent = &self.sent;
        if let (Some(first), Some(ate)) = (sent.time_to_first_s, sent.ate_rmse_m) {
            let _ = writeln!(
                s,
                "sent       {} poses to the flight controller, the first after {first:.1} s: \
                 ATE {ate:.3} m, median {:.3} m",
                sent.poses,
                sent.position_error_median_m.unwrap_or(f64::NAN)
            );
        }
        s
    }
}

/// Mean, RMSE, median and max of non-negative errors (all 0 for none).
pub(crate) struct Summary {
    pub(crate) mean: f64,
    pub(crate) rmse: f64,
    pub(crate) median: f64,
    pub(crate) max: f64,
}

pub(crate) fn summarize(errors: &[f64]) -> Summary {
    if errors.is_empty() {
        return Summary {
            mean: 0.0,
            rmse: 0.0,
            median: 0.0,
            max: 0.0,
        };
    }
    let n = errors.len() as f64;
    let mut sorted = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    let median = if sorted.len().is_multiple_of(2) {
        0.5 * (sorted[mid - 1] + sorted[mid])
    } else {
        sorted[mid]
    };
    Summary {
        mean: errors.iter().sum::<f64>() / n,
        rmse: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        median,
        max: sorted[sorted.len() - 1],
    }
}

#[cfg(test)]
/// Population standard deviation of `values` (0 for none).
pub(crate) fn std_dev(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = values.clone().count() as f64;
    if n == 0.0 {
        return 0.0;
    }
    let mean = values.clone().sum::<f64>() / n;
    (values.map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
}

#[cfg(test)]
/// Largest speed from finite differences of truth positions at least
/// [`SPEED_MIN_INTERVAL_S`] apart (each pose with the first one far enough after it), m/s.
pub(crate) fn max_speed(truth: &[Pose]) -> f64 {
    let min_ns = (SPEED_MIN_INTERVAL_S * 1e9).round() as i64;
    let mut best: f64 = 0.0;
    let mut j = 0;
    for (i, a) in truth.iter().enumerate() {
        j = j.max(i + 1);
        while j < truth.len() && truth[j].t.0 - a.t.0 < min_ns {
            j += 1;
        }
        let Some(b) = truth.get(j) else { break };
        best = best.max((b.p_b_in_w - a.p_b_in_w).norm() / b.t.secs_since(a.t));
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::test_pose as pose;
    use nalgebra::Vector3;

    #[test]
    fn statistics_match_numpy() {
        let s = summarize(&[3.0, 1.0, 4.0, 2.0]);
        assert_eq!((s.mean, s.median, s.max), (2.5, 2.5, 4.0));
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(summarize(&[5.0, 1.0, 2.0]).median, 2.0);
        assert!((std_dev([1.0, 3.0].into_iter()) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn max_speed_uses_at_least_20_ms() {
        // 1 m/s along x at 1 kHz with ±1 mm of alternating noise: 1-sample differences would
        // give 3 m/s; 20 ms differences (an even number of samples) give 1 m/s.
        let truth: Vec<_> = (0..1000)
            .map(|k| {
                let noise = if k % 2 == 0 { 1e-3 } else { -1e-3 };
                pose(k, Vector3::new(k as f64 * 1e-3 + noise, 0.0, 0.0), 0.0)
            })
            .collect();
        let v = max_speed(&truth);
        assert!((v - 1.0).abs() < 1e-9, "{v}");
        assert_eq!(max_speed(&truth[..10]), 0.0);
    }
}
