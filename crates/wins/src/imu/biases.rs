//! IMU biases: the true ones at a sample (simulator) or an estimate of them.

use nalgebra::Vector3;

/// The true biases at one sample (what an estimator would like to know), or an estimate of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuBiases {
    /// Gyro bias, rad/s, body frame.
    pub gyro_rad_s: Vector3<f64>,
    /// Accelerometer bias, m/s², body frame.
    pub accel_m_s2: Vector3<f64>,
}

impl ImuBiases {
    /// No bias.
    pub fn zero() -> Self {
        Self {
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::zeros(),
        }
    }
}
