//! Each reader's records made [`CsiPacket`]s.

use std::path::Path;

use num_complex::Complex64;

use super::tables::{self, HE_SPACING_HZ, LEGACY_SPACING_HZ};
use super::{CsiPacket, CsiPackets};
use crate::csi::atheros::{AtherosRecord, read_atheros};
use crate::csi::capture::CaptureError;
use crate::csi::feitcsi::{FeitRecord, read_feitcsi};
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{CsiRecord, read_log};
use crate::csi::iwlmvm::{IntelCsiHeader, RateFormat};
use crate::csi::nexmon::frames::{NexmonFrame, frames};
use crate::csi::nexmon::read_nexmon;
use crate::csi::picoscenes::{PicoFrame, read_picoscenes};

/// PicoScenes device types of the Intel AX200 and AX210.
const INTEL_AX_DEVICES: [u16; 2] = [0x2000, 0x2100];

/// The packets of the capture at `path` in `format`.
pub fn packets(path: &Path, format: CaptureFormat) -> Result<CsiPackets, CaptureError> {
    let io = |source| CaptureError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut out = CsiPackets::default();
    match format {
        CaptureFormat::Intel5300 => {
            let log = read_log(path)?;
            out.packets = log.records.iter().map(intel5300).collect();
            let lost: u64 = log.skips.iter().map(|s| s.len).sum();
            out.lost = (lost > 0).then(|| format!("{lost} bytes in {} regions", log.skips.len()));
        }
        CaptureFormat::Nexmon => {
            let capture = read_nexmon(path)?;
            for frame in frames(&capture.packets) {
                push(&mut out, from_nexmon(&frame));
            }
            out.lost = capture.tail.map(|t| format!("{t:?}"));
        }
        CaptureFormat::FeitCsi => {
            let capture = read_feitcsi(path).map_err(io)?;
            for r in &capture.records {
                push(&mut out, from_feitcsi(r));
            }
            out.lost = capture.lost();
        }
        CaptureFormat::PicoScenes => {
            let capture = read_picoscenes(path).map_err(io)?;
            for f in &capture.frames {
                push(&mut out, picoscenes(f));
            }
            out.lost = capture.lost();
        }
        CaptureFormat::Atheros => {
            let capture = read_atheros(path, None).map_err(io)?;
            for r in &capture.records {
                push(&mut out, from_atheros(r));
            }
            out.lost = capture.lost();
        }
    }
    Ok(out)
}

fn push(out: &mut CsiPackets, packet: Result<CsiPacket, String>) {
    match packet {
        Ok(p) => out.packets.push(p),
        Err(why) => out.skip(why),
    }
}

/// An Intel 5300 record (its chains in antenna order, as the reader puts them).
fn intel5300(r: &CsiRecord) -> CsiPacket {
    let h = &r.header;
    let (nrx, ntx) = (usize::from(h.nrx), usize::from(h.ntx));
    let subcarriers = r.subcarrier_indices().to_vec();
    let mut csi = Vec::with_capacity(subcarriers.len() * nrx * ntx);
    for sc in 0..subcarriers.len() {
        for rx in 0..nrx {
            for tx in 0..ntx {
                let v = r.csi_at(tx, rx, sc).unwrap_or_default();
                csi.push(Complex64::new(f64::from(v.re), f64::from(v.im)));
            }
        }
    }
    CsiPacket {
        format: CaptureFormat::Intel5300,
        offset: r.offset,
        clock_ns: i64::from(h.timestamp_low) * 1000,
        carrier_hz: None,
        bandwidth_mhz: h.rate.bandwidth().mhz(),
        spacing_hz: LEGACY_SPACING_HZ,
        subcarriers,
        chains: (0..h.nrx).collect(),
        num_tx: ntx,
        csi,
        rssi: h
            .rssi
            .iter()
            .take(nrx)
            .map(|&v| Some(f64::from(v)))
            .collect(),
        transmitter: None,
        sequence: None,
    }
}

/// The carrier of a Broadcom chanspec's channel, Hz (bits 14–15: the band, 3 = 5 GHz).
fn broadcom_carrier_hz(chanspec: u16) -> f64 {
    let channel = f64::from(chanspec & 0xff);
    let mhz = if chanspec >> 14 == 3 {
        5000.0 + 5.0 * channel
    } else if channel == 14.0 {
        2484.0
    } else {
        2407.0 + 5.0 * channel
    };
    mhz * 1e6
}

/// A Nexmon frame: one receive row per core, one stream per spatial stream; a frame that lacks
/// a (core, stream) pair the others have is skipped.
pub fn from_nexmon(frame: &NexmonFrame<'_>) -> Result<CsiPacket, String> {
    let first = *frame.packets.first().ok_or("an empty Nexmon frame")?;
    let chains = frame.cores();
    let mut streams: Vec<u8> = frame.packets.iter().map(|p| p.spatial_stream()).collect();
    streams.sort_unstable();
    streams.dedup();
    if chains.len() * streams.len() != frame.packets.len() {
        return Err("a Nexmon frame missing a core of one of its streams".into());
    }
    let bins = first.words.len();
    let kept: Vec<(usize, i32)> = (0..bins)
        .filter_map(|b| tables::nexmon_bin(b, bins).map(|k| (b, k)))
        .collect();
    if kept.is_empty() {
        return Err(format!(
            "a Nexmon frame of {bins} bins (no subcarrier table)"
        ));
    }
    let mut sorted = kept.clone();
    sorted.sort_by_key(|&(_, k)| k);
    let values: Vec<Vec<Complex64>> = frame
        .packets
        .iter()
        .map(|p| {
            let (v, _) = p.csi_autoscaled();
            v.iter()
                .map(|c| Complex64::new(c.re as f64, c.im as f64))
                .collect()
        })
        .collect();
    let find = |core: u8, stream: u8| {
        frame
            .packets
            .iter()
            .position(|p| p.core() == core && p.spatial_stream() == stream)
    };
    let mut csi = Vec::with_capacity(sorted.len() * chains.len() * streams.len());
    for &(bin, _) in &sorted {
        for &core in &chains {
            for &stream in &streams {
                let v = find(core, stream).and_then(|i| values[i].get(bin).copied());
                csi.push(v.ok_or("a Nexmon packet shorter than its frame's")?);
            }
        }
    }
    let rssi = chains
        .iter()
        .map(|&c| {
            let p = frame.packets.iter().find(|p| p.core() == c)?;
            p.rssi_dbm.map(f64::from)
        })
        .collect();
    Ok(CsiPacket {
        format: CaptureFormat::Nexmon,
        offset: first.offset,
        clock_ns: first.time_ns,
        carrier_hz: Some(broadcom_carrier_hz(first.chanspec)),
        bandwidth_mhz: first.bandwidth_mhz(),
        spacing_hz: LEGACY_SPACING_HZ,
        subcarriers: sorted.iter().map(|&(_, k)| k).collect(),
        chains,
        num_tx: streams.len(),
        csi,
        rssi,
        transmitter: Some(first.transmitter),
        sequence: Some(first.seq_num()),
    })
}

/// A FeitCSI record as a packet (its file carries no carrier), or why it cannot be one.
pub fn from_feitcsi(r: &FeitRecord) -> Result<CsiPacket, String> {
    intel_ax(&r.header, &r.csi, r.offset, None)
}

/// An Intel AX200/AX210 report (FeitCSI, PicoScenes): `values` laid out chain, stream, tone.
fn intel_ax(
    h: &IntelCsiHeader,
    values: &[num_complex::Complex<i16>],
    offset: u64,
    carrier_hz: Option<f64>,
) -> Result<CsiPacket, String> {
    let tones = h.num_subcarriers as usize;
    let table = tables::intel_ax(tones)
        .ok_or_else(|| format!("an Intel AX report of {tones} tones (no subcarrier table)"))?;
    let (nrx, ntx) = (usize::from(h.num_rx), usize::from(h.num_tx));
    let he = matches!(h.format(), RateFormat::He | RateFormat::Eht) || tones >= 484;
    let mut subcarriers = Vec::with_capacity(tones);
    let mut csi = Vec::with_capacity(tones * nrx * ntx);
    for (tone, &k) in table.iter().enumerate() {
        if tables::intel_ax_pilot(tones, k) {
            continue;
        }
        subcarriers.push(k);
        for rx in 0..nrx {
            for tx in 0..ntx {
                let v = h
                    .csi_at(values, rx, tx, tone)
                    .ok_or("an Intel AX report shorter than its header says")?;
                csi.push(Complex64::new(f64::from(v.re), f64::from(v.im)));
            }
        }
    }
    Ok(CsiPacket {
        format: CaptureFormat::FeitCsi,
        offset,
        clock_ns: h.mu_clock_ns(),
        carrier_hz,
        bandwidth_mhz: h.width_mhz(),
        spacing_hz: if he { HE_SPACING_HZ } else { LEGACY_SPACING_HZ },
        subcarriers,
        chains: (0..h.num_rx).collect(),
        num_tx: ntx,
        csi,
        rssi: (0..nrx)
            .map(|i| h.rssi.get(i).map(|&v| -f64::from(v)))
            .collect(),
        transmitter: Some(h.source_mac),
        sequence: None,
    })
}

/// A PicoScenes frame of an Intel AX200/AX210.
fn picoscenes(f: &PicoFrame) -> Result<CsiPacket, String> {
    let (Some(c), Some(h)) = (&f.csi, &f.mvm_extra) else {
        return Err("a PicoScenes frame without a CSI or an MVMExtra segment".into());
    };
    if !INTEL_AX_DEVICES.contains(&c.device_type) {
        return Err(format!(
            "a PicoScenes frame of device type {:#06x} (only the Intel AX200/AX210's subcarriers are known)",
            c.device_type
        ));
    }
    if c.subcarrier_index_offset != 0 {
        return Err("a PicoScenes frame whose subcarrier indices are offset".into());
    }
    // The CSI segment's shape is the one to use; the Intel header's rate flags give the format.
    let header = IntelCsiHeader {
        num_rx: c.num_rx,
        num_tx: c.num_sts,
        num_subcarriers: u32::from(c.num_tone),
        ..h.clone()
    };
    let mut p = intel_ax(&header, &c.values, f.offset, Some(c.carrier_freq_hz as f64))?;
    p.format = CaptureFormat::PicoScenes;
    p.bandwidth_mhz = u32::from(c.cbw_mhz);
    p.spacing_hz = f64::from(c.subcarrier_bandwidth_hz);
    if let Some(b) = &f.rxs_basic {
        p.rssi = (0..p.num_rx())
            .map(|i| {
                let v = b.rssi_chains.get(i).copied().unwrap_or(-128);
                (v != -128).then_some(f64::from(v))
            })
            .collect();
    }
    p.transmitter = f.transmitter();
    p.sequence = f.seq_ctl().map(|s| s >> 4);
    Ok(p)
}

/// An Atheros CSI Tool record with CSI as a packet, or why it cannot be one.
pub fn from_atheros(r: &AtherosRecord) -> Result<CsiPacket, String> {
    if r.csi.is_empty() {
        return Err("an Atheros record without CSI".into());
    }
    let tones = usize::from(r.num_tones);
    let subcarriers = tables::atheros(tones)
        .ok_or_else(|| format!("an Atheros record of {tones} tones (no subcarrier table)"))?;
    let (nr, nc) = (usize::from(r.nr), usize::from(r.nc));
    let mut csi = Vec::with_capacity(tones * nr * nc);
    for tone in 0..tones {
        for rx in 0..nr {
            for tx in 0..nc {
                let v = r
                    .csi_at(rx, tx, tone)
                    .ok_or("an Atheros record shorter than its shape")?;
                csi.push(Complex64::new(f64::from(v.re), f64::from(v.im)));
            }
        }
    }
    Ok(CsiPacket {
        format: CaptureFormat::Atheros,
        offset: r.offset,
        clock_ns: r.clock_ns(),
        carrier_hz: Some(f64::from(r.channel_mhz) * 1e6),
        bandwidth_mhz: if r.bandwidth == 1 { 40 } else { 20 },
        spacing_hz: LEGACY_SPACING_HZ,
        subcarriers,
        chains: (0..r.nr).collect(),
        num_tx: nc,
        csi,
        rssi: r
            .rssi_chains
            .iter()
            .take(nr)
            .map(|&v| Some(f64::from(v)))
            .collect(),
        transmitter: r.transmitter(),
        sequence: r.sequence(),
    })
}
