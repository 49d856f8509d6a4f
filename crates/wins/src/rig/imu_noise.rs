//! The IMU's noise: continuous-time densities and turn-on bias spreads, shared by the simulator
//! and the estimator (docs/DESIGN.md §2).

use serde::{Deserialize, Serialize};

use crate::check::Problems;

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

impl ImuNoise {
    /// Every density and spread finite and ≥ 0 (zero is an ideal sensor), under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        for (key, v) in [
            (
                "gyro_noise_density_rad_s_sqrt_hz",
                self.gyro_noise_density_rad_s_sqrt_hz,
            ),
            (
                "gyro_bias_random_walk_rad_s2_sqrt_hz",
                self.gyro_bias_random_walk_rad_s2_sqrt_hz,
            ),
            ("gyro_turn_on_bias_rad_s", self.gyro_turn_on_bias_rad_s),
            (
                "accel_noise_density_m_s2_sqrt_hz",
                self.accel_noise_density_m_s2_sqrt_hz,
            ),
            (
                "accel_bias_random_walk_m_s3_sqrt_hz",
                self.accel_bias_random_walk_m_s3_sqrt_hz,
            ),
            ("accel_turn_on_bias_m_s2", self.accel_turn_on_bias_m_s2),
        ] {
            p.non_negative(prefix, key, v);
        }
        p
    }

    /// [`ImuNoise::problems`], in words.
    pub fn validate(&self) -> Result<(), String> {
        self.problems("").into_result().map_err(|p| p.to_string())
    }
}
