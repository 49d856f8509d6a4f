//! CSI logs to columns (`read_csi`, `CsiChunks`) and per-packet AoA (`aoa`).

use std::fs::File;
use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use wins::Config;
use wins::csi::format::CaptureFormat;
use wins::csi::intel5300::{CsiColumns, Event, LogReader, ReadError, Skip, why_no_records};
use wins::io_safety::open_regular;
use wins::pipeline::aoa_log::AoaMode;
use wins::pipeline::aoa_log::capture::estimate_capture;
use wins::pipeline::aoa_log::input::{AoaInput, AoaSpec};
use wins::rig::ChainCalibration;

use crate::{raise, raise_text};

/// The most chains or streams an Intel 5300 reports.
const MAX_CHAINS: usize = 3;

/// `n` as a chain or stream count, 1–3.
fn chains(n: usize, what: &str) -> PyResult<usize> {
    if (1..=MAX_CHAINS).contains(&n) {
        Ok(n)
    } else {
        Err(raise_text(format!(
            "{what} = {n}: an Intel 5300 has 1 to 3"
        )))
    }
}

/// Little-endian bytes of `values`.
pub(crate) fn le_bytes<T: Copy, const N: usize>(values: &[T], to: fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&v| to(v)).collect()
}

/// Sets `columns[name]` to the numpy description of `values`: `(bytes, "<i8", shape)`.
pub(crate) fn put_i64(
    columns: &Bound<'_, PyDict>,
    name: &str,
    values: &[i64],
    shape: Vec<usize>,
) -> PyResult<()> {
    let bytes = PyBytes::new(columns.py(), &le_bytes(values, i64::to_le_bytes));
    columns.set_item(name, (bytes, "<i8", shape))
}

/// One int64 column `name`: `f` of each of `items`.
pub(crate) fn put_column<R>(
    columns: &Bound<'_, PyDict>,
    items: &[R],
    name: &str,
    f: impl Fn(&R) -> i64,
) -> PyResult<()> {
    put_i64(
        columns,
        name,
        &items.iter().map(f).collect::<Vec<_>>(),
        vec![items.len()],
    )
}

/// The columns as a dict: each field `(bytes, numpy dtype, shape)`, the CSI as int8 pairs.
fn columns_dict<'py>(
    py: Python<'py>,
    c: &CsiColumns,
    skips: &[Skip],
) -> PyResult<Bound<'py, PyDict>> {
    let n = c.count();
    let out = PyDict::new(py);
    out.set_item("count", n)?;
    out.set_item("nrx", c.nrx)?;
    out.set_item("ntx", c.ntx)?;
    let columns = PyDict::new(py);
    let put = |name: &str, bytes: Vec<u8>, dtype: &str, shape: Vec<usize>| {
        columns.set_item(name, (PyBytes::new(py, &bytes), dtype, shape))
    };
    put(
        "offset",
        le_bytes(&c.offset, u64::to_le_bytes),
        "<u8",
        vec![n],
    )?;
    put(
        "timestamp_low",
        le_bytes(&c.timestamp_low, u32::to_le_bytes),
        "<u4",
        vec![n],
    )?;
    put_i64(&columns, "timestamp_ns", &c.timestamp_ns, vec![n])?;
    put_i64(&columns, "bfee_count", &c.bfee_count, vec![n])?;
    put_i64(&columns, "Nrx", &c.nrx_of, vec![n])?;
    put_i64(&columns, "Ntx", &c.ntx_of, vec![n])?;
    for (name, rssi) in ["rssi_a", "rssi_b", "rssi_c"].iter().zip(&c.rssi) {
        put_i64(&columns, name, rssi, vec![n])?;
    }
    put_i64(&columns, "noise", &c.noise, vec![n])?;
    put_i64(&columns, "agc", &c.agc, vec![n])?;
    let perm: Vec<i64> = c.perm.iter().flatten().copied().collect();
    put_i64(&columns, "perm", &perm, vec![n, 3])?;
    put_i64(&columns, "rate", &c.rate, vec![n])?;
    let csi = PyBytes::new_with(py, c.csi_re_im.len(), |buf| {
        for (b, v) in buf.iter_mut().zip(&c.csi_re_im) {
            *b = v.to_le_bytes()[0];
        }
        Ok(())
    })?;
    columns.set_item("csi_re_im", (csi, "i1", vec![n, 30, c.nrx, c.ntx, 2]))?;
    out.set_item("columns", columns)?;
    let skipped = PyList::empty(py);
    for s in skips {
        skipped.append((s.offset, s.len, s.reason.to_string()))?;
    }
    out.set_item("skipped", skipped)?;
    Ok(out)
}

/// Reads a whole Intel 5300 log (see python/wins/__init__.py, `read_csi`), as it is decoded:
/// only the columns are held.
#[pyfunction]
#[pyo3(signature = (path, nrx = 3, ntx = None))]
pub fn read_csi(
    py: Python<'_>,
    path: PathBuf,
    nrx: usize,
    ntx: Option<usize>,
) -> PyResult<Py<PyDict>> {
    let nrx = chains(nrx, "nrx")?;
    let block_ntx = ntx.map(|n| chains(n, "ntx")).transpose()?;
    let (columns, skips, bytes) = py
        .detach(|| -> Result<_, ReadError> {
            let file = open_regular(&path).map_err(ReadError::io(&path))?;
            let bytes = file.metadata().map_err(ReadError::io(&path))?.len();
            let mut columns = CsiColumns::new(nrx, block_ntx.unwrap_or(MAX_CHAINS));
            let mut skips: Vec<Skip> = Vec::new();
            for event in LogReader::new(file) {
                match event.map_err(ReadError::io(&path))? {
                    Event::Csi(record) => columns.push(&record),
                    Event::Skipped(s) => merge_skip(&mut skips, s),
                }
            }
            if block_ntx.is_none() {
                columns.keep_streams(columns.most_streams().max(1));
            }
            Ok((columns, skips, bytes))
        })
        .map_err(raise)?;
    if columns.count() == 0 {
        return Err(raise_text(format!(
            "{}: no CSI records ({bytes} bytes): {}",
            path.display(),
            why_no_records(&path)
        )));
    }
    let out = columns_dict(py, &columns, &skips)?;
    out.set_item("bytes", bytes)?;
    Ok(out.unbind())
}

/// Appends `s`, merged into the last skip when it follows it for the same reason (a long run of
/// garbage is one skip, as `read_log` gives it).
fn merge_skip(skips: &mut Vec<Skip>, s: Skip) {
    match skips.last_mut() {
        Some(last) if last.offset + last.len == s.offset && last.reason == s.reason => {
            last.len += s.len;
        }
        _ => skips.push(s),
    }
}

/// A log read in chunks of records (see python/wins/__init__.py, `iter_csi`).
#[pyclass(module = "wins._wins")]
pub struct CsiChunks {
    reader: LogReader<File>,
    chunk: usize,
    nrx: usize,
    ntx: usize,
    done: bool,
}

#[pymethods]
impl CsiChunks {
    #[new]
    #[pyo3(signature = (path, chunk = 10_000, nrx = 3, ntx = 3))]
    fn new(path: PathBuf, chunk: usize, nrx: usize, ntx: usize) -> PyResult<Self> {
        if chunk == 0 {
            return Err(raise_text("chunk = 0: a chunk holds at least one record"));
        }
        Ok(Self {
            reader: LogReader::open(&path).map_err(raise)?,
            chunk,
            nrx: chains(nrx, "nrx")?,
            ntx: chains(ntx, "ntx")?,
            done: false,
        })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<Py<PyDict>>> {
        if self.done {
            return Ok(None);
        }
        let mut columns = CsiColumns::new(self.nrx, self.ntx);
        let mut skips = Vec::new();
        while columns.count() < self.chunk {
            match self.reader.next() {
                Some(Ok(Event::Csi(record))) => columns.push(&record),
                Some(Ok(Event::Skipped(skip))) => merge_skip(&mut skips, skip),
                Some(Err(e)) => return Err(raise(e)),
                None => {
                    self.done = true;
                    break;
                }
            }
        }
        if columns.count() == 0 && skips.is_empty() {
            return Ok(None);
        }
        Ok(Some(columns_dict(py, &columns, &skips)?.unbind()))
    }
}

/// Per-packet AoA as `wins aoa` gives it (see python/wins/__init__.py, `aoa`): the rows and the
/// summary as JSON, and the warnings.
#[pyfunction]
#[pyo3(signature = (path, ap = None, channel = None, center_freq_hz = None, spacing_m = None,
                    config = None, calibration = None, mode = "music", group_size = 10,
                    csi_format = None))]
#[allow(clippy::too_many_arguments)]
pub fn aoa(
    py: Python<'_>,
    path: PathBuf,
    ap: Option<String>,
    channel: Option<u32>,
    center_freq_hz: Option<f64>,
    spacing_m: Option<f64>,
    config: Option<PathBuf>,
    calibration: Option<PathBuf>,
    mode: &str,
    group_size: usize,
    csi_format: Option<String>,
) -> PyResult<(String, String, Vec<String>)> {
    let forced = match &csi_format {
        Some(name) => Some(name.parse::<CaptureFormat>().map_err(raise_text)?),
        None => None,
    };
    let mode = match mode {
        "music" => AoaMode::Music,
        "spotfi" => AoaMode::Spotfi { group_size },
        other => {
            return Err(raise_text(format!(
                "mode {other:?}: \"music\" or \"spotfi\""
            )));
        }
    };
    let config = match &config {
        Some(p) => Config::from_toml_file(p).map_err(raise)?.aoa,
        None => Config::default().aoa,
    };
    let calibration = match &calibration {
        Some(p) => Some(ChainCalibration::load(p).map_err(raise)?),
        None => None,
    };
    let uncalibrated = calibration.is_none();
    let spec = AoaSpec {
        file: path,
        ap,
        channel,
        center_freq_hz,
        spacing_m,
        config,
    };
    if let Some(format) = CaptureFormat::other_card(&spec.file, forced) {
        if !matches!(mode, AoaMode::Music) {
            return Err(raise_text(format!(
                "mode \"spotfi\" takes Intel 5300 logs and datasets; {} is {}",
                spec.file.display(),
                format.describe()
            )));
        }
        let out = py
            .detach(|| estimate_capture(&spec, format, calibration))
            .map_err(raise)?;
        let mut warnings: Vec<String> = out.lost.iter().map(|l| format!("not read: {l}")).collect();
        if uncalibrated {
            warnings.push(wins::pipeline::aoa_log::capture::UNCALIBRATED.into());
        }
        let rows = serde_json::to_string(&out.rows).map_err(raise)?;
        let summary = serde_json::to_string(&out.summary).map_err(raise)?;
        return Ok((rows, summary, warnings));
    }
    let outcome = py
        .detach(|| AoaInput::open(&spec)?.estimate(calibration, mode))
        .map_err(raise)?;
    let mut warnings: Vec<String> = outcome.ambiguity.iter().cloned().collect();
    if uncalibrated {
        warnings.push(wins::pipeline::aoa_log::input::UNCALIBRATED.into());
    }
    let rows = serde_json::to_string(&outcome.rows).map_err(raise)?;
    let summary = serde_json::to_string(&outcome.summary).map_err(raise)?;
    Ok((rows, summary, warnings))
}
