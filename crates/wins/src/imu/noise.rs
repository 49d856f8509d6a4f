//! IMU noise densities and biases, shared by the simulator and the estimator (DESIGN.md §2).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Continuous-time noise parameters of a 3-axis gyro and accelerometer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuNoise {
    /// Gyro white noise density (angle random walk), rad/s/√Hz.
    pub gyro_noise_density_rad_s_sqrt_hz: f64,
    /// Gyro bias random walk, rad/s²/√Hz (rad/s per √s).
    pub gyro_bias_random_walk_rad_s2_sqrt_hz: f64,
    /// Standard deviation of the gyro bias at power-on, per axis, rad/s.
    pub gyro_turn_on_bias_rad_s: f64,
    /// Accelerometer white noise density (velocity random walk), m/s²/√Hz.
    pub accel_noise_density_m_s2_sqrt_hz: f64,
    /// Accelerometer bias random walk, m/s³/√Hz (m/s² per √s).
    pub accel_bias_random_walk_m_s3_sqrt_hz: f64,
    /// Standard deviation of the accelerometer bias at power-on, per axis, m/s².
    pub accel_turn_on_bias_m_s2: f64,
}

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
