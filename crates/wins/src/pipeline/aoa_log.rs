//! The AoA of every packet of a log, one row per record: the lowest-ToF credible MUSIC peak of each
//! packet, or SpotFi's direct path over consecutive groups. Records that give no angle are kept as
//! rows with a status and counted in the summary. Also pairs a dataset's records with the truth
//! AoA, for calibrating on a capture with a reference system (or the simulator's truth).

pub mod capture;
pub mod input;

use std::collections::BTreeMap;

use serde::Serialize;

use super::stats::PacketStatus;
use crate::aoa::estimator::{AoaError, AoaEstimator};
use crate::aoa::music::AoaWindow;
use crate::aoa::peak::Peak;
use crate::aoa::spotfi::MIN_GROUP_SIZE;
use crate::aoa::spotfi::SpotfiError;
use crate::aoa::{ChainCurvature, Correction, restart_step_rad};
use crate::csi::intel5300::CsiRecord;
use crate::dataset::Dataset;
use crate::dataset::truth::Truth;

/// Rows (or records) searched ahead for a matching `bfee_count` when the log and the truth disagree;
/// far below the 65 536 packets after which the 16-bit count repeats.
pub const RESYNC_WINDOW: usize = 4096;

/// One record's AoA (a row of `wins aoa`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PacketAoa {
    /// Index of the record in the log (CSI records only, from 0).
    pub index: usize,
    /// Byte offset of the record in the log.
    pub offset: u64,
    /// The record's NIC timestamp (unwrapped), ns.
    pub timestamp_ns: i64,
    /// Bandwidth of the record, MHz.
    pub bandwidth_mhz: u32,
    /// What the record gave.
    pub status: PacketStatus,
    /// Why the record was skipped (empty otherwise).
    pub reason: String,
    /// Direct-path AoA, degrees (steering-vector convention).
    pub aoa_deg: Option<f64>,
    /// Its sanitized ToF, ns (relative to the packet's fitted delay).
    pub tof_ns: Option<f64>,
    /// Its normalized MUSIC pseudo-spectrum, dB.
    pub spectrum_db: Option<f64>,
    /// On an array wider than λ/2, the other angles with the same phases, degrees,
    /// `;`-separated (empty otherwise).
    pub aliases_deg: String,
    /// Credible peaks of the packet.
    pub peaks: usize,
    /// SpotFi group of the record (SpotFi mode only).
    pub group: Option<usize>,
    /// AoA of the group's direct-path cluster, degrees (SpotFi mode, when the group has one).
    pub group_aoa_deg: Option<f64>,
}

/// Measures the chains' curvature over a log's records ([`crate::aoa::ChainCurvature`]) and makes
/// the estimator's calibration agree with it: with a stored calibration (`has_prior`) only by a
/// multiple of the NIC's restart step, without one wholly. Records of another antenna count or
/// without the configured stream are left out of the measurement (the estimator skips them
/// anyway).
pub fn match_chain_curvature<'a>(
    records: impl IntoIterator<Item = &'a CsiRecord>,
    estimator: &mut AoaEstimator,
    has_prior: bool,
) -> Result<Correction, AoaError> {
    let mut curvature = ChainCurvature::default();
    let antennas = estimator.geometry().num_antennas;
    for record in records {
        if let Ok(csi) = estimator.received_csi(record) {
            curvature.push(&csi, antennas);
        }
    }
    let correction = curvature.corrected(
        estimator.calibration(),
        restart_step_rad(estimator.center_freq_hz()),
        has_prior,
    );
    estimator.set_calibration(correction.calibration.clone())?;
    Ok(correction)
}

/// How each packet's direct path is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AoaMode {
    /// Per packet: the lowest-ToF credible MUSIC peak.
    Music,
    /// SpotFi clustering over consecutive groups of `group_size` packets (≥ [`MIN_GROUP_SIZE`]);
    /// a last partial group is used when it has at least [`MIN_GROUP_SIZE`] packets.
    Spotfi {
        /// Packets per group (the paper uses 10).
        group_size: usize,
    },
}

/// Counts over a log.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct AoaLogSummary {
    /// Records seen.
    pub packets: usize,
    /// Records with an angle.
    pub with_aoa: usize,
    /// Records processed without a credible direct path.
    pub no_credible_peak: usize,
    /// Skipped records per reason.
    pub skipped_by_reason: BTreeMap<String, usize>,
    /// SpotFi groups run (0 in MUSIC mode).
    pub groups: usize,
    /// SpotFi groups without a direct path, per reason.
    pub groups_without_direct_path: BTreeMap<String, usize>,
}

impl AoaLogSummary {
    /// Skipped records over all reasons.
    pub fn skipped(&self) -> usize {
        self.skipped_by_reason.values().sum()
    }
}

/// Why a log cannot be processed or paired with its truth.
#[derive(Debug, thiserror::Error)]
pub enum AoaLogError {
    /// The SpotFi group size is below [`MIN_GROUP_SIZE`].
    #[error("SpotFi group size {group_size} is below {MIN_GROUP_SIZE}")]
    GroupSize {
        /// The size asked for.
        group_size: usize,
    },
    /// The dataset has no AP of that name.
    #[error("no AP {ap:?} in the dataset (it has {known})")]
    UnknownAp {
        /// The name asked for.
        ap: String,
        /// The dataset's AP names, comma-separated.
        known: String,
    },
    /// The truth has no packet rows for the AP.
    #[error("the truth has no packet rows for AP {ap:?}")]
    NoTruth {
        /// The AP.
        ap: String,
    },
}

/// The AoA of every record, in input order, and the counts. See [`AoaMode`] for how the direct
/// path is chosen; in SpotFi mode a record's angle is its own peak in the group's chosen cluster.
pub fn estimate_log<'a>(
    records: impl IntoIterator<Item = &'a CsiRecord>,
    estimator: &AoaEstimator,
    mode: AoaMode,
) -> Result<(Vec<PacketAoa>, AoaLogSummary), AoaLogError> {
    let mut summary = AoaLogSummary::default();
    let rows = match mode {
        AoaMode::Music => records
            .into_iter()
            .enumerate()
            .map(|(index, record)| {
                let mut row = empty_row(index, record);
                match estimator.peaks(record, AoaWindow::FULL) {
                    Ok(peaks) => set_peak(&mut row, peaks.len(), peaks.first(), estimator),
                    Err(e) => skip(&mut row, e.to_string()),
                }
                row
            })
            .collect(),
        AoaMode::Spotfi { group_size } => {
            if group_size < MIN_GROUP_SIZE {
                return Err(AoaLogError::GroupSize { group_size });
            }
            let records: Vec<&CsiRecord> = records.into_iter().collect();
            let mut rows = Vec::with_capacity(records.len());
            for (g, chunk) in records.chunks(group_size).enumerate() {
                spotfi_group(estimator, g, g * group_size, chunk, &mut rows, &mut summary);
            }
            rows
        }
    };
    for row in &rows {
        summary.packets += 1;
        match row.status {
            PacketStatus::Measured => summary.with_aoa += 1,
            PacketStatus::NoCrediblePeak => summary.no_credible_peak += 1,
            // Skipped (the pipeline's own statuses never occur here).
            _ => {
                *summary
                    .skipped_by_reason
                    .entry(row.reason.clone())
                    .or_default() += 1
            }
        }
    }
    Ok((rows, summary))
}

/// Rows of one SpotFi group whose first record has index `first`.
fn spotfi_group(
    estimator: &AoaEstimator,
    group: usize,
    first: usize,
    chunk: &[&CsiRecord],
    rows: &mut Vec<PacketAoa>,
    summary: &mut AoaLogSummary,
) {
    let start = rows.len();
    rows.extend(chunk.iter().enumerate().map(|(k, record)| PacketAoa {
        group: Some(group),
        ..empty_row(first + k, record)
    }));
    let rows = &mut rows[start..];
    if chunk.len() < MIN_GROUP_SIZE {
        let reason = format!("last SpotFi group has a single packet (needs {MIN_GROUP_SIZE})");
        rows.iter_mut().for_each(|row| skip(row, reason.clone()));
        return;
    }
    summary.groups += 1;
    let result = estimator.spotfi(chunk.iter().copied());
    let direct = match &result.direct {
        Ok(d) => Some(d),
        Err(e) => {
            *summary
                .groups_without_direct_path
                .entry(group_failure(e))
                .or_default() += 1;
            None
        }
    };
    for (k, row) in rows.iter_mut().enumerate() {
        if let Some((_, reason)) = result.skipped.iter().find(|(i, _)| *i == k) {
            skip(row, reason.clone());
            continue;
        }
        let credible = result.peaks.get(k).map_or(0, Vec::len);
        let own = direct.and_then(|d| d.per_packet.get(k).copied().flatten());
        set_peak(row, credible, own.as_ref(), estimator);
        row.group_aoa_deg = direct.map(|d| d.aoa_rad.to_degrees());
    }
}

/// A summary key for a group without a direct path (per-group numbers left out, so groups that
/// failed the same way are counted together).
fn group_failure(e: &SpotfiError) -> String {
    match e {
        SpotfiError::NoPeaks { .. } => "no packet of the group has a credible peak".into(),
        SpotfiError::NoEligibleCluster { .. } => {
            "no cluster is seen by enough of the group's packets".into()
        }
        other => other.to_string(),
    }
}

/// A row for `record` with no peak yet.
fn empty_row(index: usize, record: &CsiRecord) -> PacketAoa {
    PacketAoa::empty(
        index,
        record.offset,
        record.timestamp.as_nanos(),
        record.header.rate.bandwidth().mhz(),
    )
}

impl PacketAoa {
    /// The row of the packet `index` at byte `offset`, time `timestamp_ns` and width
    /// `bandwidth_mhz`, with no peak yet.
    pub fn empty(index: usize, offset: u64, timestamp_ns: i64, bandwidth_mhz: u32) -> Self {
        Self {
            index,
            offset,
            timestamp_ns,
            bandwidth_mhz,
            status: PacketStatus::NoCrediblePeak,
            reason: String::new(),
            aoa_deg: None,
            tof_ns: None,
            spectrum_db: None,
            aliases_deg: String::new(),
            peaks: 0,
            group: None,
            group_aoa_deg: None,
        }
    }
}

fn set_peak(row: &mut PacketAoa, credible: usize, peak: Option<&Peak>, estimator: &AoaEstimator) {
    row.peaks = credible;
    if let Some(p) = peak {
        let aliases: Vec<String> = estimator
            .aliases_rad(p.aoa_rad)
            .iter()
            .map(|a| format!("{:.1}", a.to_degrees()))
            .collect();
        row.aliases_deg = aliases.join(";");
        row.status = PacketStatus::Measured;
        row.aoa_deg = Some(p.aoa_deg());
        row.tof_ns = Some(p.tof_s * 1e9);
        row.spectrum_db = Some(p.spectrum_db());
    }
}

fn skip(row: &mut PacketAoa, reason: String) {
    row.status = PacketStatus::Skipped;
    row.reason = reason;
}

/// A dataset AP's records paired with their true AoA.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthPairs<'a> {
    /// `(record, true direct-path AoA in rad)`, in log order.
    pub pairs: Vec<(&'a CsiRecord, f64)>,
    /// Logged records with no truth row (no row with their `bfee_count`, or after `lost_sync`).
    pub unmatched: usize,
    /// Received truth rows with no logged record (e.g. a record lost to corruption).
    pub truth_rows_skipped: usize,
    /// Index of the record at which no resynchronization was found; it and every later record
    /// are unmatched.
    pub lost_sync: Option<usize>,
}

/// Pairs each logged record of AP `ap` with its truth AoA: the truth rows with `received` are
/// walked in order alongside the log's records, requiring equal `bfee_count`. On a mismatch the
/// next [`RESYNC_WINDOW`] rows are searched for the record's count (records missing from the
/// log), then the next records for the row's count (records the truth does not know); if neither
/// is found the walk stops and the rest is unmatched.
pub fn truth_pairs<'a>(
    dataset: &'a Dataset,
    truth: &Truth,
    ap: &str,
) -> Result<TruthPairs<'a>, AoaLogError> {
    let Some(log) = dataset.aps.iter().find(|a| a.name == ap) else {
        let known: Vec<&str> = dataset.aps.iter().map(|a| a.name.as_str()).collect();
        return Err(AoaLogError::UnknownAp {
            ap: ap.to_string(),
            known: known.join(", "),
        });
    };
    let rows = truth
        .aps
        .iter()
        .position(|a| a.name == ap)
        .and_then(|i| truth.packets.get(i))
        .filter(|rows| !rows.is_empty())
        .ok_or_else(|| AoaLogError::NoTruth { ap: ap.to_string() })?;
    let rows: Vec<_> = rows.iter().filter(|r| r.received).collect();
    let records = &log.packets;
    let mut out = TruthPairs {
        pairs: Vec::with_capacity(records.len()),
        unmatched: 0,
        truth_rows_skipped: 0,
        lost_sync: None,
    };
    let (mut i, mut j) = (0, 0);
    let records: Vec<&CsiRecord> = records
        .iter()
        .filter_map(|p| p.record.intel5300())
        .collect();
    while let (Some(&record), Some(row)) = (records.get(i), rows.get(j)) {
        let count = record.header.bfee_count;
        if row.bfee_count == count {
            out.pairs.push((record, row.aoa_rad));
            (i, j) = (i + 1, j + 1);
        } else if let Some(k) = rows[j..]
            .iter()
            .take(RESYNC_WINDOW)
            .position(|r| r.bfee_count == count)
        {
            out.truth_rows_skipped += k;
            j += k;
        } else if let Some(k) = records[i..]
            .iter()
            .take(RESYNC_WINDOW)
            .position(|r| r.header.bfee_count == row.bfee_count)
        {
            out.unmatched += k;
            i += k;
        } else {
            out.lost_sync = Some(i);
            break;
        }
    }
    out.unmatched += records.len() - i;
    Ok(out)
}

#[cfg(test)]
mod tests;
