//! Why an estimator refused an input. Both estimators refuse the same things: an IMU sample the
//! preintegration cannot take, a frame whose IMU interval does not join, a frame that came late.

use crate::imu::PreintegrationError;

/// Why an input was refused (the estimator's state is unchanged; the refusal is counted).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimatorError {
    /// The IMU sample was refused.
    #[error(transparent)]
    Imu(#[from] PreintegrationError),
    /// The window refused the frame.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// A frame older than the last IMU sample (cannot be cut any more).
    #[error("frame at {t_ns} ns is older than the last IMU sample at {last_ns} ns")]
    LateFrame {
        /// Frame time, ns.
        t_ns: i64,
        /// Last IMU sample, ns.
        last_ns: i64,
    },
}

/// Why a window refused a frame or could not solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrameError {
    /// A frame after the first came without the IMU interval from the previous frame.
    #[error("frame at {t_ns} ns has no IMU interval from the previous frame")]
    MissingImu {
        /// Frame time, ns.
        t_ns: i64,
    },
    /// The IMU interval does not join the previous frame to this one.
    #[error(
        "IMU interval {start_ns}…{end_ns} ns does not join the frames at {prev_ns} and {t_ns} ns"
    )]
    ImuMismatch {
        /// Interval start, ns.
        start_ns: i64,
        /// Interval end, ns.
        end_ns: i64,
        /// Previous frame, ns.
        prev_ns: i64,
        /// This frame, ns.
        t_ns: i64,
    },
    /// The normal equations were not positive definite (degenerate input).
    #[error("the normal equations are not positive definite")]
    NotPositiveDefinite,
}
