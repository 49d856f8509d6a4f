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
/// off. Its solution is read only when a start is tried, at most once per `retry_share` of the
/// start window's span ([`crate::fusion::nonlinear::NonlinearConfig::start_retry_share`]): its
/// window is solved at that cadence too (`startup_solves_per_window = 1 / retry_share`; solving
/// more often costs a fifth of a failing start's time and is never read).
pub fn linear_start_solver(config: LinearConfig, retry_share: f64) -> StartSolverFactory {
    let candidate_ap_sigma_m = config.window.converged_ap_sigma_m;
    let config = start_solver_config(config, retry_share);
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

/// The paper's window as a start solver: its own convergence test off, and at most
/// `1 / retry_share` solves per window length (never more than `config` asks for).
fn start_solver_config(config: LinearConfig, retry_share: f64) -> LinearConfig {
    let mut config = config;
    config.window.converged_ap_sigma_m = 0.0;
    if retry_share > 0.0 {
        let per_window = (1.0 / retry_share).round().clamp(1.0, 1e6) as usize;
        config.window.startup_solves_per_window =
            config.window.startup_solves_per_window.min(per_window);
    }
    config
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::ImuNoise;

    #[test]
    fn the_start_solver_solves_at_the_tries_cadence() {
        let config = LinearConfig::new(ImuNoise {
            gyro_noise_density_rad_s_sqrt_hz: 1e-4,
            gyro_bias_random_walk_rad_s2_sqrt_hz: 1e-5,
            gyro_turn_on_bias_rad_s: 1e-3,
            accel_noise_density_m_s2_sqrt_hz: 1e-3,
            accel_bias_random_walk_m_s3_sqrt_hz: 1e-4,
            accel_turn_on_bias_m_s2: 0.05,
        });
        assert_eq!(config.window.startup_solves_per_window, 50);
        let at = |share: f64| {
            start_solver_config(config.clone(), share)
                .window
                .startup_solves_per_window
        };
        assert_eq!(at(0.1), 10);
        assert_eq!(at(0.25), 4);
        // Never more often than the window's own setting, and a share of 0 keeps it.
        assert_eq!(at(0.01), 50);
        assert_eq!(at(0.0), 50);
        let c = start_solver_config(config, 0.1);
        assert_eq!(c.window.converged_ap_sigma_m, 0.0);
    }
}
