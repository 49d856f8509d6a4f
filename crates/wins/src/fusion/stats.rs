//! What an estimator has seen and skipped: the counters `stats.json` reports for either
//! estimator.

/// What the estimator has seen and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EstimatorStats {
    /// IMU samples integrated.
    pub imu_samples: u64,
    /// IMU samples refused (non-finite, out of order).
    pub imu_refused: u64,
    /// Frames solved.
    pub frames: u64,
    /// Bearings fed to the window.
    pub bearings: u64,
    /// Frames dropped because they were older than the IMU stream or came before any IMU.
    pub frames_late: u64,
    /// Frames the window refused (their IMU interval did not join the previous frame); each is
    /// also in [`Step::refused`](super::pose::Step::refused) with the reason.
    pub frames_refused: u64,
    /// Window solves that failed (the frame stays, the previous estimate is kept).
    pub solve_failures: u64,
    /// Times the converged estimate was lost and the window started over (a new `b0`).
    pub restarts: u64,
    /// Candidate convergences rejected as implausible.
    pub rejected_convergences: u64,
    /// Gaps in the IMU stream ([`crate::imu::ImuGap`]).
    pub imu_gaps: u64,
    /// Frames dropped because they fell inside an IMU gap (no pose for a time the IMU did not
    /// see).
    pub frames_in_imu_gap: u64,
    /// Keyframes held at zero velocity: taken while the IMU was still, on the ground
    /// ([`crate::fusion::nonlinear::start::still`]).
    pub still_keyframes: u64,
    /// The largest accelerometer white density integrated with, m/s²/√Hz: the dataset's, or
    /// what the samples showed when more ([`crate::imu::noise_meter`]); 0 when not measured.
    pub imu_accel_density_max_m_s2_sqrt_hz: f64,
    /// The same for the gyro, rad/s/√Hz.
    pub imu_gyro_density_max_rad_s_sqrt_hz: f64,
}
