//! What an Atheros CSI Tool log holds, as `wins csi info` prints it.

use std::collections::BTreeMap;

use crate::csi::report::{self, count, counts};

use super::AtherosCapture;

/// An Atheros CSI Tool log's summary.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct AtherosSummary {
    /// Bytes in the file.
    pub bytes: u64,
    /// The byte order of its fields.
    pub order: super::ByteOrder,
    /// Whether a byte-order byte comes first.
    pub leading_byte: bool,
    /// Records.
    pub records: u64,
    /// Records with CSI.
    pub with_csi: u64,
    /// Records with CSI per shape, `"rx x tx x tones"`.
    pub shapes: BTreeMap<String, u64>,
    /// Records per channel and width (`"2437 MHz, 20 MHz wide"`).
    pub channels: BTreeMap<String, u64>,
    /// Records per transmitter (the payload's addr2).
    pub transmitters: BTreeMap<String, u64>,
    /// Records whose error information is not 0.
    pub with_errors: u64,
    /// The timestamps' span, s.
    pub span_s: f64,
    /// Where the reading stopped before the end, and why.
    pub tail: Option<String>,
}

impl AtherosSummary {
    /// The summary of `capture`.
    pub fn of(capture: &AtherosCapture) -> Self {
        let mut s = Self {
            bytes: capture.bytes,
            order: capture.order,
            leading_byte: capture.leading_byte,
            records: capture.records.len() as u64,
            with_csi: 0,
            shapes: BTreeMap::new(),
            channels: BTreeMap::new(),
            transmitters: BTreeMap::new(),
            with_errors: 0,
            span_s: 0.0,
            tail: capture.lost(),
        };
        for r in &capture.records {
            if !r.csi.is_empty() {
                s.with_csi += 1;
                count(&mut s.shapes, format!("{}x{}x{}", r.nr, r.nc, r.num_tones));
            }
            let width = if r.bandwidth == 1 { 40 } else { 20 };
            count(
                &mut s.channels,
                format!("{} MHz, {width} MHz wide", r.channel_mhz),
            );
            if let Some(mac) = r.transmitter() {
                count(&mut s.transmitters, report::mac(&mac));
            }
            s.with_errors += u64::from(r.err_info != 0);
        }
        let times = capture.records.iter().map(|r| r.timestamp_us);
        if let (Some(lo), Some(hi)) = (times.clone().min(), times.max()) {
            s.span_s = (hi - lo) as f64 * 1e-6;
        }
        s
    }
}

impl std::fmt::Display for AtherosSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let order = match self.order {
            super::ByteOrder::Little => "little-endian",
            super::ByteOrder::Big => "big-endian",
        };
        let lead = if self.leading_byte {
            ", after a byte-order byte"
        } else {
            ""
        };
        writeln!(f, "{:<12}Atheros CSI Tool log ({order}{lead})", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        writeln!(
            f,
            "{:<12}{} ({} with CSI, {} with errors)",
            "records", self.records, self.with_csi, self.with_errors
        )?;
        writeln!(
            f,
            "{:<12}{} (rx x tx x tones)",
            "shape",
            counts(&self.shapes)
        )?;
        writeln!(f, "{:<12}{}", "channel", counts(&self.channels))?;
        writeln!(f, "{:<12}{}", "transmitter", counts(&self.transmitters))?;
        writeln!(f, "{:<12}{:.3} s", "span", self.span_s)?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}
