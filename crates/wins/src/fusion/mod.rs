//! WiFi-inertial fusion: two estimators behind one push API, and what they share.
//!
//! - [`nonlinear`]: the 6-DoF nonlinear sliding window, the default (docs/ESTIMATOR.md).
//! - [`paper`]: the paper's method, kept as the comparison: its linear sliding window (Sec. V),
//!   the feasibility-study EKF (Sec. III) and the observability analysis (`eqn:nullspace`).
//! - [`choice`]: which of the two a run uses (`estimator = "nonlinear"` or `"paper"`), and the
//!   one place where the default estimator is handed the paper's window as its airborne start.
//!
//! Shared by both, and owned by neither:
//! - [`bearing`]: the AoA measurement as the estimators take it (cone angle plus side);
//! - [`pose`]: what comes out (a pose with its covariance, what one IMU push produced);
//! - [`stats`], [`error`]: what was seen, skipped and refused;
//! - [`frames`]: the rules on the inputs' order (late frames, frames inside an IMU gap);
//! - [`arrow`]: the block-arrow normal equations and their solver;
//! - [`proposal`]: the interface of a start solver: what proposes a first state when no state is
//!   known (the paper's linear window implements it).

pub mod arrow;
pub mod bearing;
pub mod choice;
pub mod error;
pub mod frames;
pub mod nonlinear;
pub mod paper;
pub mod pose;
pub mod proposal;
pub mod stats;
