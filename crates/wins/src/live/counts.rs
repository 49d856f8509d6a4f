//! What a live session counts, and its clocks as it sees them (`stats.json`, the status line).

use serde::Serialize;

/// Counts of everything a session saw, skipped and sent (`stats.json`'s `live`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LiveStats {
    /// IMU samples received.
    pub imu_received: u64,
    /// IMU samples whose time jumped further than `max_clock_jump_s` from the newest (the
    /// flight controller's clock restarting): dropped.
    pub imu_time_jumps: u64,
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
    /// CSI records received.
    pub csi_records: u64,
    /// Stretches of bytes the CSI decoder skipped (garbage, non-CSI records other than the
    /// frame records before CSI records, cut records).
    pub csi_skips: u64,
    /// Their bytes.
    pub csi_skipped_bytes: u64,
    /// 0xC1 frame records (they name the next record's transmitter).
    pub csi_frame_records: u64,
    /// Records without a frame record naming their transmitter (with `ap_by = "transmitter"`).
    pub csi_no_transmitter: u64,
    /// Records from a transmitter no AP of the rig has.
    pub csi_unknown_transmitter: u64,
    /// Records that came before the flight controller's clock was known.
    pub csi_before_fc_clock: u64,
    /// A connection's first [`super::session::CLOCK_WARMUP_RECORDS`] records, left out while its clock
    /// relation settles.
    pub csi_clock_warmup: u64,
    /// NIC clock jumps (the relation started over).
    pub nic_clock_jumps: u64,
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
