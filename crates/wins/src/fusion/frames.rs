//! The order of an estimator's inputs: frames that come too late, and frames inside a gap of the
//! IMU stream. Both estimators queue frames until the IMU passes them and apply these rules.

use std::collections::VecDeque;

use super::error::EstimatorError;
use super::stats::EstimatorStats;
use crate::imu::{ImuSample, Preintegrator};
use crate::time::Timestamp;

/// Refuses (and counts in `frames_late`) a frame at `t` older than the newest queued frame or,
/// with none queued, than the last IMU sample `pre` integrated.
pub(crate) fn check_frame_order(
    t: Timestamp,
    newest_queued: Option<Timestamp>,
    pre: &Preintegrator,
    stats: &mut EstimatorStats,
) -> Result<(), EstimatorError> {
    let newest = newest_queued.or(pre.last_sample().map(|s| s.t));
    match newest.filter(|l| t < *l) {
        Some(l) => {
            stats.frames_late += 1;
            Err(EstimatorError::LateFrame {
                t_ns: t.0,
                last_ns: l.0,
            })
        }
        None => Ok(()),
    }
}

/// When `s` comes after an IMU gap ([`crate::imu::ImuGap`]): counts it, drops the queued frames
/// strictly inside it (no pose for a time the IMU did not see; `time` gives a frame's time) and
/// returns its length, s.
pub(crate) fn drop_frames_in_gap<F>(
    pending: &mut VecDeque<F>,
    time: impl Fn(&F) -> Timestamp,
    pre: &Preintegrator,
    s: &ImuSample,
    stats: &mut EstimatorStats,
) -> Option<f64> {
    let from = pre.gap_before(s)?;
    stats.imu_gaps += 1;
    let before = pending.len();
    pending.retain(|f| !(time(f) > from && time(f) < s.t));
    stats.frames_in_imu_gap += (before - pending.len()) as u64;
    Some(s.t.secs_since(from))
}
