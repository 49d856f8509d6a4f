//! What a Nexmon capture holds, as `wins csi info` prints it: packets and frames (by the cores
//! they have), transmitters, channels, bandwidths, chips, header versions, duration, and what
//! was not a CSI packet.

use std::collections::BTreeMap;
use std::fmt;

use serde::Serialize;

use super::NexmonCapture;
use super::frames::frames;

/// The summary of a capture ([`NexmonSummary::of`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct NexmonSummary {
    /// Bytes in the capture.
    pub bytes: u64,
    /// Nexmon CSI packets.
    pub packets: u64,
    /// Frames the packets make, by the cores each has (`"0,1,3"`).
    pub frames_by_cores: BTreeMap<String, u64>,
    /// Packets per transmitter.
    pub transmitters: BTreeMap<String, u64>,
    /// Packets per channel.
    pub channels: BTreeMap<u8, u64>,
    /// Packets per bandwidth, MHz.
    pub bandwidths_mhz: BTreeMap<u32, u64>,
    /// Packets per chip (`"0x006a"`).
    pub chips: BTreeMap<String, u64>,
    /// Packets with the old (`u32` magic) and the newer header.
    pub headers_old_new: (u64, u64),
    /// From the first packet to the last, s.
    pub duration_s: Option<f64>,
    /// pcap records that are not Nexmon CSI packets, and their bytes.
    pub other_records: (u64, u64),
    /// What ended the file early, in words.
    pub tail: Option<String>,
}

impl NexmonSummary {
    /// The summary of `capture`.
    pub fn of(capture: &NexmonCapture) -> Self {
        let mut s = Self {
            bytes: capture.bytes,
            packets: capture.packets.len() as u64,
            other_records: (capture.other_records, capture.other_bytes),
            tail: capture.tail.as_ref().map(ToString::to_string),
            ..Self::default()
        };
        for f in frames(&capture.packets) {
            let cores: Vec<String> = f.cores().iter().map(u8::to_string).collect();
            *s.frames_by_cores.entry(cores.join(",")).or_default() += 1;
        }
        for p in &capture.packets {
            let mac: Vec<String> = p.transmitter.iter().map(|b| format!("{b:02x}")).collect();
            *s.transmitters.entry(mac.join(":")).or_default() += 1;
            *s.channels.entry(p.channel()).or_default() += 1;
            *s.bandwidths_mhz.entry(p.bandwidth_mhz()).or_default() += 1;
            *s.chips.entry(format!("{:#06x}", p.chip)).or_default() += 1;
            if p.rssi_dbm.is_some() {
                s.headers_old_new.1 += 1;
            } else {
                s.headers_old_new.0 += 1;
            }
        }
        let time = |p: &super::NexmonPacket| f64::from(p.ts_sec) + f64::from(p.ts_frac) * 1e-6;
        if let (Some(first), Some(last)) = (capture.packets.first(), capture.packets.last()) {
            s.duration_s = Some(time(last) - time(first));
        }
        s
    }
}

/// `key value, key value` of a map.
fn list<K: fmt::Display>(map: &BTreeMap<K, u64>) -> String {
    if map.is_empty() {
        return "-".into();
    }
    map.iter()
        .map(|(k, v)| format!("{k}: {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl fmt::Display for NexmonSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{:<12}Nexmon CSI in a pcap capture", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        let frames: u64 = self.frames_by_cores.values().sum();
        writeln!(
            f,
            "{:<12}{} packets, {frames} frames",
            "records", self.packets
        )?;
        writeln!(f, "{:<12}{}", "cores", list(&self.frames_by_cores))?;
        writeln!(f, "{:<12}{}", "transmitter", list(&self.transmitters))?;
        writeln!(f, "{:<12}{}", "channel", list(&self.channels))?;
        writeln!(f, "{:<12}{}", "bandwidth", list(&self.bandwidths_mhz))?;
        writeln!(f, "{:<12}{}", "chip", list(&self.chips))?;
        let (old, new) = self.headers_old_new;
        writeln!(
            f,
            "{:<12}{old} old (u32 magic), {new} newer (with RSSI)",
            "header"
        )?;
        match self.duration_s {
            Some(d) => writeln!(f, "{:<12}{d:.3} s", "duration")?,
            None => writeln!(f, "{:<12}-", "duration")?,
        }
        let (n, bytes) = self.other_records;
        writeln!(
            f,
            "{:<12}{n} records ({bytes} bytes) not Nexmon CSI",
            "other"
        )?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}
