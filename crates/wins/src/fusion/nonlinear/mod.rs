//! The 6-DoF nonlinear sliding-window estimator, started by the paper's linear one.
//!
//! State per keyframe `k` ([`state::NavState`]): attitude `R_k` on SO(3), position, velocity,
//! gyro and accelerometer biases, in a gravity-aligned world frame `w` (z up); every AP's position
//! in 3-D; the barometer's offset when there is one; without a chain calibration, a common offset
//! of every bearing's `sin θ` (what an error in the receive chains' uniform phase step does). The
//! error state of a keyframe is `[δθ, δp, δv, δb_g, δb_a]` with `R = R̂ Exp(δθ)` (15 numbers).
//!
//! Factors, each with an analytic Jacobian beside its finite-difference test:
//! - [`imu_factor`]: IMU preintegration on the manifold with first-order bias correction;
//! - [`cone_factor`]: the exact AoA model of a linear array, `sin θ = ŷ_a · unit(c − p_array)`,
//!   with the lever arm: no front/back decision and no assumption on the AP's height; a robust
//!   (Cauchy) loss so that one reflection cannot drag the solution; `∂r/∂β = 1` for the
//!   bearings' common offset β when it is estimated;
//! - [`baro_factor`]: the barometer's altitude, `z + o`, with the offset `o` a state;
//! - after a hole in the information, a range anchor (`range_anchor`): what the window lost to it
//!   knew of an AP's horizontal range from the path across the hole;
//! - [`zero_velocity`]: a keyframe taken while the IMU is still (on the ground, [`still`]) holds
//!   its velocity at zero;
//! - the marginalization prior ([`window`]), with first-estimate Jacobians.
//!
//! Measurements between keyframes are tied to the keyframe before them through the partial
//! preintegration to their instant ([`state::pose_at`]), so keyframes can be sparser than the
//! bearings. [`estimator::NonlinearEstimator`] runs the start (static initialization, the paper's linear
//! window, the χ² acceptance) and the loss test.

mod anchor;
mod aps;
pub mod baro_factor;
mod bridge;
pub mod cone_factor;
pub mod config;
pub mod estimator;
mod fit;
mod holes;
pub mod imu_factor;
mod late_ap;
mod nullspace;
mod output;
mod phase;
mod proposal;
mod range_anchor;
mod relocate;
pub mod rest;
mod solve;
mod start;
pub mod state;
pub mod still;
mod track;
pub mod triangulate;
pub mod window;
pub mod zero_velocity;

pub use config::NonlinearConfig;
pub use estimator::{NonlinearEstimator, Sensors};
pub use fit::passes_chi2;
pub use phase::{PhaseChange, PhaseKind, Reason};
pub use solve::{SolveError, SolveReport};
pub use window::{FitStats, NonlinearWindow, SubFrame};
