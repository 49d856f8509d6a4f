//! What describes the hardware: the antenna array and its mounting, the NIC's receive-chain
//! calibration and carrier, the IMU's noise. Read from a dataset's manifest or a scenario, used by
//! every stage above; this module depends on none of them.

pub mod array;
pub(crate) mod chain_calibration;
pub mod channel;
pub(crate) mod imu_noise;

use nalgebra::Isometry3;

use crate::csi::format::CaptureFormat;

pub use array::{Ambiguity, ArrayGeometry, GeometryError};
pub use chain_calibration::{CalibrationError, CalibrationSetup, ChainCalibration};
pub use imu_noise::ImuNoise;

/// The rig: what the pipeline needs to know about the hardware.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    /// The card, as its capture format names it: the Intel 5300's records get its own model
    /// (subcarrier groups, receiver response, chain offsets resolved in flight), other cards'
    /// packets MUSIC on their own subcarriers with the calibration as given.
    pub card: CaptureFormat,
    /// Antenna count and spacing.
    pub geometry: ArrayGeometry,
    /// `body_from_array`: the array's pose on the body (IMU) frame.
    pub body_from_array: Isometry3<f64>,
    /// Carrier frequency, Hz.
    pub center_freq_hz: f64,
    /// The NIC's chain calibration (`None`: uncalibrated, AoA wrong by tens of degrees).
    pub calibration: Option<ChainCalibration>,
    /// IMU noise densities.
    pub imu_noise: ImuNoise,
    /// AP names, in the order of the AP indices pushed.
    pub ap_names: Vec<String>,
}

/// Why a rig cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RigError {
    /// The array does not fit its carrier.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// `body_from_array` holds a value that is not finite.
    #[error("the array's mounting (body_from_array) is not finite")]
    Mounting,
    /// An IMU noise density is negative or not finite.
    #[error("IMU noise: {0}")]
    ImuNoise(String),
}

impl Rig {
    /// Checks the array against its carrier ([`ArrayGeometry::validate`]), that the mounting is
    /// finite and that the IMU's noise densities are finite and non-negative.
    pub fn validate(&self) -> Result<(), RigError> {
        self.geometry.validate(self.center_freq_hz)?;
        let t = &self.body_from_array.translation.vector;
        let q = self.body_from_array.rotation.coords;
        if t.iter().chain(q.iter()).any(|v| !v.is_finite()) {
            return Err(RigError::Mounting);
        }
        self.imu_noise.validate().map_err(RigError::ImuNoise)
    }
}
