//! What a live session counts, and its clocks as it sees them (`stats.json`, the status line).

use serde::Serialize;

/// Counts of everything a session saw, skipped and sent (`stats.json`'s `live`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LiveStats {
    /// IMU samples received.
    pub imu_received: u64,
    /// IMU samples refused as outliers: a lone time far from the flight controller's clock
    /// line ([`crate::live::clock::ClockTrack`]).
    pub fc_clock_outliers: u64,
    /// Re-locks of the flight controller's clock (it restarted, or its line went stale over a
    /// silence).
    pub fc_clock_relocks: u64,
    /// IMU samples left out while the flight controller's clock locked or re-locked.
    pub imu_clock_locking: u64,
    /// Barometer readings received (used only with `live.barometer` and
    /// `pipeline.use_barometer`).
    pub baro_received: u64,
    /// Messages from the flight controller whose values could not be used.
    pub fc_refused: u64,
    /// Read or decode errors on the flight controller's link.
    pub fc_link_errors: u64,
    /// CSI connections accepted.
    pub csi_connections: u64,
    /// CSI connections that ended.
    pub csi_disconnects: u64,
    /// Of those, the ones the peer closed after a whole record (a replay or a logger that
    /// finished); the others were dropped (an error, an idle timeout, a record cut).
    pub csi_closed: u64,
    /// CSI records received.
    pub csi_records: u64,
    /// Stretches of bytes the CSI decoder skipped (garbage, non-CSI records other than the
    /// frame records before CSI records, cut records).
    pub csi_skips: u64,
    /// Their bytes.
    pub csi_skipped_bytes: u64,
    /// Records whose CSI the estimator cannot take (a Nexmon frame missing a core of its
    /// stream, a shape without a subcarrier table), counted and left out.
    pub csi_unusable: u64,
    /// 0xC1 frame records (they name the next record's transmitter).
    pub csi_frame_records: u64,
    /// Records without a frame record naming their transmitter (with `ap_by = "transmitter"`).
    pub csi_no_transmitter: u64,
    /// Records from a transmitter no AP of the rig has.
    pub csi_unknown_transmitter: u64,
    /// Records of an AP that another, still open, connection already streams: a second stream
    /// for one AP is refused (the first stays until it closes or goes idle).
    pub csi_second_stream: u64,
    /// CSI connections refused: beyond the cap on open connections, or from a peer not allowed.
    pub csi_refused_connections: u64,
    /// Records that came before the flight controller's clock was known.
    pub csi_before_fc_clock: u64,
    /// Records left out while their connection's clock locked (its first records) or
    /// re-locked.
    pub csi_clock_warmup: u64,
    /// CSI records refused as outliers: a lone NIC time far from its connection's clock line.
    pub nic_clock_outliers: u64,
    /// Re-locks of a NIC's clock (it jumped: a driver reload, a counter reset).
    pub nic_clock_relocks: u64,
    /// CSI records whose time, through the clocks, lay further than `max_clock_jump_s` from the
    /// flight controller's present: dropped.
    pub csi_far_from_present: u64,
    /// Inputs that came later than `max_latency_ms` after their time: dropped.
    pub late: u64,
    /// CSI records handed to the pipeline, per AP.
    pub csi_used_per_ap: Vec<u64>,
    /// Frames the pipeline solved.
    pub frames: u64,
    /// Converged frames.
    pub frames_converged: u64,
    /// Times the estimate restarted (each bumps the `reset_counter` sent).
    pub restarts: u64,
    /// The faults that stopped the poses, each said once in words with its time.
    pub notices: Vec<String>,
}

/// The clocks as the session sees them (for the status line and `stats.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ClockReport {
    /// Host time minus flight controller time, ns (`None` before the first IMU sample).
    pub fc_offset_ns: Option<i64>,
    /// The flight controller clock's drift against the host's, ppm.
    pub fc_drift_ppm: Option<f64>,
    /// Per CSI connection: host time minus NIC time, ns, and the drift, ppm.
    pub nic: Vec<(u64, Option<i64>, Option<f64>)>,
}
