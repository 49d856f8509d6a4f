//! What a PicoScenes file holds, as `wins csi info` prints it.

use std::collections::BTreeMap;

use crate::csi::report::{self, count, counts};

use super::PicoCapture;

/// A PicoScenes file's summary.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PicoSummary {
    /// Bytes in the file.
    pub bytes: u64,
    /// Frames.
    pub frames: u64,
    /// Frames with CSI.
    pub with_csi: u64,
    /// Segments per name and version (`"CSI v4"`).
    pub segments: BTreeMap<String, u64>,
    /// Frames with CSI per shape, `"rx x streams x tones"`.
    pub shapes: BTreeMap<String, u64>,
    /// Frames with CSI per carrier and width (`"2412 MHz, 20 MHz wide"`).
    pub channels: BTreeMap<String, u64>,
    /// Frames per card (`deviceType`, hex).
    pub cards: BTreeMap<String, u64>,
    /// Frames per transmitter (the MPDU's addr2).
    pub transmitters: BTreeMap<String, u64>,
    /// Where the reading stopped before the end, and why.
    pub tail: Option<String>,
}

impl PicoSummary {
    /// The summary of `capture`.
    pub fn of(capture: &PicoCapture) -> Self {
        let mut s = Self {
            bytes: capture.bytes,
            frames: capture.frames.len() as u64,
            tail: capture.lost(),
            ..Self::default()
        };
        for f in &capture.frames {
            for (name, version) in &f.segments {
                count(&mut s.segments, format!("{name} v{version}"));
            }
            if let Some(b) = &f.rxs_basic {
                count(&mut s.cards, format!("{:#06x}", b.device_type));
            }
            if let Some(mac) = f.transmitter() {
                count(&mut s.transmitters, report::mac(&mac));
            }
            if let Some(c) = &f.csi {
                s.with_csi += 1;
                count(
                    &mut s.shapes,
                    format!("{}x{}x{}", c.num_rx, c.num_sts, c.num_tone),
                );
                let mhz = c.carrier_freq_hz as f64 / 1e6;
                count(
                    &mut s.channels,
                    format!("{mhz} MHz, {} MHz wide", c.cbw_mhz),
                );
            }
        }
        s
    }
}

impl std::fmt::Display for PicoSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{:<12}PicoScenes", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        writeln!(
            f,
            "{:<12}{} ({} with CSI)",
            "frames", self.frames, self.with_csi
        )?;
        writeln!(f, "{:<12}{}", "segments", counts(&self.segments))?;
        writeln!(f, "{:<12}{}", "card", counts(&self.cards))?;
        writeln!(
            f,
            "{:<12}{} (rx x streams x tones)",
            "shape",
            counts(&self.shapes)
        )?;
        writeln!(f, "{:<12}{}", "channel", counts(&self.channels))?;
        writeln!(f, "{:<12}{}", "transmitter", counts(&self.transmitters))?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}
