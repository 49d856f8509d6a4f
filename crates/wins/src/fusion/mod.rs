//! WiFi-inertial fusion (paper Sections III, IV-A and V).
//!
//! - [`attitude`]: drift-free attitude by relaxed rotation averaging (Sec. IV-A) with absolute
//!   gravity and bearing rows, and the gyro bias from it.
//! - [`bearing`]: the AoA measurement as the fusion stages take it (cone angle plus side).
//! - [`window`]: the linear sliding-window estimator (Sec. V), initialization-free.
//! - [`nonlinear`]: the 6-DoF nonlinear sliding window, the default estimator.
//! - [`estimator`]: [`estimator::Wins`], the push API (IMU samples and bearings in, poses out).
//! - [`choice`]: which of the two a run uses (`estimator = "nonlinear"` or `"paper"`).
//! - [`ekf`]: the feasibility-study EKF baseline (Sec. III), needs an initial state.
//! - [`observability`]: the observability matrix of the Sec. III model and its nullspace
//!   (`eqn:nullspace`).

pub mod attitude;
pub mod bearing;
pub mod choice;
pub mod ekf;
pub mod estimator;
pub mod nonlinear;
pub mod observability;
pub mod window;
