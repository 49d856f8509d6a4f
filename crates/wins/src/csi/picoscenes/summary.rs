//! What a PicoScenes file holds, as `wins csi info` prints it.

use std::collections::BTreeMap;

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
        let add = |map: &mut BTreeMap<String, u64>, key: String| *map.entry(key).or_default() += 1;
        for f in &capture.frames {
            for (name, version) in &f.segments {
                add(&mut s.segments, format!("{name} v{version}"));
            }
            if let Some(b) = &f.rxs_basic {
                add(&mut s.cards, format!("{:#06x}", b.device_type));
            }
            if let Some(mac) = f.transmitter() {
                let parts: Vec<String> = mac.iter().map(|b| format!("{b:02x}")).collect();
                add(&mut s.transmitters, parts.join(":"));
            }
            if let Some(c) = &f.csi {
                s.with_csi += 1;
                add(
                    &mut s.shapes,
                    format!("{}x{}x{}", c.num_rx, c.num_sts, c.num_tone),
                );
                let mhz = c.carrier_freq_hz as f64 / 1e6;
                add(
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
        let list = |m: &BTreeMap<String, u64>| {
            let items: Vec<String> = m.iter().map(|(k, v)| format!("{k}: {v}")).collect();
            if items.is_empty() {
                "-".to_string()
            } else {
                items.join(", ")
            }
        };
        writeln!(f, "{:<12}PicoScenes", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        writeln!(
            f,
            "{:<12}{} ({} with CSI)",
            "frames", self.frames, self.with_csi
        )?;
        writeln!(f, "{:<12}{}", "segments", list(&self.segments))?;
        writeln!(f, "{:<12}{}", "card", list(&self.cards))?;
        writeln!(
            f,
            "{:<12}{} (rx x streams x tones)",
            "shape",
            list(&self.shapes)
        )?;
        writeln!(f, "{:<12}{}", "channel", list(&self.channels))?;
        writeln!(f, "{:<12}{}", "transmitter", list(&self.transmitters))?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}
