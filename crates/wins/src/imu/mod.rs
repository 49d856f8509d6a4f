//! Inertial measurements: the sample type, noise densities and biases, and preintegration between
//! PAoA frames (paper `eqn:alpha`, `eqn:beta`, `eqn:rotation`).

pub(crate) mod biases;
pub mod gap;
pub mod noise_meter;
pub mod preintegration;
pub(crate) mod sample;

pub use biases::ImuBiases;
pub use gap::ImuGap;
pub use noise_meter::NoiseMeter;
pub use preintegration::{Preintegrated, PreintegrationError, Preintegrator};
pub use sample::ImuSample;

/// Standard gravity, m/s² (the magnitude of the upward specific force at rest).
pub const STANDARD_GRAVITY_M_S2: f64 = 9.806_65;
