//! The estimator a run uses (`estimator` in the configuration): the nonlinear one
//! ([`super::nonlinear`], the default) or the paper's linear window
//! ([`super::paper::estimator::LinearEstimator`]), behind one push API so that a sweep can compare them side by
//! side.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::bearing::Bearing;
use super::error::EstimatorError;
use super::nonlinear::{NonlinearConfig, NonlinearEstimator, PhaseChange, Sensors};
use super::paper::estimator::{LinearConfig, LinearEstimator};
use super::paper::start_solver::linear_start_solver;
use super::pose::{ApInWorld, Step};
use super::stats::EstimatorStats;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// Which estimator (`estimator = "nonlinear"` or `"paper"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EstimatorKind {
    /// The 6-DoF nonlinear sliding window, started from the rest (or, airborne, from the
    /// linear window), the default (docs/ESTIMATOR.md).
    #[default]
    Nonlinear,
    /// The paper's linear sliding window (Sec. V).
    Paper,
}

/// One of the two estimators.
#[derive(Clone, Debug)]
pub enum Estimator {
    /// The paper's.
    Paper(Box<LinearEstimator>),
    /// The nonlinear window.
    Nonlinear(Box<NonlinearEstimator>),
}

impl Estimator {
    /// A fresh estimator of `kind`; `has_baro`: barometer samples will come (the paper's
    /// estimator ignores them).
    pub fn new(
        kind: EstimatorKind,
        linear: LinearConfig,
        nonlinear: NonlinearConfig,
        has_baro: bool,
    ) -> Self {
        match kind {
            EstimatorKind::Paper => Self::Paper(Box::new(LinearEstimator::new(linear))),
            EstimatorKind::Nonlinear => {
                let sensors = Sensors {
                    imu_noise: linear.imu_noise.clone(),
                    imu_gap: linear.imu_gap,
                    body_from_array: linear.window.body_from_array,
                };
                // The paper's window proposes the start when no state is known (airborne).
                let start_solver = linear_start_solver(linear, nonlinear.start_retry_share);
                Self::Nonlinear(Box::new(NonlinearEstimator::new(
                    nonlinear,
                    sensors,
                    has_baro,
                    start_solver,
                )))
            }
        }
    }

    /// Integrates one IMU sample (see [`LinearEstimator::push_imu`]).
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError> {
        match self {
            Self::Paper(w) => w.push_imu(s),
            Self::Nonlinear(n) => n.push_imu(s),
        }
    }

    /// Runs a keyframe's solve that is due (the nonlinear estimator's
    /// [`NonlinearEstimator::solve_pending`]); nothing for the paper's.
    pub fn solve_pending(&mut self) {
        if let Self::Nonlinear(n) = self {
            n.solve_pending();
        }
    }

    /// Queues a frame of bearings at `t`.
    pub fn push_bearings(
        &mut self,
        t: Timestamp,
        bearings: Vec<Bearing>,
    ) -> Result<(), EstimatorError> {
        match self {
            Self::Paper(w) => w.push_bearings(t, bearings),
            Self::Nonlinear(n) => n.push_bearings(t, bearings),
        }
    }

    /// Queues a barometer altitude (the paper's estimator has no barometer: ignored).
    pub fn push_baro(&mut self, t: Timestamp, altitude_m: f64) -> Result<(), EstimatorError> {
        match self {
            Self::Paper(_) => Ok(()),
            Self::Nonlinear(n) => n.push_baro(t, altitude_m),
        }
    }

    /// Counters.
    pub fn stats(&self) -> EstimatorStats {
        match self {
            Self::Paper(w) => w.stats(),
            Self::Nonlinear(n) => n.stats(),
        }
    }

    /// The default estimator's phases, with when and why each began (the paper's estimator
    /// keeps none: empty).
    pub fn timeline(&self) -> &[PhaseChange] {
        match self {
            Self::Paper(_) => &[],
            Self::Nonlinear(n) => n.timeline(),
        }
    }

    /// When the estimate first converged.
    pub fn converged_at(&self) -> Option<Timestamp> {
        match self {
            Self::Paper(w) => w.converged_at(),
            Self::Nonlinear(n) => n.converged_at(),
        }
    }

    /// Whether the estimate is converged now.
    pub fn is_converged(&self) -> bool {
        match self {
            Self::Paper(w) => w.window().converged_at().is_some(),
            Self::Nonlinear(n) => n.is_tracking(),
        }
    }

    /// Changes of the frame the poses' `b0` parts are in (restarts, starts).
    pub fn epoch(&self) -> u64 {
        match self {
            Self::Paper(w) => w.stats().restarts,
            Self::Nonlinear(n) => n.epoch(),
        }
    }

    /// AP `l` in the `b0` frame of the current poses, once converged.
    pub fn ap_in_b0(&self, l: usize) -> Option<Vector3<f64>> {
        match self {
            Self::Paper(w) => w.window().ap_in_b0(l),
            Self::Nonlinear(n) => n.ap_in_b0(l),
        }
    }

    /// AP `l` in the output frame `w` and its largest σ, m.
    pub fn ap_in_w(&self, l: usize) -> Option<ApInWorld> {
        match self {
            Self::Paper(w) => {
                let c = w.window().ap_in_b0(l)?;
                let world_from_b0 = w.world_from_b0();
                let r = world_from_b0.rotation.to_rotation_matrix();
                let covariance_in_b0 = w
                    .window()
                    .ap_covariance(l)
                    .unwrap_or_else(|| Matrix3::from_diagonal_element(f64::INFINITY));
                Some(ApInWorld {
                    p_in_w: world_from_b0.transform_point(&c.into()).coords,
                    covariance_in_w: r.matrix() * covariance_in_b0 * r.matrix().transpose(),
                })
            }
            Self::Nonlinear(n) => n.ap_in_w(l),
        }
    }

    /// The σ of the sine of the cone angle toward AP `l` that the state predicts, from the
    /// window's joint covariance of the newest pose, the AP and the bearings' common offset
    /// ([`crate::fusion::nonlinear::NonlinearWindow::predicted_sin`]); `None` for the paper's
    /// window (which keeps no such covariance) or when the AP is not placed.
    pub fn predicted_sin_sigma(&self, l: usize) -> Option<f64> {
        match self {
            Self::Paper(_) => None,
            Self::Nonlinear(n) => n.window()?.predicted_sin(l).map(|(_, sigma)| sigma),
        }
    }

    /// The gyro bias now, rad/s.
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        match self {
            Self::Paper(w) => w.window().gyro_bias_rad_s(),
            Self::Nonlinear(n) => n.gyro_bias_rad_s(),
        }
    }

    /// How badly the window's state explains its bearings (lower is more consistent; compare
    /// only within one estimator kind): the nonlinear window's mean robust cost per bearing
    /// (`Σ ρ(e²)/n`, `e` the residual in σ), the paper's window's RMS of the AoA residuals in σ;
    /// `None` without a window or bearings.
    pub fn bearing_misfit(&self) -> Option<f64> {
        match self {
            Self::Paper(w) => w.window().aoa_residual_rms(),
            Self::Nonlinear(n) => {
                let fit = n.window()?.fit();
                (fit.bearings > 0).then(|| fit.bearing_robust / fit.bearings as f64)
            }
        }
    }

    /// The bearings' common `sin θ` offset β the window estimates and its σ
    /// ([`crate::fusion::nonlinear::NonlinearConfig::sin_bias_sigma`]); `None` when not
    /// estimated or not tracking.
    pub fn sin_bias(&self) -> Option<(f64, f64)> {
        match self {
            Self::Paper(_) => None,
            Self::Nonlinear(n) => n.window()?.sin_bias(),
        }
    }
}
