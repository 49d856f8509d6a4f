//! The interface of a start solver: what proposes a first state to the default estimator when
//! no state is known (a flight started in the air, a start after an IMU gap). The paper's linear
//! window is one (`paper::estimator::LinearEstimator`): initialization-free, it solves
//! positions, velocities, gravity and APs from zeros. The default estimator
//! ([`super::nonlinear`]) takes any start solver through this interface and imports no
//! estimator of its own kind; [`super::choice`] hands it the paper's.

use std::fmt;
use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};

use super::bearing::Bearing;
use super::error::EstimatorError;
use super::pose::Step;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// One frame's estimate of a linear start solver, in its own first frame `b0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameEstimate {
    /// Frame time.
    pub t: Timestamp,
    /// `p_k` in `b0`, m.
    pub p_in_b0: Vector3<f64>,
    /// `v_k` in `b_k`, m/s.
    pub v_in_bk: Vector3<f64>,
    /// Upward gravity `g_k` in `b_k`, m/s².
    pub g_in_bk: Vector3<f64>,
    /// `R_{b_k}^{b_0}`.
    pub b0_from_bk: UnitQuaternion<f64>,
}

/// What is known at the start of a window (a static initialization, or the state a lost
/// estimate last had): the first frame's gravity and velocity (in `b0`, the first frame) and the
/// gyro bias, each with its 1σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartPrior {
    /// Upward gravity in `b0`, m/s².
    pub gravity_in_b0: Vector3<f64>,
    /// 1σ per axis, m/s².
    pub gravity_sigma_m_s2: f64,
    /// Velocity in `b0`, m/s.
    pub velocity_in_b0: Vector3<f64>,
    /// 1σ per axis, m/s.
    pub velocity_sigma_m_s: f64,
    /// Gyro bias, rad/s (its 1σ stays the solver's prior).
    pub gyro_bias_rad_s: Vector3<f64>,
}

/// A start solver's solution, proposed once its APs are placed well enough.
#[derive(Clone, Debug, PartialEq)]
pub struct StartSolution {
    /// Every frame the solver holds, oldest first.
    pub frames: Vec<FrameEstimate>,
    /// Every AP in `b0` (`None`: not placed).
    pub aps_in_b0: Vec<Option<Vector3<f64>>>,
    /// Gyro bias, rad/s.
    pub gyro_bias_rad_s: Vector3<f64>,
    /// Accelerometer bias, m/s².
    pub accel_bias_m_s2: Vector3<f64>,
}

/// A start solver (module doc): fed the same IMU samples and bearings as the estimator that
/// holds it, until that estimator has started.
pub trait StartSolver: fmt::Debug + Send {
    /// Integrates one IMU sample; the poses it gives are not converged ones.
    fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError>;
    /// Queues a frame of bearings at `t`.
    fn push_bearings(&mut self, t: Timestamp, bearings: Vec<Bearing>)
    -> Result<(), EstimatorError>;
    /// Its gyro bias now, rad/s.
    fn gyro_bias_rad_s(&self) -> Vector3<f64>;
    /// Its solution, once it has one worth proposing.
    fn proposal(&self) -> Option<StartSolution>;
    /// A copy of it.
    fn clone_box(&self) -> Box<dyn StartSolver>;
}

impl Clone for Box<dyn StartSolver> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

/// Makes a start solver: from zeros (`None`), or from what is known.
#[derive(Clone)]
pub struct StartSolverFactory(
    Arc<dyn Fn(Option<StartPrior>) -> Box<dyn StartSolver> + Send + Sync>,
);

impl StartSolverFactory {
    /// A factory from a function.
    pub fn new(
        make: impl Fn(Option<StartPrior>) -> Box<dyn StartSolver> + Send + Sync + 'static,
    ) -> Self {
        Self(Arc::new(make))
    }

    /// A new start solver.
    pub fn make(&self, prior: Option<StartPrior>) -> Box<dyn StartSolver> {
        (self.0)(prior)
    }
}

impl fmt::Debug for StartSolverFactory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("StartSolverFactory")
    }
}
