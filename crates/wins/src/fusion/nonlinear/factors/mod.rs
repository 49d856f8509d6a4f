//! The factors of the nonlinear window, each a residual with its analytic Jacobian beside its
//! finite-difference test (through the one helper `state::testing`),
//! and each handing the solver its linearization ([`crate::fusion::arrow::Linearized`]):
//!
//! - [`imu`]: IMU preintegration on the manifold with first-order bias correction;
//! - [`cone`]: the exact AoA model of a linear array, `sin θ = ŷ_a · unit(c − p_array)`;
//! - [`baro`]: the barometer's altitude, `z + o`, with the offset `o` a state;
//! - [`zero_velocity`]: a keyframe held at zero velocity while the IMU is still;
//! - [`range_anchor`]: after a hole, an AP's horizontal range from the path across it.
//!
//! The marginalization prior, in information form, is the window's own
//! ([`crate::fusion::nonlinear::solve`]).

pub mod baro;
pub mod cone;
pub mod imu;
pub mod range_anchor;
pub mod zero_velocity;
