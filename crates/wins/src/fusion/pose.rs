//! What an estimator gives out: a pose with its covariance, and what one IMU push produced. Both
//! estimators (the default [`super::nonlinear`] and the paper's [`super::paper`]) give these.

use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3};

use super::error::FrameError;
use crate::time::Timestamp;

/// One pose estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseEstimate {
    /// Time.
    pub t: Timestamp,
    /// Body position in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Body velocity in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Attitude.
    pub world_from_body: UnitQuaternion<f64>,
    /// Body position in `b0` (the current window's own frame; a restart starts a new one), m.
    pub p_b_in_b0: Vector3<f64>,
    /// `R_{b}^{b_0}`.
    pub b0_from_body: UnitQuaternion<f64>,
    /// Whether the window had converged.
    pub converged: bool,
    /// Covariance of `[δθ, δp]`: attitude error on the body side (`R = R̂ Exp(δθ)`), rad², and
    /// position in `w`, m² (`None`: the estimator gives none).
    pub covariance: Option<Matrix6<f64>>,
}

/// Output of one IMU push.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Step {
    /// Poses of the frames solved by this push (usually zero or one).
    pub frames: Vec<PoseEstimate>,
    /// The pose propagated to this IMU sample (once a frame exists).
    pub imu_pose: Option<PoseEstimate>,
    /// Frames the window refused in this push, and why (counted in `frames_refused`).
    pub refused: Vec<FrameError>,
}

/// An AP placed by the estimator, in its world frame `w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApInWorld {
    /// Position in `w`, m.
    pub p_in_w: Vector3<f64>,
    /// Marginal covariance of the position in `w` (the window's last solve), m².
    pub covariance_in_w: Matrix3<f64>,
}

impl ApInWorld {
    /// Largest standard deviation of the position (square root of the covariance's largest
    /// eigenvalue), m; infinite when the covariance is not finite.
    pub fn sigma_m(&self) -> f64 {
        if !self.covariance_in_w.iter().all(|x| x.is_finite()) {
            return f64::INFINITY;
        }
        self.covariance_in_w
            .symmetric_eigenvalues()
            .max()
            .max(0.0)
            .sqrt()
    }
}
