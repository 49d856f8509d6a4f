//! The evaluation ([`StreamedEval`]): an estimate against the truth, each read in passes, from
//! a file (a flight too long to hold: a file of [`EstRecord`]s, a TUM file) or from memory
//! ([`super::evaluate`]). Both are in time order, so the association is a merge-join of the
//! two; the alignment, ATE, RPE, drift and NEES are sums over the pairs, taken in the order
//! the direct formulas take them ([`super::associate`], [`super::umeyama`],
//! [`super::relative_pose_errors`], [`super::position_nees`]: the tests check the passes
//! against them bit for bit). Only the pairs' position errors are held (one `f64` each, for
//! the median).

use std::io;
use std::path::Path;

use nalgebra::{Isometry3, Translation3};

use super::align::{UmeyamaCross, UmeyamaMeans};
use super::associate::nearest;
use super::drift::{DRIFT_WINDOW_S, SECONDS_PER_MINUTE, heading_error_rad, unwrap_step};
use super::metrics;
use super::nees::{NEES_95_3DOF, NeesSummary, nees};
use super::records::{EstRecord, read_records};
use super::scan::TrajectoryScan;
use super::{Alignment, EstimatedAp, EvalError, EvalOptions, Metrics, SentMetrics, aps};
use crate::dataset::truth::{ApRow, Pose, tum_poses};
use crate::time::{NANOS_PER_SEC, Timestamp};

/// Why a streamed evaluation stopped.
#[derive(Debug, thiserror::Error)]
pub(crate) enum StreamedError {
    /// The run cannot be scored.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// A file could not be read again.
    #[error(transparent)]
    Read(#[from] io::Error),
}

/// An associated pair: the estimate's index and record, the truth's pose.
struct Pair {
    i: usize,
    est: EstRecord,
    truth: Pose,
}

/// Where an evaluation reads the estimate from, in time order, once per pass.
#[derive(Clone, Copy, Debug)]
pub(crate) enum EstSource<'a> {
    /// A file of [`EstRecord`]s ([`super::records`]).
    File(&'a Path),
    /// Records in memory.
    Records(&'a [EstRecord]),
}

/// Where an evaluation reads the truth from, in time order, once per pass.
#[derive(Clone, Copy, Debug)]
pub(crate) enum TruthSource<'a> {
    /// A TUM file.
    File(&'a Path),
    /// Poses in memory.
    Poses(&'a [Pose]),
}

/// The inputs of an evaluation read in passes.
#[derive(Clone, Debug)]
pub(crate) struct StreamedEval<'a> {
    /// The estimate, in time order.
    pub(crate) est: EstSource<'a>,
    /// What one pass over it found.
    pub(crate) est_scan: &'a TrajectoryScan,
    /// The truth, in time order.
    pub(crate) truth: TruthSource<'a>,
    /// What one pass over it found.
    pub(crate) truth_scan: &'a TrajectoryScan,
    /// The settings.
    pub(crate) options: &'a EvalOptions,
}

/// One pass over a trajectory's items.
type PassOver<'a, T> = Box<dyn Iterator<Item = io::Result<T>> + 'a>;

/// What a streamed evaluation gives.
#[derive(Clone, Debug)]
pub(crate) struct Streamed {
    /// The metrics (run-only fields `None`).
    pub(crate) metrics: Metrics,
    /// The position NEES of the pairs whose estimate has a covariance.
    pub(crate) nees: Option<NeesSummary>,
}

impl<'a> StreamedEval<'a> {
    /// The estimate's records, in order.
    pub(crate) fn est_records(&self) -> io::Result<PassOver<'a, EstRecord>> {
        Ok(match self.est {
            EstSource::File(path) => Box::new(read_records(path, self.est_scan.poses())?),
            EstSource::Records(records) => Box::new(records.iter().map(|r| Ok(*r))),
        })
    }

    /// The truth's poses, in order.
    pub(crate) fn truth_poses(&self) -> io::Result<PassOver<'a, Pose>> {
        Ok(match self.truth {
            TruthSource::File(path) => Box::new(truth_poses(path)?),
            TruthSource::Poses(poses) => Box::new(poses.iter().map(|p| Ok(*p))),
        })
    }

    /// Every associated pair to `f`, in order ([`super::associate`]'s pairs: the shorter
    /// trajectory drives).
    fn for_each_pair(&self, mut f: impl FnMut(Pair)) -> io::Result<()> {
        let max_ns = self.options.max_time_diff_ns();
        let est = self
            .est_records()?
            .enumerate()
            .map(|(i, r)| r.map(|r| (r.pose.t, (i, r))));
        let truth = self.truth_poses()?.map(|r| r.map(|p| (p.t, p)));
        if self.truth_scan.poses() < self.est_scan.poses() {
            nearest(truth, est, max_ns, |truth, &(i, est)| {
                f(Pair {
                    i,
                    est,
                    truth: *truth,
                })
            })
        } else {
            nearest(est, truth, max_ns, |&(i, est), truth| {
                f(Pair {
                    i,
                    est,
                    truth: *truth,
                })
            })
        }
    }

    /// The evaluation of [`super::evaluate`] and [`super::position_nees`], with the same errors
    /// in the same order; `aps` are scored against `truth_aps`.
    pub(crate) fn evaluate(
        &self,
        aps: &[EstimatedAp],
        truth_aps: &[ApRow],
    ) -> Result<Streamed, StreamedError> {
        self.options.validate()?;
        self.est_scan.check_finite("estimate")?;
        self.truth_scan.check_finite("truth")?;
        self.est_scan.check_sorted("estimate")?;
        self.truth_scan.check_sorted("truth")?;
        let window_ns = (DRIFT_WINDOW_S * NANOS_PER_SEC as f64).round() as i64;
        // Pass 1: count, span and sums of the pairs (all, and those of the first minute).
        let (mut n, mut span, mut matched, mut last_i) = (0, None, 0, None);
        let (mut global, mut first_minute) = (UmeyamaMeans::default(), UmeyamaMeans::default());
        self.for_each_pair(|p| {
            n += 1;
            let t = p.est.pose.t;
            let (first, _) = *span.get_or_insert((t, t));
            span = Some((first, t));
            if last_i != Some(p.i) {
                matched += 1;
                last_i = Some(p.i);
            }
            global.push(&p.est.pose.p_b_in_w, &p.truth.p_b_in_w);
            if t.0 <= first.0 + window_ns {
                first_minute.push(&p.est.pose.p_b_in_w, &p.truth.p_b_in_w);
            }
        })?;
        let Some((first, last)) = span else {
            return Err(EvalError::NoMatches {
                est_poses: self.est_scan.poses(),
                truth_poses: self.truth_scan.poses(),
                max_time_diff_s: self.options.max_time_diff_ns() as f64 * 1e-9,
            }
            .into());
        };
        // Pass 2: the cross-covariances.
        let mut global = global.cross()?;
        let mut first_minute: Option<UmeyamaCross> = first_minute.cross().ok();
        self.for_each_pair(|p| {
            global.push_pose(&p.est.pose, &p.truth);
            if let Some(c) = &mut first_minute
                && p.est.pose.t.0 <= first.0 + window_ns
            {
                c.push_pose(&p.est.pose, &p.truth);
            }
        })?;
        let alignment = global.alignment(self.options.align)?;
        let first_minute = if last.0 - first.0 < 2 * window_ns {
            None
        } else {
            first_minute.and_then(|c| c.alignment(self.options.align).ok())
        };
        let delta = self.options.rpe_delta_frames;
        if delta == 0 || n <= delta {
            return Err(EvalError::RpeTooShort { poses: n, delta }.into());
        }
        let ap_position_error_m = aps::ap_errors(aps, truth_aps, &alignment)?;
        let sums = self.errors(&alignment, first_minute.as_ref(), (first, last))?;
        let moments = self.moments(&alignment, first, n, &sums)?;
        let nf = n as f64;
        let position = metrics::summarize(&sums.norms);
        let rms = |(sum_sq, k): (f64, usize)| {
            if k == 0 {
                0.0
            } else {
                (sum_sq / k as f64).sqrt()
            }
        };
        let (rpe_n, rpe_trans_sq, rpe_rot_sq) = sums.rpe;
        let nees = (sums.nees.2 > 0).then(|| {
            let k = sums.nees.2 as f64;
            NeesSummary {
                mean: sums.nees.0 / k,
                within_95: sums.nees.1 as f64 / k,
                poses: sums.nees.2,
            }
        });
        let metrics = Metrics {
            ate_rmse_m: position.rmse,
            position_error_mean_m: position.mean,
            position_error_rmse_m: position.rmse,
            position_error_median_m: position.median,
            position_error_max_m: position.max,
            position_error_std_xyz_m: moments.std_xyz,
            attitude_error_mean_deg: sums.attitude.0 / nf,
            attitude_error_rmse_deg: (sums.attitude.1 / nf).sqrt(),
            position_error_last_60s_rmse_m: rms(sums.last_minute),
            drift_last_60s_m: first_minute.map(|_| rms(sums.drift)),
            heading_drift_deg_per_min: moments.slope_rad_s.to_degrees() * SECONDS_PER_MINUTE,
            jumps: self.est_scan.jumps(),
            rpe_trans_rmse_m: (rpe_trans_sq / rpe_n as f64).sqrt(),
            rpe_rot_rmse_deg: (rpe_rot_sq / rpe_n as f64).sqrt(),
            rpe_delta_frames: delta,
            rpe_pairs: rpe_n,
            convergence_time_s: time_between(self.truth_scan.first_t(), self.est_scan.first_t()),
            duration_s: last.secs_since(first),
            max_speed_m_s: self.truth_scan.max_speed_m_s(),
            poses_evaluated: n,
            poses_unmatched: self.est_scan.poses() - matched,
            max_time_diff_s: self.options.max_time_diff_s,
            ap_position_error_m,
            aoa_error_median_deg: None,
            position_nees_mean: None,
            position_nees_within_95: None,
            packets_used: None,
            packets_dropped: None,
            realtime_factor: None,
            sent: SentMetrics::default(),
            alignment,
        };
        Ok(Streamed { metrics, nees })
    }

    /// Pass 3: the errors of the pairs under `alignment` and their sums.
    fn errors(
        &self,
        alignment: &Alignment,
        first_minute: Option<&Alignment>,
        (first, last): (Timestamp, Timestamp),
    ) -> io::Result<ErrorSums> {
        let window_ns = (DRIFT_WINDOW_S * NANOS_PER_SEC as f64).round() as i64;
        let iso = alignment.isometry();
        let r = iso.rotation.to_rotation_matrix().into_inner();
        let delta = self.options.rpe_delta_frames;
        let mut s = ErrorSums::default();
        let (mut k, mut start, mut heading) = (0usize, None::<(Pose, Pose)>, None);
        let pose_iso =
            |p: &Pose| Isometry3::from_parts(Translation3::from(p.p_b_in_w), p.world_from_body);
        self.for_each_pair(|p| {
            let (est, truth) = (&p.est.pose, &p.truth);
            let e = iso.transform_point(&est.p_b_in_w.into()).coords - truth.p_b_in_w;
            let norm = e.norm();
            s.norms.push(norm);
            for (sum, x) in s.e.iter_mut().zip(e.iter()) {
                *sum += x;
            }
            let aligned = alignment.apply_pose(est);
            let angle = (truth.world_from_body.inverse() * aligned.world_from_body)
                .angle()
                .to_degrees();
            s.attitude.0 += angle;
            s.attitude.1 += angle * angle;
            if k.is_multiple_of(delta) {
                if let Some((est_0, truth_0)) = &start {
                    let q_rel = pose_iso(truth_0).inverse() * pose_iso(truth);
                    let p_rel = pose_iso(est_0).inverse() * pose_iso(est);
                    let e = q_rel.inverse() * p_rel;
                    let (trans, rot) =
                        (e.translation.vector.norm(), e.rotation.angle().to_degrees());
                    s.rpe.0 += 1;
                    s.rpe.1 += trans * trans;
                    s.rpe.2 += rot * rot;
                }
                start = Some((*est, *truth));
            }
            k += 1;
            if est.t.0 >= last.0 - window_ns {
                s.last_minute = (s.last_minute.0 + norm * norm, s.last_minute.1 + 1);
                if let Some(a) = first_minute {
                    let x = (a.apply_point(&est.p_b_in_w) - truth.p_b_in_w).norm();
                    s.drift = (s.drift.0 + x * x, s.drift.1 + 1);
                }
            }
            let h = heading_error_rad(&truth.world_from_body, &aligned.world_from_body);
            s.heading_t += est.t.secs_since(first);
            s.heading_y += unwrap_step(&mut heading, h);
            if let Some(c) = p.est.position_covariance
                && let Some(v) = nees(&e, &c, &r)
            {
                s.nees.0 += v;
                s.nees.1 += usize::from(v <= NEES_95_3DOF);
                s.nees.2 += 1;
            }
        })?;
        Ok(s)
    }

    /// Pass 4: the sums about the means of pass 3 (per-axis spread, heading slope).
    fn moments(
        &self,
        alignment: &Alignment,
        first: Timestamp,
        n: usize,
        sums: &ErrorSums,
    ) -> io::Result<Moments> {
        let nf = n as f64;
        let iso = alignment.isometry();
        let mean_e = sums.e.map(|s| s / nf);
        let (t_mean, y_mean) = (sums.heading_t / nf, sums.heading_y / nf);
        let mut sq = [-0.0; 3];
        let (mut num, mut den, mut heading) = (0.0, 0.0, None);
        self.for_each_pair(|p| {
            let (est, truth) = (&p.est.pose, &p.truth);
            let e = iso.transform_point(&est.p_b_in_w.into()).coords - truth.p_b_in_w;
            for c in 0..3 {
                sq[c] += (e[c] - mean_e[c]).powi(2);
            }
            let aligned = alignment.apply_pose(est);
            let h = heading_error_rad(&truth.world_from_body, &aligned.world_from_body);
            let dt = est.t.secs_since(first) - t_mean;
            num += dt * (unwrap_step(&mut heading, h) - y_mean);
            den += dt * dt;
        })?;
        Ok(Moments {
            std_xyz: sq.map(|s| (s / nf).sqrt()),
            slope_rad_s: if n >= 2 && den > 0.0 { num / den } else { 0.0 },
        })
    }
}

/// The sums of pass 3 (each as the in-memory evaluation sums them: from −0 as `Iterator::sum`,
/// from 0 as its folds).
struct ErrorSums {
    norms: Vec<f64>,
    e: [f64; 3],
    /// Σ angle, Σ angle².
    attitude: (f64, f64),
    /// Pairs, Σ translation², Σ rotation².
    rpe: (usize, f64, f64),
    /// Σ ‖e‖², count over the last minute.
    last_minute: (f64, usize),
    /// The same under the first minute's alignment.
    drift: (f64, usize),
    heading_t: f64,
    heading_y: f64,
    /// Σ NEES, within the 95 % point, count.
    nees: (f64, usize, usize),
}

impl Default for ErrorSums {
    fn default() -> Self {
        Self {
            norms: Vec::new(),
            e: [-0.0; 3],
            attitude: (-0.0, -0.0),
            rpe: (0, -0.0, -0.0),
            last_minute: (0.0, 0),
            drift: (0.0, 0),
            heading_t: -0.0,
            heading_y: -0.0,
            nees: (-0.0, 0, 0),
        }
    }
}

/// The results of pass 4.
struct Moments {
    std_xyz: [f64; 3],
    slope_rad_s: f64,
}

/// `later − earlier`, s (0 when either is missing).
fn time_between(earlier: Option<Timestamp>, later: Option<Timestamp>) -> f64 {
    match (earlier, later) {
        (Some(a), Some(b)) => b.secs_since(a),
        _ => 0.0,
    }
}

/// The poses of the TUM file at `path`, in order (a malformed line is an error naming it).
pub(crate) fn truth_poses(path: &Path) -> io::Result<impl Iterator<Item = io::Result<Pose>>> {
    let file = crate::io_safety::open_regular(path)?;
    let name = path.display().to_string();
    Ok(tum_poses(io::BufReader::new(file))
        .map(move |r| r.map_err(|e| io::Error::other(format!("{name}: {e}")))))
}

#[cfg(test)]
mod tests;
