//! The captures of other cards than the Intel 5300: Nexmon pcaps (`read_nexmon`) and FeitCSI
//! files (`read_feitcsi`), as columns the Python half turns into numpy arrays; and any card's
//! capture as the one CSI type (`read_packets`).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::csi::{le_bytes, put_column, put_i64};
use crate::{raise, raise_text};

/// Reads a Nexmon capture (see python/wins/__init__.py, `read_nexmon`): one row per CSI packet,
/// the CSI autoscaled as csiread gives it (or exact), and each packet's frame.
#[pyfunction]
#[pyo3(signature = (path, exact = false))]
pub fn read_nexmon(py: Python<'_>, path: PathBuf, exact: bool) -> PyResult<Py<PyDict>> {
    let capture = py
        .detach(|| wins::csi::nexmon::read_nexmon(&path))
        .map_err(raise)?;
    let packets = &capture.packets;
    if packets.is_empty() {
        return Err(raise_text(format!(
            "{}: no Nexmon CSI packets ({} records of other traffic)",
            path.display(),
            capture.other_records
        )));
    }
    let bins = packets.iter().map(|p| p.words.len()).max().unwrap_or(0);
    let n = packets.len();
    let out = PyDict::new(py);
    out.set_item("count", n)?;
    out.set_item("bins", bins)?;
    let columns = PyDict::new(py);
    let column = |name: &str, f: &dyn Fn(&wins::csi::nexmon::NexmonPacket) -> i64| {
        put_column(&columns, packets, name, f)
    };
    column("sec", &|p| i64::from(p.ts_sec))?;
    column("usec", &|p| i64::from(p.ts_frac))?;
    column("caplen", &|p| i64::from(p.caplen))?;
    column("wirelen", &|p| i64::from(p.wirelen))?;
    column("magic", &|p| i64::from(p.magic))?;
    column("seq", &|p| i64::from(p.seq))?;
    column("core", &|p| i64::from(p.core()))?;
    column("spatial", &|p| i64::from(p.spatial_stream()))?;
    column("chan_spec", &|p| i64::from(p.chanspec))?;
    column("channel", &|p| i64::from(p.channel()))?;
    column("bandwidth_mhz", &|p| i64::from(p.bandwidth_mhz()))?;
    column("chip", &|p| i64::from(p.chip))?;
    column("rssi", &|p| p.rssi_dbm.map_or(i64::MIN, i64::from))?;
    let mut frame = vec![0i64; n];
    for (k, f) in wins::csi::nexmon::frames::frames(packets)
        .iter()
        .enumerate()
    {
        for p in &f.packets {
            frame[p.index] = k as i64;
        }
    }
    put_i64(&columns, "frame", &frame, vec![n])?;
    let macs: Vec<u8> = packets.iter().flat_map(|p| p.transmitter).collect();
    columns.set_item("src_addr", (PyBytes::new(py, &macs), "u1", vec![n, 6]))?;
    // Each packet decoded once: its autoscaled values and shift (and its exact values if asked).
    let mut csi = vec![0f64; n * bins * 2];
    let mut shifts = Vec::with_capacity(n);
    for (row, p) in csi.chunks_mut(bins * 2).zip(packets) {
        let (autoscaled, shift) = p.csi_autoscaled();
        shifts.push(i64::from(shift));
        let values: Vec<(f64, f64)> = if exact {
            p.csi_exact().iter().map(|c| (c.re, c.im)).collect()
        } else {
            autoscaled
                .iter()
                .map(|c| (c.re as f64, c.im as f64))
                .collect()
        };
        for (slot, (re, im)) in row.chunks_mut(2).zip(values) {
            slot[0] = re;
            slot[1] = im;
        }
    }
    put_i64(&columns, "float_shift", &shifts, vec![n])?;
    columns.set_item(
        "csi_re_im",
        (
            PyBytes::new(py, &le_bytes(&csi, f64::to_le_bytes)),
            "<f8",
            vec![n, bins, 2],
        ),
    )?;
    out.set_item("columns", columns)?;
    let tail = capture.tail.as_ref().map(ToString::to_string);
    out.set_item("other_records", capture.other_records)?;
    out.set_item("tail", tail)?;
    Ok(out.unbind())
}

/// Reads a FeitCSI file (see python/wins/__init__.py, `read_feitcsi`): one row per record, the
/// CSI in a `records × subcarriers × rx × tx` block (zero where a record has fewer).
#[pyfunction]
pub fn read_feitcsi(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyDict>> {
    let capture = py
        .detach(|| wins::csi::feitcsi::read_feitcsi(&path))
        .map_err(raise)?;
    let records = &capture.records;
    if records.is_empty() {
        let why = capture
            .tail
            .as_ref()
            .map_or("empty".to_string(), |t| t.2.clone());
        return Err(raise_text(format!(
            "{}: no FeitCSI records: {why}",
            path.display()
        )));
    }
    let n = records.len();
    let nsc = records
        .iter()
        .map(|r| r.header.num_subcarriers as usize)
        .max()
        .unwrap_or(0);
    let nrx = records
        .iter()
        .map(|r| usize::from(r.header.num_rx))
        .max()
        .unwrap_or(0);
    let ntx = records
        .iter()
        .map(|r| usize::from(r.header.num_tx))
        .max()
        .unwrap_or(0);
    let out = PyDict::new(py);
    out.set_item("count", n)?;
    out.set_item("shape", (nsc, nrx, ntx))?;
    let columns = PyDict::new(py);
    let column = |name: &str, f: &dyn Fn(&wins::csi::feitcsi::FeitRecord) -> i64| {
        put_column(&columns, records, name, f)
    };
    column("offset", &|r| r.offset as i64)?;
    column("ftm_clock", &|r| i64::from(r.header.ftm_clock))?;
    column("mu_clock", &|r| i64::from(r.header.mu_clock))?;
    column("num_rx", &|r| i64::from(r.header.num_rx))?;
    column("num_tx", &|r| i64::from(r.header.num_tx))?;
    column("num_subcarriers", &|r| i64::from(r.header.num_subcarriers))?;
    column("rssi1", &|r| i64::from(r.header.rssi[0]))?;
    column("rssi2", &|r| i64::from(r.header.rssi[1]))?;
    column("rate_flags", &|r| i64::from(r.header.rate_flags))?;
    column("mcs", &|r| i64::from(r.header.mcs()))?;
    column("width_mhz", &|r| i64::from(r.header.width_mhz()))?;
    let macs: Vec<u8> = records.iter().flat_map(|r| r.header.source_mac).collect();
    columns.set_item("source_mac", (PyBytes::new(py, &macs), "u1", vec![n, 6]))?;
    put_csi_block(&columns, records, (nsc, nrx, ntx), |r, sc, rx, tx| {
        r.csi_at(rx, tx, sc).map(|c| (c.re, c.im))
    })?;
    out.set_item("columns", columns)?;
    let formats: Vec<&str> = records.iter().map(|r| r.header.format().name()).collect();
    out.set_item("format", formats)?;
    out.set_item("tail", capture.lost())?;
    Ok(out.unbind())
}

/// Reads any card's capture as packets (see python/wins/__init__.py, `read_packets`): the
/// format, one dict per packet (its CSI as little-endian float64 pairs), the skips and what
/// was not read.
#[pyfunction]
#[pyo3(signature = (path, format = None))]
pub fn read_packets(py: Python<'_>, path: PathBuf, format: Option<String>) -> PyResult<Py<PyDict>> {
    let forced = match &format {
        Some(name) => Some(
            name.parse::<wins::csi::format::CaptureFormat>()
                .map_err(raise_text)?,
        ),
        None => None,
    };
    let (format, read) = py
        .detach(|| wins::csi::packet::read_packets(&path, forced))
        .map_err(raise)?;
    let out = PyDict::new(py);
    out.set_item("format", format.name())?;
    let packets = pyo3::types::PyList::empty(py);
    for p in &read.packets {
        let d = PyDict::new(py);
        d.set_item("offset", p.offset)?;
        d.set_item("clock_ns", p.clock_ns)?;
        d.set_item("carrier_hz", p.carrier_hz)?;
        d.set_item("bandwidth_mhz", p.bandwidth_mhz)?;
        d.set_item("spacing_hz", p.spacing_hz)?;
        d.set_item("subcarriers", p.subcarriers.clone())?;
        d.set_item("chains", p.chains.clone())?;
        d.set_item("num_tx", p.num_tx)?;
        let re_im: Vec<f64> = p.csi.iter().flat_map(|c| [c.re, c.im]).collect();
        d.set_item("csi", PyBytes::new(py, &le_bytes(&re_im, f64::to_le_bytes)))?;
        d.set_item("rssi", p.rssi.clone())?;
        d.set_item(
            "transmitter",
            p.transmitter.map(|m| wins::csi::report::mac(&m)),
        )?;
        d.set_item("sequence", p.sequence)?;
        packets.append(d)?;
    }
    out.set_item("packets", packets)?;
    out.set_item("skipped", read.skipped.clone())?;
    out.set_item("lost", read.lost.clone())?;
    Ok(out.unbind())
}

/// The column `csi_re_im`: the complex values of `records` in one `records × tones × rx × tx`
/// block of int16 `[re, im]` (zero where a record has fewer), from each record's
/// `at(tone, rx, tx)`.
fn put_csi_block<R>(
    columns: &Bound<'_, PyDict>,
    records: &[R],
    shape: (usize, usize, usize),
    at: impl Fn(&R, usize, usize, usize) -> Option<(i16, i16)>,
) -> PyResult<()> {
    let (nt, nr, nc) = shape;
    let mut out = vec![0i16; records.len() * nt * nr * nc * 2];
    for (block, r) in out.chunks_mut((nt * nr * nc * 2).max(1)).zip(records) {
        for t in 0..nt {
            for rx in 0..nr {
                for tx in 0..nc {
                    if let Some((re, im)) = at(r, t, rx, tx) {
                        let i = ((t * nr + rx) * nc + tx) * 2;
                        block[i] = re;
                        block[i + 1] = im;
                    }
                }
            }
        }
    }
    columns.set_item(
        "csi_re_im",
        (
            PyBytes::new(columns.py(), &le_bytes(&out, i16::to_le_bytes)),
            "<i2",
            vec![records.len(), nt, nr, nc, 2],
        ),
    )
}

/// Reads an Atheros CSI Tool log (see python/wins/__init__.py, `read_atheros`): one row per
/// record, csiread's names, the CSI in the vendor's layout.
#[pyfunction]
pub fn read_atheros(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyDict>> {
    let capture = py
        .detach(|| wins::csi::atheros::read_atheros(&path, None))
        .map_err(raise)?;
    let records = &capture.records;
    if records.is_empty() {
        return Err(raise_text(format!(
            "{}: no Atheros CSI Tool records: {}",
            path.display(),
            capture.lost().unwrap_or_else(|| "empty".into())
        )));
    }
    let n = records.len();
    let max = |f: &dyn Fn(&wins::csi::atheros::AtherosRecord) -> u8| {
        records.iter().map(|r| usize::from(f(r))).max().unwrap_or(0)
    };
    let shape = (max(&|r| r.num_tones), max(&|r| r.nr), max(&|r| r.nc));
    let out = PyDict::new(py);
    out.set_item("count", n)?;
    out.set_item("shape", shape)?;
    let columns = PyDict::new(py);
    let column = |name: &str, f: &dyn Fn(&wins::csi::atheros::AtherosRecord) -> i64| {
        put_column(&columns, records, name, f)
    };
    column("offset", &|r| r.offset as i64)?;
    column("timestamp", &|r| r.timestamp_us as i64)?;
    column("csi_len", &|r| i64::from(r.csi_len))?;
    column("tx_channel", &|r| i64::from(r.channel_mhz))?;
    column("err_info", &|r| i64::from(r.err_info))?;
    column("noise_floor", &|r| i64::from(r.noise_floor))?;
    column("rate", &|r| i64::from(r.rate))?;
    column("bandwidth", &|r| i64::from(r.bandwidth))?;
    column("num_tones", &|r| i64::from(r.num_tones))?;
    column("nr", &|r| i64::from(r.nr))?;
    column("nc", &|r| i64::from(r.nc))?;
    column("rssi", &|r| i64::from(r.rssi))?;
    column("rssi_1", &|r| i64::from(r.rssi_chains[0]))?;
    column("rssi_2", &|r| i64::from(r.rssi_chains[1]))?;
    column("rssi_3", &|r| i64::from(r.rssi_chains[2]))?;
    column("payload_len", &|r| r.payload.len() as i64)?;
    put_csi_block(&columns, records, shape, |r, t, rx, tx| {
        r.csi_at(rx, tx, t).map(|c| (c.re, c.im))
    })?;
    out.set_item("columns", columns)?;
    let payloads: Vec<&[u8]> = records.iter().map(|r| r.payload.as_slice()).collect();
    out.set_item("payloads", payloads)?;
    out.set_item("order", format!("{:?}", capture.order).to_lowercase())?;
    out.set_item("tail", capture.lost())?;
    Ok(out.unbind())
}

/// Reads a PicoScenes file (see python/wins/__init__.py, `read_picoscenes`): one row per frame
/// with CSI, its RxSBasic and CSI header fields and the MPDU's addresses, the CSI as stored.
#[pyfunction]
pub fn read_picoscenes(py: Python<'_>, path: PathBuf) -> PyResult<Py<PyDict>> {
    let capture = py
        .detach(|| wins::csi::picoscenes::read_picoscenes(&path))
        .map_err(raise)?;
    let frames: Vec<&wins::csi::picoscenes::PicoFrame> =
        capture.frames.iter().filter(|f| f.csi.is_some()).collect();
    if frames.is_empty() {
        return Err(raise_text(format!(
            "{}: no PicoScenes frame with CSI: {}",
            path.display(),
            capture.lost().unwrap_or_else(|| "no CSI segment".into())
        )));
    }
    let n = frames.len();
    type Frame<'a> = &'a wins::csi::picoscenes::PicoFrame;
    fn csi_of(f: Frame<'_>) -> Option<&wins::csi::picoscenes::PicoCsi> {
        f.csi.as_ref()
    }
    let max = |g: &dyn Fn(&wins::csi::picoscenes::PicoCsi) -> usize| {
        frames
            .iter()
            .filter_map(|f| csi_of(f))
            .map(g)
            .max()
            .unwrap_or(0)
    };
    let shape = (
        max(&|c| usize::from(c.num_tone)),
        max(&|c| usize::from(c.num_rx)),
        max(&|c| usize::from(c.num_sts)),
    );
    let out = PyDict::new(py);
    out.set_item("count", n)?;
    out.set_item("shape", shape)?;
    let columns = PyDict::new(py);
    let column =
        |name: &str, f: &dyn Fn(Frame<'_>) -> i64| put_column(&columns, &frames, name, |x| f(x));
    let basic = |f: Frame<'_>, g: &dyn Fn(&wins::csi::picoscenes::RxsBasic) -> i64| {
        f.rxs_basic.as_ref().map_or(i64::MIN, g)
    };
    let csi_field = |f: Frame<'_>, g: &dyn Fn(&wins::csi::picoscenes::PicoCsi) -> i64| {
        csi_of(f).map_or(i64::MIN, g)
    };
    column("offset", &|f| f.offset as i64)?;
    column("mu_clock", &|f| {
        f.mvm_extra
            .as_ref()
            .map_or(i64::MIN, |h| i64::from(h.mu_clock))
    })?;
    column("device_type", &|f| basic(f, &|b| i64::from(b.device_type)))?;
    column("packet_format", &|f| {
        basic(f, &|b| i64::from(b.packet_format))
    })?;
    column("cbw", &|f| basic(f, &|b| i64::from(b.cbw_mhz)))?;
    column("mcs", &|f| basic(f, &|b| i64::from(b.mcs)))?;
    column("num_sts", &|f| basic(f, &|b| i64::from(b.num_sts)))?;
    column("noise_floor", &|f| basic(f, &|b| i64::from(b.noise_floor)))?;
    column("rssi", &|f| basic(f, &|b| i64::from(b.rssi)))?;
    for (i, name) in ["rssi_ctl0", "rssi_ctl1", "rssi_ctl2"]
        .into_iter()
        .enumerate()
    {
        column(name, &|f| basic(f, &|b| i64::from(b.rssi_chains[i])))?;
    }
    column("carrier_freq", &|f| {
        csi_field(f, &|c| c.carrier_freq_hz as i64)
    })?;
    column("firmware_version", &|f| {
        csi_field(f, &|c| i64::from(c.firmware_version))
    })?;
    column("num_tone", &|f| csi_field(f, &|c| i64::from(c.num_tone)))?;
    column("num_rx", &|f| csi_field(f, &|c| i64::from(c.num_rx)))?;
    column("frame_control", &|f| {
        f.frame_control().map_or(i64::MIN, i64::from)
    })?;
    column("seq_ctl", &|f| f.seq_ctl().map_or(i64::MIN, i64::from))?;
    put_csi_block(&columns, &frames, shape, |f, t, rx, sts| {
        csi_of(f)
            .and_then(|c| c.at(rx, sts, t))
            .map(|v| (v.re, v.im))
    })?;
    out.set_item("columns", columns)?;
    let mac = |m: Option<wins::csi::MacAddress>| m.map(|m| wins::csi::report::mac(&m));
    out.set_item(
        "addr1",
        frames.iter().map(|f| mac(f.receiver())).collect::<Vec<_>>(),
    )?;
    out.set_item(
        "addr2",
        frames
            .iter()
            .map(|f| mac(f.transmitter()))
            .collect::<Vec<_>>(),
    )?;
    out.set_item("tail", capture.lost())?;
    Ok(out.unbind())
}

/// Checks a capture of any card for AoA (see python/wins/__init__.py, `check`): the check as
/// JSON, as `wins csi check --json` gives it.
#[pyfunction]
#[pyo3(signature = (path, channel = None, calibration = None, format = None))]
pub fn check(
    py: Python<'_>,
    path: PathBuf,
    channel: Option<u32>,
    calibration: Option<PathBuf>,
    format: Option<String>,
) -> PyResult<String> {
    let forced = match &format {
        Some(name) => Some(
            name.parse::<wins::csi::format::CaptureFormat>()
                .map_err(raise_text)?,
        ),
        None => None,
    };
    let center_freq_hz = match channel {
        Some(n) => Some(wins::rig::channel::wifi_channel_hz(n).ok_or_else(|| {
            raise_text(format!(
                "channel {n} is not a Wi-Fi channel (1–14 at 2.4 GHz, 32–177 at 5 GHz)"
            ))
        })?),
        None => None,
    };
    let calibration = match &calibration {
        Some(p) => Some(wins::rig::ChainCalibration::load(p).map_err(raise)?),
        None => None,
    };
    let options = wins::aoa::capture_check::CheckOptions {
        center_freq_hz,
        calibration,
    };
    let checked = py
        .detach(|| wins::aoa::capture_check::check_any(&path, forced, &options))
        .map_err(raise)?;
    let value = serde_json::json!({ "verdict": checked.verdict(), "check": checked });
    serde_json::to_string(&value).map_err(raise)
}
