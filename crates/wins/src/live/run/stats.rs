//! `stats.json`: what a live run leaves ([`LiveSummary`]). It is replaced atomically every
//! [`STATS_PERIOD`] while the run goes (`"complete": false`: interim counts, what a killed run
//! leaves) and once when it stops (`"complete": true`, after the last frames).

use std::io::{self, Write};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

use serde::Serialize;

use super::outputs::Outputs;
use super::{LiveError, io_err};
use crate::live::mavlink::inbound::{InboundDecoder, InboundStats};
use crate::live::mavlink::link::{LinkCounts, MavlinkLink};
use crate::live::mavlink::signing::SigningCounts;
use crate::live::session::{ClockReport, LiveStats};

/// The file's name in the output folder.
pub const STATS_FILE: &str = "stats.json";

/// How often the interim `stats.json` is written during a run: a killed run's counts are at
/// most this old. Each is written to a temporary file and renamed over the last, without
/// waiting for the disk (so the loop that sends the poses never stalls on it).
pub const STATS_PERIOD: Duration = Duration::from_secs(2);

/// What a live run leaves (`stats.json`).
#[derive(Clone, Debug, Serialize)]
pub struct LiveSummary {
    /// `false` in the interim files written during the run (every [`STATS_PERIOD`]: the counts
    /// so far), `true` in the last one, written when the run stops.
    pub complete: bool,
    /// The session's counts.
    pub live: LiveStats,
    /// The flight controller link's counts.
    pub mavlink_in: InboundStats,
    /// What arrived on the flight controller link: CRC-valid frames, garbage bytes, bad CRCs,
    /// messages the dialect does not know, UDP datagrams without a valid frame, stream
    /// connections lost.
    pub mavlink_link: LinkCounts,
    /// With a signing key (`live.mavlink_key`): the messages signed and sent, and those received
    /// taken or refused by reason; `null` without one.
    pub mavlink_signing: Option<SigningCounts>,
    /// Poses sent to the flight controller.
    pub poses_sent: u64,
    /// Poses that could not be sent (the link failed, or a pose not finite).
    pub poses_not_sent: u64,
    /// The clocks when written.
    pub clocks: ClockReport,
    /// Median and 99th percentile of the poses' age when sent, ms, over the run so far.
    pub latency_ms: Option<(f64, f64)>,
    /// The CSI server's address.
    pub csi_listen: String,
    /// The recording, when made.
    pub recording: Option<PathBuf>,
}

/// What `stats.json` holds beside the session's counts and the outputs', and where it goes.
pub(super) struct StatsFile<'a> {
    /// The file.
    pub(super) path: PathBuf,
    /// The flight controller link's decoder (its counts).
    pub(super) inbound: &'a Mutex<InboundDecoder>,
    /// The flight controller link (its counts).
    pub(super) link: &'a MavlinkLink,
    /// The CSI server's address.
    pub(super) csi_listen: String,
    /// The recording's folder, when recording.
    pub(super) recording: Option<PathBuf>,
}

impl StatsFile<'_> {
    /// The summary of the run so far: the session's counts `live` and `clocks`, the outputs'.
    pub(super) fn summary(
        &self,
        live: LiveStats,
        clocks: ClockReport,
        out: &Outputs<'_>,
        complete: bool,
    ) -> LiveSummary {
        LiveSummary {
            complete,
            live,
            mavlink_in: self.inbound.lock().map(|d| *d.stats()).unwrap_or_default(),
            mavlink_link: self.link.counts(),
            mavlink_signing: self.link.signing_counts(),
            poses_sent: out.sent,
            poses_not_sent: out.not_sent,
            clocks,
            latency_ms: out.ages.percentiles(),
            csi_listen: self.csi_listen.clone(),
            recording: self.recording.clone(),
        }
    }

    /// Replaces the file with `summary`, atomically; synced to the disk when it is the last
    /// (`complete`).
    pub(super) fn write(&self, summary: &LiveSummary) -> Result<(), LiveError> {
        let json = serde_json::to_vec_pretty(summary).map_err(|e| LiveError::Io {
            what: format!("writing {STATS_FILE}"),
            source: io::Error::other(e),
        })?;
        let fill = |w: &mut io::BufWriter<std::fs::File>| w.write_all(&json);
        match summary.complete {
            true => crate::io_safety::write_atomically(&self.path, fill),
            false => crate::io_safety::write_atomically_unsynced(&self.path, fill),
        }
        .map_err(io_err(format!("writing {STATS_FILE}")))
    }
}
