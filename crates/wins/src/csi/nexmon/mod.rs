//! Nexmon (`nexmon_csi`) captures: a pcap of UDP packets to port 5500, one per receive core and
//! spatial stream of each received frame, each an 18-byte header and the CSI as 32-bit words.
//!
//! Both header magics are read: the old `u32` 0x11111111, and the newer `u16` 0x1111 followed by
//! the frame's RSSI and frame-control byte. The core and stream are taken from `csiconf` as the
//! BCM4366c0 encodes them (`(csiconf >> 8) & 3`, `(csiconf >> 11) & 3`; the nexmon_csi README's
//! "lowest three bits" fits the bcm4358 only). The CSI words decode in the chip's floating point
//! ([`unpack`]); [`frames`] groups the packets of one received frame. Every byte of a capture is
//! in a packet, in a counted non-CSI record, or in the reported tail ([`pcap::PcapTail`]);
//! nothing panics on damaged input. Format notes and references: `../shared/data/nexmon/README.md`.

pub mod frames;
pub mod pcap;
mod summary;
pub mod unpack;
pub mod write;

pub use summary::NexmonSummary;

use std::path::Path;

use num_complex::Complex;

use self::pcap::{PcapError, PcapTail, PcapWalk};
use crate::csi::MacAddress;

/// Nexmon's UDP destination port.
pub const NEXMON_PORT: u16 = 5500;
/// The old header magic (`u32`).
pub const MAGIC_OLD: u32 = 0x1111_1111;
/// The newer header magic (`u16`, then RSSI and frame control).
pub const MAGIC_NEW: u16 = 0x1111;
/// Bytes of the Nexmon header before the CSI words.
pub const NEXMON_HEADER_LEN: usize = 18;

/// One Nexmon CSI packet: one core and stream of one received frame.
#[derive(Clone, Debug, PartialEq)]
pub struct NexmonPacket {
    /// Index among the capture's CSI packets, from 0.
    pub index: usize,
    /// Byte offset of its pcap record.
    pub offset: u64,
    /// Capture time, seconds.
    pub ts_sec: u32,
    /// Capture time, the sub-second part in µs (ns for a nanosecond pcap).
    pub ts_frac: u32,
    /// Capture time, ns since the epoch (`ts_sec` and `ts_frac` in one).
    pub time_ns: i64,
    /// Bytes captured.
    pub caplen: u32,
    /// Bytes on the wire.
    pub wirelen: u32,
    /// The header's magic (`0x11111111`, or `0x1111` with the newer header).
    pub magic: u32,
    /// The frame's RSSI, dBm (newer header only).
    pub rssi_dbm: Option<i8>,
    /// The frame-control byte (newer header only).
    pub frame_control: Option<u8>,
    /// The transmitter's address.
    pub transmitter: MacAddress,
    /// `seq`: the 802.11 sequence number << 4 | fragment.
    pub seq: u16,
    /// The raw `csiconf` (core, stream, …).
    pub csiconf: u16,
    /// The raw `chanspec` (channel, band, bandwidth).
    pub chanspec: u16,
    /// The chip (0x006a: BCM4366c0).
    pub chip: u16,
    /// The CSI words, one per FFT bin.
    pub words: Vec<u32>,
}

impl NexmonPacket {
    /// The 802.11 sequence number.
    pub fn seq_num(&self) -> u16 {
        self.seq >> 4
    }

    /// The fragment number.
    pub fn fragment(&self) -> u16 {
        self.seq & 0xf
    }

    /// The receive core (BCM4366c0 encoding).
    pub fn core(&self) -> u8 {
        ((self.csiconf >> 8) & 3) as u8
    }

    /// The spatial stream (BCM4366c0 encoding).
    pub fn spatial_stream(&self) -> u8 {
        ((self.csiconf >> 11) & 3) as u8
    }

    /// The channel number.
    pub fn channel(&self) -> u8 {
        (self.chanspec & 0xff) as u8
    }

    /// Bandwidth, MHz, from the number of CSI words (64 per 20 MHz).
    pub fn bandwidth_mhz(&self) -> u32 {
        (self.words.len() as u32 / 64) * 20
    }

    /// The CSI autoscaled as csiread and the muTrack MATLAB decode it, and the shift applied
    /// ([`unpack::autoscaled`]), in FFT-bin order (bin k is subcarrier k below half the bins,
    /// k − bins above).
    pub fn csi_autoscaled(&self) -> (Vec<Complex<i64>>, i32) {
        unpack::autoscaled(&self.words)
    }

    /// The exact CSI ([`unpack::exact`]), FFT-bin order.
    pub fn csi_exact(&self) -> Vec<Complex<f64>> {
        unpack::exact(&self.words)
    }
}

/// A whole Nexmon capture read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NexmonCapture {
    /// The CSI packets, in file order.
    pub packets: Vec<NexmonPacket>,
    /// pcap records that are not Nexmon CSI packets (other traffic, a damaged header).
    pub other_records: u64,
    /// Their bytes, record headers included.
    pub other_bytes: u64,
    /// What ended the file early, if anything.
    pub tail: Option<PcapTail>,
    /// Bytes in the capture.
    pub bytes: u64,
}

impl NexmonCapture {
    /// The bytes its parts account for: the global header, the CSI packets' records, the other
    /// records and the tail; equal to [`NexmonCapture::bytes`] for every capture read.
    pub fn bytes_accounted(&self) -> u64 {
        let packets: u64 = self
            .packets
            .iter()
            .map(|p| pcap::RECORD_HEADER_LEN as u64 + u64::from(p.caplen))
            .sum();
        let tail = match &self.tail {
            Some(PcapTail::Cut { len, .. } | PcapTail::Oversized { len, .. }) => *len,
            None => 0,
        };
        pcap::GLOBAL_HEADER_LEN as u64 + packets + self.other_bytes + tail
    }
}

/// Why a capture cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum NexmonError {
    /// The file cannot be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not a pcap capture of Ethernet frames.
    #[error("{path}: {source}")]
    Pcap {
        /// The file.
        path: String,
        /// Why.
        source: PcapError,
    },
}

/// Reads the Nexmon capture at `path` (a regular file).
pub fn read_nexmon(path: &Path) -> Result<NexmonCapture, NexmonError> {
    let io = |source| NexmonError::Io {
        path: path.display().to_string(),
        source,
    };
    let mut file = crate::io_safety::open_regular(path).map_err(io)?;
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut file, &mut bytes).map_err(io)?;
    parse_nexmon(&bytes).map_err(|source| NexmonError::Pcap {
        path: path.display().to_string(),
        source,
    })
}

/// [`read_nexmon`] of a capture held in memory.
pub fn parse_nexmon(bytes: &[u8]) -> Result<NexmonCapture, PcapError> {
    let mut walk = PcapWalk::new(bytes)?;
    let frac_ns = if walk.header().nanoseconds { 1 } else { 1000 };
    let mut capture = NexmonCapture {
        bytes: bytes.len() as u64,
        ..NexmonCapture::default()
    };
    for record in walk.by_ref() {
        match packet(record.data) {
            Some(p) => capture.packets.push(NexmonPacket {
                index: capture.packets.len(),
                offset: record.offset,
                ts_sec: record.ts_sec,
                ts_frac: record.ts_frac,
                time_ns: i64::from(record.ts_sec) * 1_000_000_000
                    + i64::from(record.ts_frac) * frac_ns,
                caplen: record.caplen,
                wirelen: record.wirelen,
                ..p
            }),
            None => {
                capture.other_records += 1;
                capture.other_bytes += (pcap::RECORD_HEADER_LEN + record.data.len()) as u64;
            }
        }
    }
    capture.tail = walk.tail;
    Ok(capture)
}

/// The Nexmon packet in an Ethernet frame, `None` when it is not one (other traffic, a frame
/// too short for its headers).
fn packet(frame: &[u8]) -> Option<NexmonPacket> {
    const ETHERNET: usize = 14;
    let ethertype = u16::from_be_bytes([*frame.get(12)?, *frame.get(13)?]);
    if ethertype != 0x0800 {
        return None;
    }
    let ip = frame.get(ETHERNET..)?;
    let ihl = usize::from(ip.first()? & 0x0f) * 4;
    if ihl < 20 || *ip.get(9)? != 17 {
        return None;
    }
    let udp = ip.get(ihl..)?;
    let port = u16::from_be_bytes([*udp.get(2)?, *udp.get(3)?]);
    let udp_len = usize::from(u16::from_be_bytes([*udp.get(4)?, *udp.get(5)?]));
    if port != NEXMON_PORT || udp_len < 8 {
        return None;
    }
    parse_payload(udp.get(8..udp_len.min(udp.len()))?)
}

/// The Nexmon packet a UDP payload holds (as nexmon_csi sends it to port 5500), `None` when it
/// is not one (another magic, a header cut short, CSI not in whole words). Its capture fields
/// (index, offset, times, lengths) are zero.
pub fn parse_payload(payload: &[u8]) -> Option<NexmonPacket> {
    let h = payload.get(..NEXMON_HEADER_LEN)?;
    let le16 = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]);
    let magic32 = u32::from_le_bytes([h[0], h[1], h[2], h[3]]);
    let (magic, rssi_dbm, frame_control) = if magic32 == MAGIC_OLD {
        (MAGIC_OLD, None, None)
    } else if le16(0) == MAGIC_NEW {
        (
            u32::from(MAGIC_NEW),
            Some(i8::from_le_bytes([h[2]])),
            Some(h[3]),
        )
    } else {
        return None;
    };
    let csi = payload.get(NEXMON_HEADER_LEN..)?;
    if csi.len() % 4 != 0 {
        return None;
    }
    let words = csi
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect();
    Some(NexmonPacket {
        index: 0,
        offset: 0,
        ts_sec: 0,
        ts_frac: 0,
        time_ns: 0,
        caplen: 0,
        wirelen: 0,
        magic,
        rssi_dbm,
        frame_control,
        transmitter: [h[4], h[5], h[6], h[7], h[8], h[9]],
        seq: le16(10),
        csiconf: le16(12),
        chanspec: le16(14),
        chip: le16(16),
        words,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A capture of one Ethernet/IPv4/UDP frame to `port` with `payload`, in the byte order and
    /// time unit asked.
    fn capture(little_endian: bool, nanoseconds: bool, port: u16, payload: &[u8]) -> Vec<u8> {
        let u32b = |v: u32| {
            if little_endian {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        let magic: u32 = if nanoseconds {
            0xa1b2_3c4d
        } else {
            0xa1b2_c3d4
        };
        let mut out = Vec::new();
        out.extend(u32b(magic));
        out.extend([0u8; 16]);
        out.extend(u32b(1));
        let mut frame = vec![0u8; 12];
        frame.extend([0x08, 0x00]);
        let mut ip = vec![0x45, 0, 0, 0, 0, 0, 0, 0, 64, 17];
        ip.extend([0u8; 10]);
        frame.extend(ip);
        let udp_len = (8 + payload.len()) as u16;
        frame.extend([0x15, 0x7c]);
        frame.extend(port.to_be_bytes());
        frame.extend(udp_len.to_be_bytes());
        frame.extend([0, 0]);
        frame.extend(payload);
        for v in [7, 250, frame.len() as u32, frame.len() as u32] {
            out.extend(u32b(v));
        }
        out.extend(frame);
        out
    }

    /// A Nexmon payload with the newer header: RSSI −60 dBm, core 3, two CSI words.
    fn newer_payload() -> Vec<u8> {
        let mut p = vec![0x11, 0x11, (-60i8).to_le_bytes()[0], 0x08];
        p.extend([1, 2, 3, 4, 5, 6]);
        p.extend((100u16 << 4 | 1).to_le_bytes());
        p.extend(0x0300u16.to_le_bytes());
        p.extend(0xd09du16.to_le_bytes());
        p.extend(0x006au16.to_le_bytes());
        p.extend(0x2004_0041u32.to_le_bytes());
        p.extend(0u32.to_le_bytes());
        p
    }

    #[test]
    fn both_byte_orders_both_time_units_and_the_newer_header_are_read() {
        for (le, ns) in [(true, false), (false, false), (true, true), (false, true)] {
            let bytes = capture(le, ns, NEXMON_PORT, &newer_payload());
            let c = parse_nexmon(&bytes).expect("a capture");
            assert_eq!(c.packets.len(), 1, "le {le} ns {ns}");
            let p = &c.packets[0];
            assert_eq!((p.ts_sec, p.ts_frac), (7, 250));
            assert_eq!(
                (p.magic, p.rssi_dbm, p.frame_control),
                (0x1111, Some(-60), Some(8))
            );
            assert_eq!((p.seq_num(), p.fragment(), p.core()), (100, 1, 3));
            assert_eq!(
                (p.channel(), p.chip, p.transmitter),
                (157, 0x6a, [1, 2, 3, 4, 5, 6])
            );
            assert_eq!(p.words, vec![0x2004_0041, 0]);
        }
    }

    #[test]
    fn other_traffic_is_counted_not_read() {
        let bytes = capture(true, false, 53, &newer_payload());
        let c = parse_nexmon(&bytes).expect("a capture");
        assert_eq!((c.packets.len(), c.other_records), (0, 1));
        assert_eq!(c.other_bytes + 24, bytes.len() as u64);
        let mut odd = newer_payload();
        odd.push(0);
        let c = parse_nexmon(&capture(true, false, NEXMON_PORT, &odd)).expect("a capture");
        assert_eq!(c.other_records, 1, "a CSI part that is not whole words");
        let not = parse_nexmon(&[0u8; 30]).expect_err("no magic");
        assert!(not.to_string().contains("not a pcap"), "{not}");
    }
}
