//! The simulator: flights, IMU and Wi-Fi channels, written as the files a real rig produces.
//!
//! ```text
//!  scenario (TOML) ─► trajectory + yaw ─► body motion (quadrotor flatness) ─► IMU samples ─► imu.csv
//!                                            │
//!                       room + APs ─► image-method paths ─► CSI per packet ─► <ap>.dat (Intel 5300)
//!                                            └──────────► truth/ (poses, AP positions, per-packet AoA)
//! ```
//!
//! Every random stream (IMU noise, each AP's channel noise, packet timing, the random flight) has
//! its own seed derived from the scenario seed and the stream's name, so changing one sensor's
//! rate does not change another's noise.

pub mod baro;
pub mod csi;
pub mod family;
pub mod flight;
pub mod imu;
mod kinematics;
pub mod lab_calibration;
pub mod motion;
pub mod packets;
pub mod radio;
pub mod rng;
pub mod room;
pub mod run;
pub mod scenario;
pub mod summary;
pub mod trajectory;
pub mod vibration;
pub mod waypoints;
pub mod write;
pub mod yaw;

pub use radio::ReceiverResponse;
pub use run::{SimOutput, simulate};
pub use scenario::Scenario;
pub use write::write_dataset;

/// A scenario value that cannot be simulated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid scenario: {field}: {reason}")]
pub struct ConfigError {
    /// Dotted path of the offending field, e.g. `room.size_m`.
    pub field: String,
    /// What is wrong with it, with the value.
    pub reason: String,
}

impl ConfigError {
    /// An error for `field`.
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// Error unless every entry of `values` is finite.
pub(crate) fn check_finite(field: &str, name: &str, values: &[f64]) -> Result<(), ConfigError> {
    if values.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ConfigError::new(
            format!("{field}.{name}"),
            format!("must be finite, got {values:?}"),
        ))
    }
}
