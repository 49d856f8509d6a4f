//! What happened to every packet: one [`PacketLog`] row each, and counters per AP.

use serde::Serialize;

use crate::fusion::bearing::Side;
use crate::time::Timestamp;

/// What a packet gave.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PacketStatus {
    /// An angle was measured (the per-packet AoA log of [`super::aoa_log`], which does not feed
    /// an estimator; written `ok`).
    #[serde(rename = "ok")]
    Measured,
    /// Its bearing went to the estimator.
    Fed,
    /// Collected for SpotFi to start (or restart) the AP's track.
    Acquisition,
    /// The PAoA window held no credible peak: dropped.
    NoCrediblePeak,
    /// After convergence, the angle was further than the gate from the state's prediction:
    /// dropped.
    Gated,
    /// The angle was further than the track gate from the track's own prediction (a jump to
    /// another path): dropped.
    OffTrack,
    /// Before convergence with `assume_front_until_converged = false`: dropped.
    SideUnknown,
    /// Could not be processed (wrong shape, bad chains, unknown AP): dropped, `reason` says why.
    Skipped,
}

/// One packet's row of the AoA log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PacketLog {
    /// AP index.
    pub ap: usize,
    /// Reception time on the IMU clock, ns.
    pub t_ns: i64,
    /// What it gave.
    pub status: PacketStatus,
    /// Why (skips, failed acquisitions, track losses); empty otherwise.
    pub reason: String,
    /// The PAoA window's centre, degrees.
    pub predicted_aoa_deg: Option<f64>,
    /// The measured direct-path AoA (PAoA peak, or SpotFi's at the end of an acquisition),
    /// degrees, steering-vector convention.
    pub aoa_deg: Option<f64>,
    /// Its ToF after sanitization, ns.
    pub tof_ns: Option<f64>,
    /// Its MUSIC residual (0 a perfect path, 1 noise; see [`crate::aoa::Peak::residual`]).
    pub residual: Option<f64>,
    /// Credible peaks in the PAoA window (the direct path is the lowest-ToF one).
    pub candidates: Option<usize>,
    /// The side given to the estimator.
    #[serde(serialize_with = "side_name")]
    pub side: Option<Side>,
    /// Whether the side came from the state (`false`: assumed in front before convergence).
    pub side_from_state: bool,
    /// Whether the window had converged when the packet came.
    pub converged: bool,
}

fn side_name<S: serde::Serializer>(side: &Option<Side>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(match side {
        Some(Side::Front) => "front",
        Some(Side::Back) => "back",
        None => "",
    })
}

impl PacketLog {
    /// A row with no result yet.
    pub fn new(ap: usize, t: Timestamp, converged: bool) -> Self {
        Self {
            ap,
            t_ns: t.as_nanos(),
            status: PacketStatus::Skipped,
            reason: String::new(),
            predicted_aoa_deg: None,
            aoa_deg: None,
            tof_ns: None,
            residual: None,
            candidates: None,
            side: None,
            side_from_state: false,
            converged,
        }
    }
}

/// Counters of one AP.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ApStats {
    /// The AP's name.
    pub name: String,
    /// Packets seen.
    pub packets: u64,
    /// Bearings sent to the estimator.
    pub fed: u64,
    /// Packets collected for SpotFi.
    pub acquisition: u64,
    /// Dropped: no credible peak in the PAoA window.
    pub no_credible_peak: u64,
    /// Dropped: outside the gate around the state's prediction.
    pub gated: u64,
    /// Dropped: off the AP's track (a jump to another path).
    pub off_track: u64,
    /// Dropped: side unknown before convergence.
    pub side_unknown: u64,
    /// Dropped: could not be processed.
    pub skipped: u64,
    /// SpotFi acquisitions that started a track.
    pub acquisitions: u64,
    /// SpotFi acquisitions without a direct path.
    pub acquisition_failures: u64,
    /// Tracks lost after too many packets without a peak or off the track.
    pub track_losses: u64,
    /// Times the track changed side from how its angles followed the turns.
    pub side_switches: u64,
    /// Tracks started over after the AP fell silent (`pipeline.max_silence_s`).
    pub silences: u64,
    /// Tracks started over after an IMU gap (the gyro did not see the turns across it).
    pub imu_gap_restarts: u64,
    /// Stretches of the AP's log the reader skipped (corrupt or truncated bytes, non-CSI
    /// records), filled in by the replay; their packets never reach the pipeline.
    pub log_skips: u64,
    /// Bytes in those stretches.
    pub log_skipped_bytes: u64,
}

impl ApStats {
    /// Packets dropped for any reason (neither fed nor used for acquisition).
    pub fn dropped(&self) -> u64 {
        self.no_credible_peak + self.gated + self.off_track + self.side_unknown + self.skipped
    }
}

/// Counters of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PipelineStats {
    /// Per AP, in index order.
    pub per_ap: Vec<ApStats>,
    /// Packets with an AP index beyond the rig's APs.
    pub unknown_ap: u64,
    /// Bearings the estimator refused (frames older than its IMU stream).
    pub refused_bearings: u64,
}

impl PipelineStats {
    /// Zero counters for these APs.
    pub fn new(names: &[String]) -> Self {
        Self {
            per_ap: names
                .iter()
                .map(|n| ApStats {
                    name: n.clone(),
                    ..ApStats::default()
                })
                .collect(),
            ..Self::default()
        }
    }

    /// Counts one row.
    pub fn count(&mut self, row: &PacketLog) {
        let Some(s) = self.per_ap.get_mut(row.ap) else {
            return;
        };
        s.packets += 1;
        match row.status {
            PacketStatus::Fed => s.fed += 1,
            PacketStatus::Acquisition => s.acquisition += 1,
            PacketStatus::NoCrediblePeak => s.no_credible_peak += 1,
            PacketStatus::Gated => s.gated += 1,
            PacketStatus::OffTrack => s.off_track += 1,
            PacketStatus::SideUnknown => s.side_unknown += 1,
            PacketStatus::Skipped => s.skipped += 1,
            // Not a pipeline status: the AoA log counts its own rows.
            PacketStatus::Measured => {}
        }
    }

    /// Counts a packet of an unknown AP.
    pub fn count_unknown_ap(&mut self) {
        self.unknown_ap += 1;
    }

    /// Bearings fed over all APs.
    pub fn fed(&self) -> u64 {
        self.per_ap.iter().map(|s| s.fed).sum()
    }

    /// Packets dropped over all APs (plus those of unknown APs).
    pub fn dropped(&self) -> u64 {
        self.per_ap.iter().map(ApStats::dropped).sum::<u64>() + self.unknown_ap
    }
}
