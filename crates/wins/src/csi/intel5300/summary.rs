//! What a log holds, at a glance: the figures `wins csi info` prints.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::Serialize;

use super::framing::{Skip, SkipReason};
use super::reader::{Event, LogReader, ReadError};
use super::record::{CsiRecord, NOISE_UNKNOWN_DBM, Perm};

/// Count, mean and range of a quantity.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Number of values.
    pub count: u64,
    /// Mean (0 when empty).
    pub mean: f64,
    /// Minimum (0 when empty).
    pub min: f64,
    /// Maximum (0 when empty).
    pub max: f64,
}

impl Stats {
    /// Adds a value.
    pub fn add(&mut self, x: f64) {
        if self.count == 0 {
            (self.min, self.max) = (x, x);
        } else {
            self.min = self.min.min(x);
            self.max = self.max.max(x);
        }
        self.count += 1;
        self.mean += (x - self.mean) / self.count as f64;
    }
}

/// Summary of a decoded log. Feed it every [`Event`] in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LogSummary {
    /// Bytes decided on (records and skips).
    pub bytes: u64,
    /// CSI records decoded.
    pub csi_records: u64,
    /// Well-framed non-CSI records, by code (`"0xC1"`).
    pub non_csi_records: BTreeMap<String, u64>,
    /// Unframed regions and truncated tails: every byte lost to corruption, with offsets.
    pub lost: Vec<Skip>,
    /// Bytes in [`Self::lost`].
    pub lost_bytes: u64,
    /// CSI records per `nrx x ntx` shape (`"3x1"`).
    pub chains: BTreeMap<String, u64>,
    /// CSI records per bandwidth (`"20 MHz"`).
    pub bandwidth: BTreeMap<String, u64>,
    /// CSI records per rate (`"HT20 MCS 1 (0x0101)"`).
    pub rates: BTreeMap<String, u64>,
    /// Records whose antenna permutation was invalid and left unapplied.
    pub invalid_perm: u64,
    /// Records whose CSI cannot be scaled (no RSSI reading, or all-zero CSI).
    pub unscalable: u64,
    /// Unwrapped NIC time of the first CSI record, s.
    pub first_time_s: Option<f64>,
    /// Unwrapped NIC time of the last CSI record, s.
    pub last_time_s: Option<f64>,
    /// Last minus first, s.
    pub duration_s: Option<f64>,
    /// CSI records per second over the duration (records − 1 over the span).
    pub packet_rate_hz: Option<f64>,
    /// Times a record's timestamp was earlier than its predecessor's.
    pub timestamp_backsteps: u64,
    /// Reports missing by `bfee_count` (the driver's counter skipped them), counted mod 2¹⁶.
    pub bfee_count_gaps: u64,
    /// Per-chain RSSI (dB relative to AGC) over non-zero readings, chains A, B, C.
    pub rssi_db: [Stats; 3],
    /// Total received power (`get_total_rss`), dBm, over records with a reading.
    pub total_rss_dbm: Stats,
    /// Noise floor, dBm, over records that report one.
    pub noise_dbm: Stats,
    /// Records whose noise is unknown (−127).
    pub noise_unknown: u64,
    /// AGC, dB.
    pub agc_db: Stats,
    #[serde(skip)]
    last: Option<(i64, u16)>,
}

impl LogSummary {
    /// An empty summary.
    pub fn new() -> Self {
        Self::default()
    }

    /// Summarizes a log file, streaming it (memory stays bounded for long captures).
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self, ReadError> {
        let path = path.as_ref();
        let mut summary = Self::new();
        for event in LogReader::open(path)? {
            summary.add(&event.map_err(ReadError::io(path))?);
        }
        Ok(summary)
    }

    /// Adds one event.
    pub fn add(&mut self, event: &Event) {
        match event {
            Event::Csi(r) => self.add_record(r),
            Event::Skipped(s) => self.add_skip(s),
        }
    }

    fn add_skip(&mut self, skip: &Skip) {
        self.bytes += skip.len;
        match skip.reason {
            SkipReason::NonCsi { code } => {
                *self
                    .non_csi_records
                    .entry(format!("0x{code:02X}"))
                    .or_default() += 1;
            }
            SkipReason::Unframed { .. } | SkipReason::TruncatedTail { .. } => {
                self.lost_bytes += skip.len;
                self.lost.push(skip.clone());
            }
        }
    }

    fn add_record(&mut self, r: &CsiRecord) {
        let h = &r.header;
        self.bytes += r.encoded_len() as u64;
        self.csi_records += 1;
        *self
            .chains
            .entry(format!("{}x{}", h.nrx, h.ntx))
            .or_default() += 1;
        *self
            .bandwidth
            .entry(format!("{} MHz", h.rate.bandwidth().mhz()))
            .or_default() += 1;
        *self.rates.entry(h.rate.to_string()).or_default() += 1;
        if matches!(r.perm, Perm::Invalid(_)) {
            self.invalid_perm += 1;
        }
        if r.scale_factor().is_err() {
            self.unscalable += 1;
        }
        let t = r.timestamp.as_nanos();
        if let Some((last_t, last_count)) = self.last {
            if t < last_t {
                self.timestamp_backsteps += 1;
            }
            let step = h.bfee_count.wrapping_sub(last_count);
            if step > 1 && step < u16::MAX / 2 {
                self.bfee_count_gaps += u64::from(step - 1);
            }
        }
        self.last = Some((t, h.bfee_count));
        let t_s = r.timestamp.as_secs_f64();
        let first = *self.first_time_s.get_or_insert(t_s);
        self.last_time_s = Some(t_s);
        let span = t_s - first;
        self.duration_s = Some(span);
        self.packet_rate_hz = (span > 0.0).then(|| (self.csi_records - 1) as f64 / span);
        for (stats, &rssi) in self.rssi_db.iter_mut().zip(&h.rssi) {
            if rssi != 0 {
                stats.add(f64::from(rssi));
            }
        }
        let rss = r.total_rss_dbm();
        if rss.is_finite() {
            self.total_rss_dbm.add(rss);
        }
        if h.noise_dbm == NOISE_UNKNOWN_DBM {
            self.noise_unknown += 1;
        } else {
            self.noise_dbm.add(f64::from(h.noise_dbm));
        }
        self.agc_db.add(f64::from(h.agc));
    }
}

/// Most lost regions the text report lists one by one (the JSON form has all).
const LOST_LISTED: usize = 20;

fn histogram(f: &mut fmt::Formatter<'_>, name: &str, h: &BTreeMap<String, u64>) -> fmt::Result {
    let items: Vec<String> = h.iter().map(|(k, n)| format!("{k}: {n}")).collect();
    writeln!(
        f,
        "{name:<12}{}",
        if items.is_empty() {
            "-".to_owned()
        } else {
            items.join(", ")
        }
    )
}

fn stats(f: &mut fmt::Formatter<'_>, name: &str, s: &Stats, unit: &str) -> fmt::Result {
    if s.count == 0 {
        return writeln!(f, "{name:<12}-");
    }
    writeln!(
        f,
        "{name:<12}mean {:.1} {unit}, range [{:.1}, {:.1}] over {} records",
        s.mean, s.min, s.max, s.count
    )
}

/// The report `wins csi info` prints.
impl fmt::Display for LogSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let non_csi: u64 = self.non_csi_records.values().sum();
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        write!(
            f,
            "{:<12}{} CSI, {non_csi} non-CSI",
            "records", self.csi_records
        )?;
        if non_csi > 0 {
            let codes: Vec<String> = self
                .non_csi_records
                .iter()
                .map(|(c, n)| format!("{c}: {n}"))
                .collect();
            write!(f, " ({})", codes.join(", "))?;
        }
        writeln!(f)?;
        writeln!(
            f,
            "{:<12}{} bytes in {} regions",
            "lost",
            self.lost_bytes,
            self.lost.len()
        )?;
        for s in self.lost.iter().take(LOST_LISTED) {
            writeln!(
                f,
                "{:<12}  offset {}: {} bytes, {}",
                "", s.offset, s.len, s.reason
            )?;
        }
        if self.lost.len() > LOST_LISTED {
            writeln!(
                f,
                "{:<12}  … and {} more (see --json)",
                "",
                self.lost.len() - LOST_LISTED
            )?;
        }
        histogram(f, "rx x tx", &self.chains)?;
        histogram(f, "bandwidth", &self.bandwidth)?;
        histogram(f, "rates", &self.rates)?;
        writeln!(
            f,
            "{:<12}{} records with an invalid permutation (left in chain order)",
            "perm", self.invalid_perm
        )?;
        match (self.first_time_s, self.duration_s) {
            (Some(t0), Some(d)) => {
                write!(f, "{:<12}{d:.3} s from NIC time {t0:.6} s", "duration")?;
                if let Some(rate) = self.packet_rate_hz {
                    write!(f, ", {rate:.1} packets/s")?;
                }
                writeln!(f)?;
            }
            _ => writeln!(f, "{:<12}-", "duration")?,
        }
        writeln!(
            f,
            "{:<12}{} backward time steps, {} reports missing by bfee_count",
            "continuity", self.timestamp_backsteps, self.bfee_count_gaps
        )?;
        for (chain, s) in ["A", "B", "C"].iter().zip(&self.rssi_db) {
            stats(f, &format!("rssi {chain}"), s, "dB")?;
        }
        stats(f, "total rss", &self.total_rss_dbm, "dBm")?;
        stats(f, "noise", &self.noise_dbm, "dBm")?;
        if self.noise_unknown > 0 {
            writeln!(
                f,
                "{:<12}unknown (-127) on {} records; scaling assumes -92 dBm",
                "", self.noise_unknown
            )?;
        }
        stats(f, "agc", &self.agc_db, "dB")?;
        writeln!(
            f,
            "{:<12}{} records cannot be scaled (no RSSI or all-zero CSI)",
            "unscalable", self.unscalable
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_track_mean_and_range() {
        let mut s = Stats::default();
        for x in [3.0, -1.0, 4.0] {
            s.add(x);
        }
        assert_eq!((s.count, s.min, s.max), (3, -1.0, 4.0));
        assert!((s.mean - 2.0).abs() < 1e-12);
    }
}
