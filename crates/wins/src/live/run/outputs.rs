//! Where frames go: the pose messages sent to the flight controller (with their `quality`) and
//! the trajectory file, with the latency of what was sent.

use std::fs::File;
use std::time::Duration;

use ::mavlink::dialects::common::MavMessage;

use super::{LiveError, io_err};
use crate::fusion::pose::PoseEstimate;
use crate::live::PoseMessage;
use crate::live::mavlink::link::MavlinkLink;
use crate::live::mavlink::outbound::{OdometryExtras, odometry, vision_position_estimate};
use crate::live::session::LiveFrame;
use crate::live::status::Histogram;
use crate::run::trajectory::TrajectoryWriter;

/// 1σ of position at which `quality` is 37 (it falls as `exp(−σ / this)`), m.
pub const QUALITY_SIGMA_M: f64 = 0.5;

/// How often `wins live` hands its streamed files (`trajectory.tum`, the recording) what it
/// buffered, whole lines and records: a killed run loses at most this much of them, and the
/// files get one `write` each per period.
pub const FLUSH_PERIOD: Duration = Duration::from_millis(500);

/// Where frames go: the flight controller and the trajectory file.
pub(super) struct Outputs<'a> {
    pub(super) link: &'a MavlinkLink,
    pub(super) message: PoseMessage,
    pub(super) tum: TrajectoryWriter<File>,
    pub(super) sent: u64,
    pub(super) not_sent: u64,
    pub(super) ages: Histogram,
    pub(super) window_ages_ms: Vec<f64>,
}

impl Outputs<'_> {
    /// Writes a frame; sends it when it is fresh and `age_ms` (how old it is now) is known, its
    /// time put back on the flight controller's current clock (`fc_epoch_offset_ns`: the
    /// session's timeline minus that clock, [`crate::live::session::LiveSession::fc_epoch_offset_ns`]).
    pub(super) fn frame(
        &mut self,
        f: &LiveFrame,
        age_ms: Option<f64>,
        fc_epoch_offset_ns: i64,
    ) -> Result<(), LiveError> {
        if !f.pose.converged {
            return Ok(());
        }
        self.tum
            .frame(&f.pose)
            .map_err(io_err("writing trajectory.tum"))?;
        let Some(age) = age_ms.filter(|_| f.fresh) else {
            return Ok(());
        };
        match self.send(f, fc_epoch_offset_ns) {
            true => {
                self.sent += 1;
                self.ages.push(age);
                self.window_ages_ms.push(age);
            }
            false => self.not_sent += 1,
        }
        Ok(())
    }

    /// Hands the trajectory's buffered lines to its file.
    pub(super) fn flush(&mut self) -> Result<(), LiveError> {
        self.tum.flush().map_err(io_err("writing trajectory.tum"))
    }

    fn send(&self, f: &LiveFrame, fc_epoch_offset_ns: i64) -> bool {
        let fc_ns = f.pose.t.as_nanos().saturating_sub(fc_epoch_offset_ns);
        let extras = OdometryExtras {
            time_usec: u64::try_from(fc_ns / 1000).unwrap_or(0),
            reset_counter: f.reset_counter,
            quality: quality(&f.pose),
            angular_velocity_rad_s: None,
            velocity_covariance_in_w: None,
        };
        let message = match self.message {
            PoseMessage::Odometry => odometry(&f.pose, &extras).map(MavMessage::ODOMETRY),
            PoseMessage::VisionPositionEstimate => {
                vision_position_estimate(&f.pose, &extras).map(MavMessage::VISION_POSITION_ESTIMATE)
            }
        };
        message.is_ok_and(|m| self.link.send(&m).is_ok())
    }
}

/// `quality` of a converged pose: 100·exp(−σ_p / [`QUALITY_SIGMA_M`]), σ_p the RMS of the
/// position's 1σ over the axes, at least 1 (0 is "unknown" to the flight controller).
pub fn quality(pose: &PoseEstimate) -> i8 {
    let Some(c) = &pose.covariance else {
        return 0;
    };
    let sigma = ((c[(3, 3)] + c[(4, 4)] + c[(5, 5)]) / 3.0).max(0.0).sqrt();
    if !sigma.is_finite() {
        return 0;
    }
    (100.0 * (-sigma / QUALITY_SIGMA_M).exp())
        .round()
        .clamp(1.0, 100.0) as i8
}
