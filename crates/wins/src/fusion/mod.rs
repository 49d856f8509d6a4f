//! WiFi-inertial fusion (paper Sections III, IV-A and V).
//!
//! - [`bearing`]: the AoA measurement as the fusion stages take it (cone angle plus side).
//! - [`window`]: the linear sliding-window estimator (Sec. V), initialization-free.
//! - [`ekf`]: the feasibility-study EKF baseline (Sec. III), needs an initial state.
//! - [`observability`]: the observability matrix of the Sec. III model and its nullspace
//!   (`eqn:nullspace`).

pub mod bearing;
pub mod ekf;
pub mod observability;
pub mod window;
