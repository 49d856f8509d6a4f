//! `wins live`: the estimator on board. CSI comes from the CSI Tool's `log_to_server` over TCP
//! ([`csi_server`]), the IMU and barometer from the flight controller over MAVLink
//! ([`mavlink`]), and the pose goes back to the flight controller as MAVLink `ODOMETRY` at every
//! frame.
//!
//! The parts, from the sockets in:
//! - the links' threads turn what arrives into [`LiveInput`]s stamped with the host's monotonic
//!   clock ([`HostClock`]);
//! - the [`session::LiveSession`] relates the clocks ([`clock`]: the NIC's and the flight
//!   controller's, each to the host's), puts the inputs back in time order ([`merge`]), feeds the
//!   pipeline ([`crate::pipeline::ChainResolver`], as `wins run` does), records them
//!   ([`recorder`]) and returns the frames to send;
//! - [`run`] wires them together (threads, the stop flag, the status line, the outputs).
//!
//! The session does no I/O on sockets and reads no clock: it is a value in, value out machine,
//! tested without hardware, and the benchmark of its latency drives it directly.

pub mod clock;
pub mod counts;
pub mod csi_input;
pub mod csi_server;
pub mod feitcsi_udp;
pub mod mavlink;
pub mod merge;
pub mod nexmon_udp;
pub mod player;
pub mod recorder;
pub mod run;
pub mod session;
pub mod status;
mod udp;

use std::time::Instant;

pub use self::csi_server::CsiEvent;
pub use crate::config::live::{ApBy, LiveConfig, PoseMessage};
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// The host's monotonic clock, in ns since a fixed instant (copied to every thread).
#[derive(Clone, Copy, Debug)]
pub struct HostClock {
    origin: Instant,
}

impl HostClock {
    /// A clock that reads 0 now.
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
        }
    }

    /// ns since the clock's origin.
    pub fn now_ns(&self) -> i64 {
        i64::try_from(self.origin.elapsed().as_nanos()).unwrap_or(i64::MAX)
    }
}

impl Default for HostClock {
    fn default() -> Self {
        Self::new()
    }
}

/// What the flight controller's link reports.
#[derive(Clone, Debug, PartialEq)]
pub enum FcEvent {
    /// An IMU sample, its time on the flight controller's clock.
    Imu {
        /// The sample (body = the flight controller's FRD frame).
        sample: ImuSample,
        /// Host time it arrived, ns.
        arrival_ns: i64,
    },
    /// A barometric altitude, its time on the flight controller's clock.
    Baro {
        /// Time.
        t: Timestamp,
        /// Altitude above the standard atmosphere's datum, m.
        altitude_m: f64,
        /// Host time it arrived, ns.
        arrival_ns: i64,
    },
    /// A message whose values could not be used (why).
    Refused(String),
    /// The link failed to read or decode (why); the link keeps reading.
    LinkError(String),
}

/// One input to a live session.
#[derive(Clone, Debug, PartialEq)]
pub enum LiveInput {
    /// From a CSI connection.
    Csi(CsiEvent),
    /// From the flight controller.
    Fc(FcEvent),
}
