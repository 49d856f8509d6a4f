//! Per-packet AoA of a capture from a card other than the Intel 5300 (Nexmon, FeitCSI,
//! PicoScenes, Atheros): its packets ([`read_packets`]) on the card's own subcarriers and
//! chains, MUSIC per packet ([`crate::aoa::PacketAoa`]), one row per packet in the layout of the
//! 5300's ([`super::PacketAoa`]). The array is as many antennas as the packets have chains,
//! half a wavelength apart unless told; the carrier is the file's unless told (FeitCSI files do
//! not carry it). Packets of another chain count than the array are skipped and counted.

use std::collections::BTreeMap;

use super::input::{AoaInputError, AoaSpec};
use super::{AoaLogSummary, PacketAoa as AoaRow};
use crate::aoa::PacketAoa;
use crate::aoa::{CalibrateReport, calibrate_packets};
use crate::csi::format::CaptureFormat;
use crate::csi::packet::{CsiPacket, CsiPackets, read_packets};
use crate::pipeline::stats::PacketStatus;
use crate::rig::array::half_wavelength_m;
use crate::rig::channel::wifi_channel_hz;
use crate::rig::{ArrayGeometry, ChainCalibration};

/// What an AoA run over a capture gives.
#[derive(Debug)]
pub struct CaptureAoa {
    /// The capture's format.
    pub format: CaptureFormat,
    /// One row per packet, in order.
    pub rows: Vec<AoaRow>,
    /// The counts (packets the reader could not make, by reason, among the skipped).
    pub summary: AoaLogSummary,
    /// The array used.
    pub geometry: ArrayGeometry,
    /// The carrier used, Hz.
    pub center_freq_hz: f64,
    /// What the reader could not read, in words.
    pub lost: Option<String>,
}

/// The warning of a capture's AoA without a calibration.
pub const UNCALIBRATED: &str = "uncalibrated chains: the phase step between chains is not \
     measured, so angles are offset on real hardware";

/// The packets of the capture `spec.file` in `format`, and the array and carrier they are
/// taken on (module doc). Errors: a dataset's AP given, no packet, no carrier known.
pub fn open_capture(
    spec: &AoaSpec,
    format: CaptureFormat,
) -> Result<(CsiPackets, ArrayGeometry, f64), AoaInputError> {
    let options = AoaInputError::Options;
    if spec.ap.is_some() {
        return Err(options("an AP is for a dataset directory".into()));
    }
    let (_, read) = read_packets(&spec.file, Some(format))
        .map_err(|e| AoaInputError::NoRecords(e.to_string()))?;
    let Some(first) = read.packets.first() else {
        let why: Vec<String> = read.skipped.keys().cloned().collect();
        return Err(AoaInputError::NoRecords(format!(
            "{}: no packet with CSI as {} ({})",
            spec.file.display(),
            format.describe(),
            read.lost
                .clone()
                .into_iter()
                .chain(why)
                .collect::<Vec<_>>()
                .join("; ")
        )));
    };
    let center_freq_hz = match (spec.channel, spec.center_freq_hz, first.carrier_hz) {
        (Some(n), _, _) => wifi_channel_hz(n)
            .ok_or_else(|| options(format!("channel {n} is not a Wi-Fi channel")))?,
        (None, Some(f), _) | (None, None, Some(f)) => f,
        (None, None, None) => {
            return Err(options(format!(
                "{} does not say its carrier: give --channel or --center-freq-hz",
                format.describe()
            )));
        }
    };
    let num_antennas = read
        .packets
        .iter()
        .map(CsiPacket::num_rx)
        .max()
        .unwrap_or(0);
    let geometry = ArrayGeometry {
        num_antennas,
        spacing_m: spec
            .spacing_m
            .unwrap_or_else(|| half_wavelength_m(center_freq_hz)),
    };
    Ok((read, geometry, center_freq_hz))
}

/// Chain offsets from the capture `spec.file` in `format`, taken with the AP at
/// `known_aoa_rad` ([`crate::aoa::calibrate_packets`]).
pub fn calibrate_capture(
    spec: &AoaSpec,
    format: CaptureFormat,
    known_aoa_rad: f64,
) -> Result<(ChainCalibration, CalibrateReport), AoaInputError> {
    let (read, geometry, center_freq_hz) = open_capture(spec, format)?;
    calibrate_packets(
        &read.packets,
        known_aoa_rad,
        geometry,
        center_freq_hz,
        &spec.config,
    )
    .map_err(AoaInputError::from)
}

/// The AoA of every packet of the capture `spec.file` in `format` (module doc), with
/// `calibration` (one phase offset per chain) when given.
pub fn estimate_capture(
    spec: &AoaSpec,
    format: CaptureFormat,
    calibration: Option<ChainCalibration>,
) -> Result<CaptureAoa, AoaInputError> {
    let (read, geometry, center_freq_hz) = open_capture(spec, format)?;
    let mut aoa = PacketAoa::new(&spec.config, geometry, center_freq_hz, calibration)?;
    let mut summary = AoaLogSummary {
        packets: read.packets.len() + read.skipped.values().sum::<u64>() as usize,
        skipped_by_reason: read
            .skipped
            .iter()
            .map(|(k, v)| (k.clone(), *v as usize))
            .collect(),
        ..AoaLogSummary::default()
    };
    let mut rows = Vec::with_capacity(read.packets.len());
    let mut reasons: BTreeMap<String, usize> = BTreeMap::new();
    for (index, p) in read.packets.iter().enumerate() {
        let mut row = AoaRow::empty(index, p.offset, p.clock_ns, p.bandwidth_mhz);
        match aoa.peaks(p, crate::aoa::AoaWindow::FULL) {
            Ok(peaks) => {
                row.peaks = peaks.len();
                if let Some(peak) = peaks.first() {
                    row.status = PacketStatus::Measured;
                    row.aoa_deg = Some(peak.aoa_deg());
                    row.tof_ns = Some(peak.tof_s * 1e9);
                    row.spectrum_db = Some(peak.spectrum_db());
                    let aliases: Vec<String> = aoa
                        .aliases_rad(p, peak.aoa_rad)
                        .iter()
                        .map(|a| format!("{:.1}", a.to_degrees()))
                        .collect();
                    row.aliases_deg = aliases.join(";");
                    summary.with_aoa += 1;
                } else {
                    summary.no_credible_peak += 1;
                }
            }
            Err(e) => {
                row.status = PacketStatus::Skipped;
                row.reason = e.to_string();
                *reasons.entry(row.reason.clone()).or_default() += 1;
            }
        }
        rows.push(row);
    }
    for (k, v) in reasons {
        *summary.skipped_by_reason.entry(k).or_default() += v;
    }
    Ok(CaptureAoa {
        format,
        rows,
        summary,
        geometry,
        center_freq_hz,
        lost: read.lost,
    })
}
