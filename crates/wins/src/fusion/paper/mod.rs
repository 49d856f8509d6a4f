//! The paper's method (Zhang, Wang, Jiang), kept as the comparison for the default estimator:
//!
//! - [`estimator`]: [`estimator::LinearEstimator`], the paper's estimator as a push API (IMU
//!   samples and bearings in, poses out; `estimator = "paper"`);
//! - [`window`]: its linear sliding window (Sec. V), initialization-free;
//! - [`ekf`]: the feasibility-study EKF (Sec. III), needs an initial state;
//! - [`observability`]: the observability matrix of the Sec. III model and its nullspace
//!   (`eqn:nullspace`).
//!
//! The paper's relaxed rotation averaging (Sec. IV-A) is not here: fed back in the loop it made
//! the attitude worse than the window's joint gyro-bias estimate (docs/RESULTS.md), and nothing
//! used it.

pub mod ekf;
pub mod estimator;
pub mod observability;
pub mod start_solver;
pub mod window;
