//! The figures' truth side: the estimate aligned to the truth as the metrics align it (the
//! associated poses, [`crate::eval::align_poses`] with the options' mode), the truth's track,
//! height and attitude, and the position error per axis.

use nalgebra::{Matrix3, Vector3};

use super::read::RunFiles;
use super::{AoaFigure, FigureError, Points, break_wraps, euler_deg, insert_gaps};
use crate::dataset::truth::{Pose, Truth};
use crate::eval::{Alignment, EvalOptions, align_poses, associate};

/// The truth poses drawn at most, evenly thinned (the truth comes at the IMU's rate).
const MAX_TRUTH_POINTS: usize = 5000;

/// With a truth: what is drawn of it, and the errors.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthFigures {
    /// The true track from above, (x, y) m.
    pub track_xy: Points,
    /// True height over time, (s, m).
    pub height: Points,
    /// True roll, pitch, yaw over time, (s, degrees).
    pub attitude_deg: [Points; 3],
    /// The true APs: name and (x, y) m.
    pub aps_xy: Vec<(String, (f64, f64))>,
    /// The aligned estimate minus the truth along x, y, z over time, (s, m), with gaps where
    /// the estimate has them; [`super::RunFigures::sigma_m`] is its ±σ band.
    pub error_m: [Points; 3],
}

/// The alignment of the estimate to the truth.
pub(super) struct Aligned(Alignment);

impl Aligned {
    /// The alignment of `files`' poses to `truth`'s, as the metrics make it.
    pub(super) fn new(
        files: &RunFiles,
        truth: &Truth,
        options: &EvalOptions,
    ) -> Result<Self, FigureError> {
        let max_ns = (options.max_time_diff_s * 1e9).round() as i64;
        let pairs = associate(&files.poses, &truth.poses, max_ns)?.pairs;
        let est: Vec<&Pose> = pairs.iter().map(|&(i, _)| &files.poses[i]).collect();
        let tru: Vec<&Pose> = pairs.iter().map(|&(_, j)| &truth.poses[j]).collect();
        Ok(Self(align_poses(&est, &tru, options.align)?))
    }

    /// Its rotation (truth's world from the estimate's).
    pub(super) fn rotation(&self) -> Matrix3<f64> {
        *self.0.isometry().rotation.to_rotation_matrix().matrix()
    }

    /// A point of the estimate's world in the truth's.
    pub(super) fn point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.0.apply_point(p)
    }

    /// A pose of the estimate in the truth's world.
    pub(super) fn pose(&self, p: &Pose) -> Pose {
        self.0.apply_pose(p)
    }

    /// The truth's figures beside the `aligned` poses (gaps before `breaks`).
    pub(super) fn figures(
        &self,
        truth: &Truth,
        aligned: &[Pose],
        breaks: &[usize],
    ) -> TruthFigures {
        let stride = truth.poses.len() / MAX_TRUTH_POINTS + 1;
        let thinned: Vec<&Pose> = truth.poses.iter().step_by(stride).collect();
        let over_time =
            |f: &dyn Fn(&Pose) -> f64| thinned.iter().map(|p| (p.t.as_secs_f64(), f(p))).collect();
        let attitude_deg = [0, 1, 2].map(|k| {
            let angles: Points = over_time(&|p| euler_deg(&p.world_from_body)[k]);
            if k == 2 { break_wraps(angles) } else { angles }
        });
        // The truth pose nearest each estimated one (both in time order).
        let mut j = 0;
        let nearest: Vec<Option<&Pose>> = aligned
            .iter()
            .map(|p| {
                while j + 1 < truth.poses.len()
                    && (truth.poses[j + 1].t.0 - p.t.0).abs() <= (truth.poses[j].t.0 - p.t.0).abs()
                {
                    j += 1;
                }
                truth.poses.get(j)
            })
            .collect();
        let error_m = [0, 1, 2].map(|k| {
            let errors = aligned
                .iter()
                .zip(&nearest)
                .map(|(p, t)| {
                    let e = t.map_or(f64::NAN, |t| p.p_b_in_w[k] - t.p_b_in_w[k]);
                    (p.t.as_secs_f64(), e)
                })
                .collect();
            insert_gaps(errors, breaks)
        });
        TruthFigures {
            track_xy: thinned
                .iter()
                .map(|p| (p.p_b_in_w.x, p.p_b_in_w.y))
                .collect(),
            height: over_time(&|p| p.p_b_in_w.z),
            attitude_deg,
            aps_xy: truth
                .aps
                .iter()
                .map(|a| (a.name.clone(), (a.x_m, a.y_m)))
                .collect(),
            error_m,
        }
    }
}

/// Each AP's true direct-path AoA of its received packets, matched by name.
pub(super) fn add_true_aoa(aoa: &mut [AoaFigure], truth: &Truth) {
    for figure in aoa {
        let Some(i) = truth.aps.iter().position(|a| a.name == figure.name) else {
            continue;
        };
        figure.truth = truth
            .packets
            .get(i)
            .map(|rows| {
                rows.iter()
                    .filter(|r| r.received)
                    .map(|r| (r.t_ns as f64 * 1e-9, r.aoa_deg))
                    .collect()
            })
            .unwrap_or_default();
    }
}
