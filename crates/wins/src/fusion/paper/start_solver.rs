//! The paper's linear window as the default estimator's start solver
//! ([`crate::fusion::proposal`]): initialization-free, it proposes positions, velocities,
//! gravity and APs from zeros once every AP's marginal σ is below its own convergence threshold;
//! its own convergence test is off (the default estimator decides).

use nalgebra::Vector3;

use super::estimator::{LinearConfig, LinearEstimator};
use crate::fusion::bearing::Bearing;
use crate::fusion::error::EstimatorError;
use crate::fusion::pose::Step;
use crate::fusion::proposal::{StartSolution, StartSolver, StartSolverFactory};
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// The linear estimator proposing a start.
#[derive(Clone, Debug)]
struct LinearStart {
    estimator: LinearEstimator,
    /// Its solution is proposed when its APs' largest σ is below this, m.
    candidate_ap_sigma_m: f64,
}

/// Start solvers of the paper's window with `config`: its convergence threshold
/// (`converged_ap_sigma_m`) becomes the threshold of a proposal, and its own convergence test is
/// off.
pub fn linear_start_solver(config: LinearConfig) -> StartSolverFactory {
    let mut config = config;
    let candidate_ap_sigma_m = config.window.converged_ap_sigma_m;
    config.window.converged_ap_sigma_m = 0.0;
    StartSolverFactory::new(move |prior| {
        let estimator = match prior {
            Some(p) => LinearEstimator::with_start(config.clone(), p),
            None => LinearEstimator::new(config.clone()),
        };
        Box::new(LinearStart {
            estimator,
            candidate_ap_sigma_m,
        })
    })
}

impl StartSolver for LinearStart {
    fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError> {
        self.estimator.push_imu(s)
    }

    fn push_bearings(
        &mut self,
        t: Timestamp,
        bearings: Vec<Bearing>,
    ) -> Result<(), EstimatorError> {
        self.estimator.push_bearings(t, bearings)
    }

    fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        self.estimator.window().gyro_bias_rad_s()
    }

    fn proposal(&self) -> Option<StartSolution> {
        let w = self.estimator.window();
        if w.num_aps() == 0 || w.max_ap_sigma_m() >= self.candidate_ap_sigma_m {
            return None;
        }
        Some(StartSolution {
            frames: w.frames().collect(),
            aps_in_b0: (0..w.num_aps()).map(|l| w.ap_in_b0(l)).collect(),
            gyro_bias_rad_s: w.gyro_bias_rad_s(),
            accel_bias_m_s2: w.accel_bias_m_s2(),
        })
    }

    fn clone_box(&self) -> Box<dyn StartSolver> {
        Box::new(self.clone())
    }
}
