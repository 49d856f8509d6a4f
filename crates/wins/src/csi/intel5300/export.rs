//! Export of decoded CSI as JSON lines (the schema of the reference files in
//! `shared/data/intel5300`, so the two can be diffed) or as a long-format CSV.

use std::io::{self, Read, Write};

use serde::Serialize;

use super::framing::{Skip, SkipReason};
use super::reader::{Event, LogReader};
use super::record::CsiRecord;
use crate::csi::subcarriers::NUM_SUBCARRIERS;

/// Output format of [`export`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// One JSON object per CSI record: `index`, `timestamp_low`, `bfee_count`, `nrx`, `ntx`, `rssi`,
    /// `noise`, `agc`, `perm` (1-based, as MATLAB prints it), `rate`, `csi_re_im` and
    /// `csi_scaled_re_im`, each `[re, im]` indexed `[tx][rx][subcarrier]` after the permutation.
    /// `csi_scaled_re_im` is left out for records that cannot be scaled.
    Jsonl,
    /// One row per (record, tx, rx, subcarrier) with the record's header fields repeated, the true
    /// subcarrier index, and raw and scaled CSI (scaled empty when unscalable).
    Csv,
}

/// What an export wrote and skipped.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ExportStats {
    /// CSI records written.
    pub records: u64,
    /// Well-framed non-CSI records skipped.
    pub non_csi_records: u64,
    /// Records written without scaled CSI.
    pub unscalable: u64,
    /// Corrupt regions skipped, with offsets.
    pub lost: Vec<Skip>,
}

#[derive(Serialize)]
struct JsonRecord {
    index: u64,
    timestamp_low: u32,
    bfee_count: u16,
    nrx: u8,
    ntx: u8,
    rssi: [u8; 3],
    noise: i8,
    agc: u8,
    perm: [u8; 3],
    rate: u16,
    csi_re_im: [Vec<Vec<Vec<f64>>>; 2],
    #[serde(skip_serializing_if = "Option::is_none")]
    csi_scaled_re_im: Option<[Vec<Vec<Vec<f64>>>; 2]>,
}

/// `[re or im][tx][rx][sc]` nesting of a `[tx][rx][sc]` flat slice.
fn nest<T: Copy>(r: &CsiRecord, flat: &[T], part: impl Fn(T) -> f64) -> Vec<Vec<Vec<f64>>> {
    let nrx = usize::from(r.header.nrx);
    flat.chunks(nrx * NUM_SUBCARRIERS)
        .map(|tx| {
            tx.chunks(NUM_SUBCARRIERS)
                .map(|sc| sc.iter().map(|&c| part(c)).collect())
                .collect()
        })
        .collect()
}

const CSV_HEADER: &str = "index,offset,timestamp_ns,timestamp_low,bfee_count,nrx,ntx,\
rssi_a,rssi_b,rssi_c,noise_dbm,agc,perm_a,perm_b,perm_c,perm_applied,rate,bandwidth_mhz,\
tx,rx,subcarrier,subcarrier_index,re,im,scaled_re,scaled_im";

/// Decodes a log from `input` and writes its CSI records to `out`.
pub fn export<R: Read, W: Write>(
    input: R,
    format: ExportFormat,
    mut out: W,
) -> io::Result<ExportStats> {
    let mut stats = ExportStats::default();
    if format == ExportFormat::Csv {
        writeln!(out, "{CSV_HEADER}")?;
    }
    for event in LogReader::new(input) {
        let r = match event? {
            Event::Csi(r) => r,
            Event::Skipped(s) => {
                match s.reason {
                    SkipReason::NonCsi { .. } => stats.non_csi_records += 1,
                    _ => stats.lost.push(s),
                }
                continue;
            }
        };
        let scaled = r.scaled_csi().ok();
        if scaled.is_none() {
            stats.unscalable += 1;
        }
        match format {
            ExportFormat::Jsonl => write_json(&mut out, stats.records, &r, scaled.as_deref())?,
            ExportFormat::Csv => write_csv(&mut out, stats.records, &r, scaled.as_deref())?,
        }
        stats.records += 1;
    }
    out.flush()?;
    Ok(stats)
}

fn write_json<W: Write>(
    out: &mut W,
    index: u64,
    r: &CsiRecord,
    scaled: Option<&[num_complex::Complex64]>,
) -> io::Result<()> {
    let h = &r.header;
    let rec = JsonRecord {
        index,
        timestamp_low: h.timestamp_low,
        bfee_count: h.bfee_count,
        nrx: h.nrx,
        ntx: h.ntx,
        rssi: h.rssi,
        noise: h.noise_dbm,
        agc: h.agc,
        perm: h.raw_perm().map(|p| p + 1),
        rate: h.rate.0,
        csi_re_im: [
            nest(r, r.csi(), |c| f64::from(c.re)),
            nest(r, r.csi(), |c| f64::from(c.im)),
        ],
        csi_scaled_re_im: scaled.map(|s| [nest(r, s, |c| c.re), nest(r, s, |c| c.im)]),
    };
    serde_json::to_writer(&mut *out, &rec)?;
    out.write_all(b"\n")
}

fn write_csv<W: Write>(
    out: &mut W,
    index: u64,
    r: &CsiRecord,
    scaled: Option<&[num_complex::Complex64]>,
) -> io::Result<()> {
    let h = &r.header;
    let perm = h.raw_perm().map(|p| p + 1);
    let applied = matches!(r.perm, super::record::Perm::Applied(_));
    let prefix = format!(
        "{index},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{applied},{},{}",
        r.offset,
        r.timestamp.as_nanos(),
        h.timestamp_low,
        h.bfee_count,
        h.nrx,
        h.ntx,
        h.rssi[0],
        h.rssi[1],
        h.rssi[2],
        h.noise_dbm,
        h.agc,
        perm[0],
        perm[1],
        perm[2],
        h.rate.0,
        h.rate.bandwidth().mhz(),
    );
    let indices = h.rate.bandwidth().subcarrier_indices();
    let nrx = usize::from(h.nrx);
    for (i, c) in r.csi().iter().enumerate() {
        let (sc, rx, tx) = (
            i % NUM_SUBCARRIERS,
            (i / NUM_SUBCARRIERS) % nrx,
            i / (NUM_SUBCARRIERS * nrx),
        );
        write!(
            out,
            "{prefix},{tx},{rx},{sc},{},{},{}",
            indices[sc], c.re, c.im
        )?;
        match scaled.and_then(|s| s.get(i)) {
            Some(s) => writeln!(out, ",{},{}", s.re, s.im)?,
            None => writeln!(out, ",,")?,
        }
    }
    Ok(())
}
