//! One IMU reading.

use nalgebra::Vector3;

use crate::time::Timestamp;

/// One IMU reading in the body (= IMU) frame `b`, on the IMU clock.
///
/// Angular rate and specific force are instantaneous values at `t` (a real IMU low-pass filters
/// and averages internally; the simulator samples the continuous signal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Time on the IMU clock.
    pub t: Timestamp,
    /// Angular rate of `b` relative to the world, in `b`, rad/s.
    pub gyro_rad_s: Vector3<f64>,
    /// Specific force (acceleration minus gravity, so +g upward at rest) in `b`, m/s².
    pub accel_m_s2: Vector3<f64>,
}
