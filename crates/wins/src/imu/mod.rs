//! Inertial measurements. So far: the sample type shared by the simulator, the dataset reader and
//! (later) preintegration.

pub mod sample;

pub use sample::ImuSample;
