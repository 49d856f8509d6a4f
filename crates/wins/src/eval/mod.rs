//! Trajectory evaluation: an estimated trajectory (and AP positions) against the truth.
//!
//! ```text
//! estimate, truth ─► associate (nearest time ≤ 10 ms) ─► align positions ─► Metrics
//!                                                         └─► same transform on estimated APs
//! ```
//!
//! The numbers are the paper's (ATE, per-axis error spread, AP error) and the usual VIO ones of
//! Zhang & Scaramuzza (IROS 2018). The alignment is a heading and a translation by default
//! ([`AlignMode::PosYaw`]: gravity is observed); with [`AlignMode::Se3`] they are computed as evo
//! 1.38 computes them, so that `ate_rmse_m` equals `evo_ape tum TRUTH EST -a`, and `rpe_*` equal
//! `evo_rpe tum TRUTH EST --delta Δ --delta_unit f` either way (`scripts/evo_check.sh` checks both). Beside them, what a flight controller's user watches on a
//! long flight (`drift`): the error in the last minute, the drift from an alignment fixed on the
//! first minute, the heading drift rate and the position jumps; and whether the covariance
//! reported with the poses is honest (`nees`). The definitions are on the fields
//! of [`Metrics`].

pub(crate) mod align;
pub(crate) mod aps;
pub(crate) mod associate;
mod attitude_alignment;
pub mod bound;
pub(crate) mod drift;
mod evaluate;
pub(crate) mod metrics;
pub mod nees;
pub(crate) mod records;
pub(crate) mod rpe;
pub(crate) mod scan;
pub(crate) mod stream;

use serde::{Deserialize, Serialize};

pub use align::{AlignMode, Alignment, align, align_poses, umeyama};
pub use aps::{EstimatedAp, read_estimated_aps, write_estimated_aps};
pub use associate::{Association, associate};
pub use drift::{DRIFT_WINDOW_S, JUMP_THRESHOLD_M};
pub use evaluate::{evaluate, position_error_rms_from, position_error_series};
pub use metrics::{Metrics, SentMetrics};
pub use nees::{
    CovarianceRow, NEES_95_3DOF, NeesSummary, covariance_of_each_pose, mean_nees_band,
    position_nees, read_position_covariance,
};
pub use rpe::{RelativePoseError, relative_pose_errors};

use crate::check::Problems;
use crate::time::NANOS_PER_SEC;

/// Default association tolerance, s (evo's `--t_max_diff` default).
pub const DEFAULT_MAX_TIME_DIFF_S: f64 = 0.01;
/// Default RPE frame delta (evo_rpe's default).
pub const DEFAULT_RPE_DELTA_FRAMES: usize = 1;

/// Evaluation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalOptions {
    /// Largest `|t_est − t_truth|` of an associated pair, s. The default 0.01 suits truth at
    /// ≥ 100 Hz; sparser truth needs at least half its period.
    pub max_time_diff_s: f64,
    /// RPE delta Δ in associated poses (≥ 1); 1 compares consecutive estimated poses.
    pub rpe_delta_frames: usize,
    /// What the alignment before the ATE may apply: `"posyaw"` (a heading and a translation:
    /// gravity is observed) or `"se3"` (any rotation, as `evo_ape -a`).
    pub align: AlignMode,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            max_time_diff_s: DEFAULT_MAX_TIME_DIFF_S,
            rpe_delta_frames: DEFAULT_RPE_DELTA_FRAMES,
            align: AlignMode::default(),
        }
    }
}

impl EvalOptions {
    /// Every setting in its range, under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.in_range(prefix, "max_time_diff_s", self.max_time_diff_s, 0.0, 3600.0);
        p.at_least(prefix, "rpe_delta_frames", self.rpe_delta_frames, 1);
        p
    }

    /// Checks the ranges ([`EvalOptions::problems`]).
    pub fn validate(&self) -> Result<(), EvalError> {
        self.problems("")
            .into_result()
            .map_err(EvalError::InvalidOption)
    }

    pub(crate) fn max_time_diff_ns(&self) -> i64 {
        (self.max_time_diff_s * NANOS_PER_SEC as f64).round() as i64
    }
}

/// Why an evaluation could not be made.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// A trajectory has no pose.
    #[error("the {trajectory} trajectory is empty")]
    EmptyTrajectory {
        /// `"estimate"` or `"truth"`.
        trajectory: &'static str,
    },
    /// A pose earlier than the one before it.
    #[error("the {trajectory} trajectory goes back in time at pose {index}")]
    Unsorted {
        /// `"estimate"` or `"truth"`.
        trajectory: &'static str,
        /// Index of the pose.
        index: usize,
    },
    /// A position or quaternion with a NaN or infinite component.
    #[error("the {trajectory} trajectory has a non-finite pose at index {index}")]
    NonFinite {
        /// `"estimate"` or `"truth"`.
        trajectory: &'static str,
        /// Index of the pose.
        index: usize,
    },
    /// Association found no pair.
    #[error(
        "no estimated pose within {max_time_diff_s} s of a truth pose ({est_poses} estimated, \
         {truth_poses} truth poses): different clocks?"
    )]
    NoMatches {
        /// Estimated poses.
        est_poses: usize,
        /// Truth poses.
        truth_poses: usize,
        /// The tolerance, s.
        max_time_diff_s: f64,
    },
    /// Point lists of different lengths given to [`umeyama`].
    #[error("{est} estimated points but {truth} truth points")]
    LengthMismatch {
        /// Estimated points.
        est: usize,
        /// Truth points.
        truth: usize,
    },
    /// Too few associated poses to align.
    #[error("{pairs} associated poses, at least {needed} are needed to align")]
    TooFewPairs {
        /// Pairs available.
        pairs: usize,
        /// Pairs needed.
        needed: usize,
    },
    /// The estimated positions cannot fix the alignment's rotation: constant, collinear (SE(3)),
    /// or without horizontal motion (a heading).
    #[error(
        "cannot align: the estimated positions are collinear, do not move, or (for a heading) do \
         not move horizontally (cross-covariance singular values {singular_values:?})"
    )]
    Degenerate {
        /// Singular values of the cross-covariance, decreasing, m².
        singular_values: [f64; 3],
    },
    /// Not enough associated poses for one RPE pair.
    #[error("{poses} associated poses: too few for a relative pose error over {delta} frames")]
    RpeTooShort {
        /// Associated poses.
        poses: usize,
        /// The frame delta.
        delta: usize,
    },
    /// An estimated AP whose name is not among the truth APs.
    #[error("estimated AP {name:?} has no truth position")]
    ApNotInTruth {
        /// The AP name.
        name: String,
    },
    /// Two estimated APs with one name.
    #[error("estimated AP {name:?} is listed twice")]
    DuplicateAp {
        /// The AP name.
        name: String,
    },
    /// A malformed row of an estimated-AP CSV.
    #[error("AP positions, row {row}: {reason}")]
    ApCsv {
        /// 1-based data row (0: the header).
        row: usize,
        /// What is wrong.
        reason: String,
    },
    /// A malformed row of a `covariance.csv`.
    #[error("covariance, row {row}: {reason}")]
    CovarianceCsv {
        /// 1-based data row (0: the header).
        row: usize,
        /// What is wrong.
        reason: String,
    },
    /// Options out of range (every one listed).
    #[error("invalid evaluation options: {0}")]
    InvalidOption(Problems),
    /// A trajectory could not be read again for one of the evaluation's passes.
    #[error("reading a trajectory again: {0}")]
    Read(String),
}

/// A pose at `t_ms` ms, position `p`, heading `yaw` rad (for the evaluation's tests).
#[cfg(test)]
pub(crate) fn test_pose(
    t_ms: i64,
    p: nalgebra::Vector3<f64>,
    yaw: f64,
) -> crate::dataset::truth::Pose {
    crate::dataset::truth::Pose {
        t: crate::time::Timestamp(t_ms * 1_000_000),
        p_b_in_w: p,
        world_from_body: nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::truth::Pose;
    use crate::time::Timestamp;
    use nalgebra::{UnitQuaternion, Vector3};

    /// 100 Hz for 10 s; `helix` false: a straight line.
    fn flight(helix: bool) -> Vec<Pose> {
        (0..1000)
            .map(|k| {
                let s = k as f64 * 0.01;
                let p = if helix {
                    Vector3::new(s.cos(), s.sin(), 0.1 * s)
                } else {
                    Vector3::new(s, 0.0, 1.0)
                };
                Pose {
                    t: Timestamp(k * 10_000_000),
                    p_b_in_w: p,
                    world_from_body: UnitQuaternion::identity(),
                }
            })
            .collect()
    }

    fn eval(est: &[Pose], truth: &[Pose]) -> Result<Metrics, EvalError> {
        evaluate(est, truth, &[], &[], &EvalOptions::default())
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let (line, helix) = (flight(false), flight(true));
        assert!(eval(&helix, &helix).is_ok_and(|m| !m.alignment.rotation_from_attitudes));
        // A level line fixes a heading, not a rotation about itself: SE(3) takes the rotation
        // from the attitudes.
        assert!(eval(&line, &line).is_ok_and(|m| !m.alignment.rotation_from_attitudes));
        let se3 = EvalOptions {
            align: AlignMode::Se3,
            ..EvalOptions::default()
        };
        let m = evaluate(&line, &line, &[], &[], &se3).unwrap();
        assert!(
            m.alignment.rotation_from_attitudes && m.ate_rmse_m < 1e-9,
            "{m:?}"
        );
        // A climb straight up fixes no heading: the attitudes do. The estimate's world is the
        // truth's turned 30° about the vertical, its positions (on the axis) unchanged.
        let column: Vec<Pose> = line
            .iter()
            .map(|p| Pose {
                p_b_in_w: Vector3::new(0.0, 0.0, p.p_b_in_w.x),
                ..*p
            })
            .collect();
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians());
        let turned: Vec<Pose> = column
            .iter()
            .map(|p| Pose {
                world_from_body: turn.inverse() * p.world_from_body,
                ..*p
            })
            .collect();
        let m = eval(&turned, &column).unwrap();
        let yaw = m.alignment.isometry().rotation.euler_angles().2;
        assert!(m.alignment.rotation_from_attitudes, "{m:?}");
        assert!((yaw.to_degrees() - 30.0).abs() < 1e-6, "{yaw}");
        assert!(
            m.ate_rmse_m < 1e-9 && m.attitude_error_rmse_deg < 1e-6,
            "{m:?}"
        );
        // ... unless the attitudes disagree as well (every other one a half turn off).
        let torn: Vec<Pose> = column
            .iter()
            .enumerate()
            .map(|(k, p)| Pose {
                world_from_body: UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    std::f64::consts::PI * (k % 2) as f64,
                ) * p.world_from_body,
                ..*p
            })
            .collect();
        assert!(matches!(
            eval(&torn, &column),
            Err(EvalError::Degenerate { .. })
        ));
        let too_few = eval(&helix[..2], &helix);
        assert!(matches!(
            too_few,
            Err(EvalError::TooFewPairs { pairs: 2, .. })
        ));
        let mut nan = helix.clone();
        nan[3].p_b_in_w.y = f64::NAN;
        let non_finite = eval(&nan, &helix);
        assert!(matches!(
            non_finite,
            Err(EvalError::NonFinite { index: 3, .. })
        ));
        let far = eval(&helix[..10], &helix[500..]);
        assert!(matches!(
            far,
            Err(EvalError::NoMatches { est_poses: 10, .. })
        ));
        // Three poses align, but an RPE over 3 frames needs four.
        let options = EvalOptions {
            rpe_delta_frames: 3,
            ..EvalOptions::default()
        };
        let short = evaluate(&helix[..3], &helix, &[], &[], &options);
        assert!(matches!(
            short,
            Err(EvalError::RpeTooShort { poses: 3, delta: 3 })
        ));
    }

    #[test]
    fn options_are_validated() {
        assert!(EvalOptions::default().validate().is_ok());
        let bad = [
            EvalOptions {
                rpe_delta_frames: 0,
                ..EvalOptions::default()
            },
            EvalOptions {
                max_time_diff_s: -0.1,
                ..EvalOptions::default()
            },
            EvalOptions {
                max_time_diff_s: f64::NAN,
                ..EvalOptions::default()
            },
        ];
        for options in bad {
            assert!(matches!(
                options.validate(),
                Err(EvalError::InvalidOption(_))
            ));
        }
        let parsed: EvalOptions = toml::from_str("rpe_delta_frames = 10").expect("toml");
        assert_eq!(
            (parsed.rpe_delta_frames, parsed.max_time_diff_s),
            (10, 0.01)
        );
        assert!(toml::from_str::<EvalOptions>("delta = 1").is_err());
    }
}
