//! Atheros CSI Tool logs (ath9k, xieyaxiongfly/Atheros-CSI-Tool): records of a 27-byte header,
//! the CSI and the received frame, as the tool's `read_log_file.m` and `read_csi.c` read them.
//!
//! Record: `u16` block length (the bytes after it), `u64` timestamp (µs), `u16` CSI length,
//! `u16` channel (MHz), `u8` error info, noise floor, rate, bandwidth (0: 20 MHz, 1: 40 MHz),
//! tones, receive chains, transmit chains, RSSI and the three chains' RSSI, `u16` payload length;
//! then the CSI and the payload. Multi-byte fields are in the logging host's byte order; later
//! versions of the tool write one byte first (0xff: big-endian). The byte order, and whether that
//! byte is there, is told from the first record (each candidate must give a record whose lengths
//! agree) or forced. The CSI: 10-bit two's-complement numbers taken least significant bit first;
//! per tone, per transmit chain, per receive chain, imaginary then real.
//!
//! Every byte is in the leading byte, a record or the reported tail: a record whose lengths do
//! not agree, or that the end of the file cuts, ends the reading there. Notes on the format and on
//! where the public readers disagree: `../shared/data/atheros/README.md`.

mod summary;
pub mod write;

use std::path::Path;

use num_complex::Complex;

pub use summary::AtherosSummary;
pub use write::encode_record;

/// Bytes of a record's header, the block length included.
pub const ATHEROS_HEADER_LEN: usize = 27;
/// Bits of each real or imaginary part.
const BITS_PER_VALUE: usize = 10;
/// Most receive or transmit chains a record may claim (the AR9300 family has 3).
const MAX_CHAINS: u8 = 3;
/// Most tones a record may claim (114 in a 40 MHz channel).
const MAX_TONES: u8 = 114;

/// The byte order of a log's multi-byte fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ByteOrder {
    /// Little-endian (an x86 or ARM host).
    Little,
    /// Big-endian (a MIPS router).
    Big,
}

/// One Atheros CSI Tool record.
#[derive(Clone, Debug, PartialEq)]
pub struct AtherosRecord {
    /// Byte offset of its block length.
    pub offset: u64,
    /// The card's timestamp, µs.
    pub timestamp_us: u64,
    /// Channel centre, MHz.
    pub channel_mhz: u16,
    /// Error information (0: none).
    pub err_info: u8,
    /// Noise floor (the tool leaves it 0).
    pub noise_floor: u8,
    /// The rate code.
    pub rate: u8,
    /// 0: 20 MHz, 1: 40 MHz.
    pub bandwidth: u8,
    /// Tones.
    pub num_tones: u8,
    /// Receive chains.
    pub nr: u8,
    /// Transmit chains.
    pub nc: u8,
    /// Combined RSSI, dB above the noise floor.
    pub rssi: u8,
    /// Per receive chain RSSI.
    pub rssi_chains: [u8; 3],
    /// Bytes of CSI as the record states them.
    pub csi_len: u16,
    /// The CSI, tone, transmit chain, receive chain (fastest); empty when the record has none.
    pub csi: Vec<Complex<i16>>,
    /// The received 802.11 frame.
    pub payload: Vec<u8>,
}

impl AtherosRecord {
    /// The value of receive chain `rx`, transmit chain `tx`, tone `tone`.
    pub fn csi_at(&self, rx: usize, tx: usize, tone: usize) -> Option<Complex<i16>> {
        let (nr, nc) = (usize::from(self.nr), usize::from(self.nc));
        (rx < nr && tx < nc)
            .then(|| self.csi.get((tone * nc + tx) * nr + rx).copied())
            .flatten()
    }

    /// Bytes the record takes in the file.
    pub fn bytes_in_file(&self) -> usize {
        ATHEROS_HEADER_LEN + usize::from(self.csi_len) + self.payload.len()
    }

    /// Its timestamp, ns (the tool's microseconds; wraps as an `i64` would).
    pub fn clock_ns(&self) -> i64 {
        (self.timestamp_us as i64).wrapping_mul(1000)
    }

    /// The payload's 802.11 sequence number, when the payload holds its sequence control.
    pub fn sequence(&self) -> Option<u16> {
        self.payload
            .get(22..24)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) >> 4)
    }

    /// The payload's transmitter address (802.11 addr2), when the payload holds one.
    pub fn transmitter(&self) -> Option<[u8; 6]> {
        self.payload.get(10..16)?.try_into().ok()
    }
}

/// A whole Atheros CSI Tool log read.
#[derive(Clone, Debug, PartialEq)]
pub struct AtherosCapture {
    /// The byte order of its fields.
    pub order: ByteOrder,
    /// Whether a byte-order byte comes first.
    pub leading_byte: bool,
    /// The records, in file order.
    pub records: Vec<AtherosRecord>,
    /// Where the reading stopped before the end, the bytes left, and why.
    pub tail: Option<crate::csi::report::Tail>,
    /// Bytes in the file.
    pub bytes: u64,
}

impl AtherosCapture {
    /// What was not read at the end of the file, in words (`None`: all of it was read).
    pub fn lost(&self) -> Option<String> {
        crate::csi::report::lost(self.tail.as_ref())
    }

    /// Bytes in the leading byte, the records and the tail: the file's size when every byte is
    /// accounted for.
    pub fn bytes_accounted(&self) -> u64 {
        let records: usize = self.records.iter().map(AtherosRecord::bytes_in_file).sum();
        u64::from(self.leading_byte) + records as u64 + self.tail.as_ref().map_or(0, |t| t.1)
    }
}

/// Reads the Atheros CSI Tool log at `path` (a regular file); `order` forces the byte order
/// (whether a byte-order byte comes first is still told from the first record).
pub fn read_atheros(path: &Path, order: Option<ByteOrder>) -> std::io::Result<AtherosCapture> {
    Ok(parse_atheros(&crate::csi::report::read_whole(path)?, order))
}

/// The layouts a log may start with: (leading byte, byte order).
fn candidates(order: Option<ByteOrder>) -> Vec<(bool, ByteOrder)> {
    let orders = match order {
        Some(o) => vec![o],
        None => vec![ByteOrder::Little, ByteOrder::Big],
    };
    let mut out: Vec<_> = orders.iter().map(|&o| (false, o)).collect();
    out.extend(orders.iter().map(|&o| (true, o)));
    out
}

/// [`read_atheros`] of a log held in memory.
pub fn parse_atheros(bytes: &[u8], order: Option<ByteOrder>) -> AtherosCapture {
    let all = candidates(order);
    let layout = all
        .iter()
        .copied()
        .find(|&(lead, o)| record(&bytes[usize::from(lead).min(bytes.len())..], 0, o).is_ok())
        .unwrap_or(all[0]);
    let (lead, order) = layout;
    // An empty file has no byte-order byte, whatever the layout.
    let mut at = usize::from(lead && !bytes.is_empty());
    let mut capture = AtherosCapture {
        order,
        leading_byte: at == 1,
        records: Vec::new(),
        tail: None,
        bytes: bytes.len() as u64,
    };
    while at < bytes.len() {
        match record(&bytes[at..], at as u64, order) {
            Ok(r) => {
                at += r.bytes_in_file();
                capture.records.push(r);
            }
            Err(why) => {
                capture.tail = Some((at as u64, (bytes.len() - at) as u64, why));
                break;
            }
        }
    }
    capture
}

/// Whether `head`, a file's first bytes, starts (after an optional byte-order byte) with an
/// Atheros CSI Tool record whose lengths agree and whose CSI has a shape.
pub fn looks_like_atheros(head: &[u8]) -> bool {
    candidates(None).into_iter().any(|(lead, order)| {
        let rest = &head[usize::from(lead).min(head.len())..];
        match record(rest, 0, order) {
            Ok(r) => !r.csi.is_empty(),
            Err(why) => why.starts_with("a record cut") && header_agrees(rest, order),
        }
    })
}

/// Whether the header at the start of `rest` is whole and its lengths and shape agree.
fn header_agrees(rest: &[u8], order: ByteOrder) -> bool {
    rest.get(..ATHEROS_HEADER_LEN)
        .and_then(|h| Header::of(h, order).ok())
        .is_some_and(|h| h.csi_len > 0)
}

/// A record header's fields.
struct Header {
    block_len: usize,
    timestamp_us: u64,
    csi_len: usize,
    channel_mhz: u16,
    bytes: [u8; 11],
    payload_len: usize,
}

impl Header {
    /// The header `h` (27 bytes), or why its lengths or shape do not agree.
    fn of(h: &[u8], order: ByteOrder) -> Result<Self, String> {
        let int = |at: usize, len: usize| -> u64 {
            let field = &h[at..at + len];
            match order {
                ByteOrder::Little => field.iter().rev().fold(0, |v, &b| v << 8 | u64::from(b)),
                ByteOrder::Big => field.iter().fold(0, |v, &b| v << 8 | u64::from(b)),
            }
        };
        let mut bytes = [0u8; 11];
        bytes.copy_from_slice(&h[14..25]);
        let header = Self {
            block_len: int(0, 2) as usize,
            timestamp_us: int(2, 8),
            csi_len: int(10, 2) as usize,
            channel_mhz: int(12, 2) as u16,
            bytes,
            payload_len: int(25, 2) as usize,
        };
        let (tones, nr, nc) = (bytes[4], bytes[5], bytes[6]);
        if header.block_len != ATHEROS_HEADER_LEN - 2 + header.csi_len + header.payload_len {
            return Err(format!(
                "not an Atheros record: a block of {} bytes, where its header, {} bytes of CSI \
                 and {} of payload take {}",
                header.block_len,
                header.csi_len,
                header.payload_len,
                ATHEROS_HEADER_LEN - 2 + header.csi_len + header.payload_len
            ));
        }
        if header.csi_len > 0 {
            let shape = (1..=MAX_CHAINS).contains(&nr)
                && (1..=MAX_CHAINS).contains(&nc)
                && (1..=MAX_TONES).contains(&tones);
            let bits = usize::from(tones) * usize::from(nr) * usize::from(nc) * 2 * BITS_PER_VALUE;
            if !shape || header.csi_len * 8 < bits {
                return Err(format!(
                    "not an Atheros record: {} bytes of CSI for {nr} receive × {nc} transmit \
                     chains × {tones} tones",
                    header.csi_len
                ));
            }
        }
        Ok(header)
    }
}

/// The record at the start of `rest`, or why there is none.
fn record(rest: &[u8], offset: u64, order: ByteOrder) -> Result<AtherosRecord, String> {
    let h = rest
        .get(..ATHEROS_HEADER_LEN)
        .ok_or_else(|| format!("a header cut by the end of the file ({} bytes)", rest.len()))?;
    let header = Header::of(h, order)?;
    let end = 2 + header.block_len;
    let body = rest
        .get(ATHEROS_HEADER_LEN..end)
        .ok_or_else(|| format!("a record cut by the end of the file ({} bytes)", rest.len()))?;
    let (csi_bytes, payload) = body.split_at(header.csi_len);
    let b = header.bytes;
    let values = if header.csi_len > 0 {
        usize::from(b[4]) * usize::from(b[5]) * usize::from(b[6])
    } else {
        0
    };
    Ok(AtherosRecord {
        offset,
        timestamp_us: header.timestamp_us,
        channel_mhz: header.channel_mhz,
        err_info: b[0],
        noise_floor: b[1],
        rate: b[2],
        bandwidth: b[3],
        num_tones: b[4],
        nr: b[5],
        nc: b[6],
        rssi: b[7],
        rssi_chains: [b[8], b[9], b[10]],
        csi_len: header.csi_len as u16,
        csi: unpack(csi_bytes, values),
        payload: payload.to_vec(),
    })
}

/// `values` complex numbers from the packed CSI `bytes` (each the imaginary part, then the
/// real, 10 bits each, least significant bit first).
fn unpack(bytes: &[u8], values: usize) -> Vec<Complex<i16>> {
    let part = |index: usize| -> i16 {
        let mut v = 0u16;
        for bit in 0..BITS_PER_VALUE {
            let at = index * BITS_PER_VALUE + bit;
            let set = bytes
                .get(at / 8)
                .is_some_and(|byte| byte >> (at % 8) & 1 == 1);
            v |= u16::from(set) << bit;
        }
        // Sign-extend the 10-bit two's complement number.
        ((v << 6) as i16) >> 6
    };
    (0..values)
        .map(|i| {
            let im = part(2 * i);
            Complex::new(part(2 * i + 1), im)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian record of `nr` × `nc` × `tones` whose parts count 0, 1, 2, … (10 bits).
    fn record_bytes(nr: u8, nc: u8, tones: u8, order: ByteOrder) -> Vec<u8> {
        let values = usize::from(nr) * usize::from(nc) * usize::from(tones) * 2;
        let csi_len = (values * BITS_PER_VALUE).div_ceil(8);
        let mut csi = vec![0u8; csi_len];
        for i in 0..values {
            let v = (i as u16 % 1024) as usize;
            for bit in 0..BITS_PER_VALUE {
                if v >> bit & 1 == 1 {
                    let at = i * BITS_PER_VALUE + bit;
                    csi[at / 8] |= 1 << (at % 8);
                }
            }
        }
        let payload = vec![0x88u8; 30];
        let put = |out: &mut Vec<u8>, v: u64, len: usize| {
            let le = v.to_le_bytes();
            match order {
                ByteOrder::Little => out.extend(&le[..len]),
                ByteOrder::Big => out.extend(le[..len].iter().rev()),
            }
        };
        let mut out = Vec::new();
        put(&mut out, (25 + csi_len + payload.len()) as u64, 2);
        put(&mut out, 123_456_789, 8);
        put(&mut out, csi_len as u64, 2);
        put(&mut out, 5180, 2);
        out.extend([0, 0, 0x8f, 0, tones, nr, nc, 40, 30, 31, 32]);
        put(&mut out, payload.len() as u64, 2);
        out.extend(csi);
        out.extend(payload);
        out
    }

    #[test]
    fn values_are_unpacked_imaginary_first_and_sign_extended() {
        let bytes = record_bytes(3, 2, 56, ByteOrder::Little);
        let c = parse_atheros(&bytes, None);
        assert_eq!(c.tail, None);
        let r = &c.records[0];
        assert_eq!(
            (r.timestamp_us, r.channel_mhz, r.csi.len()),
            (123_456_789, 5180, 336)
        );
        // Value 1 (tone 0, tx 0, rx 1) holds parts 2 (imaginary) and 3 (real).
        assert_eq!(r.csi_at(1, 0, 0), Some(Complex::new(3, 2)));
        // Value 3 (tone 0, tx 1, rx 0): parts 6 and 7.
        assert_eq!(r.csi_at(0, 1, 0), Some(Complex::new(7, 6)));
        // Part 513 is −511 as a 10-bit two's complement number (value 256: parts 512, 513).
        assert_eq!(r.csi[256], Complex::new(-511, -512));
        assert_eq!(c.bytes_accounted(), bytes.len() as u64);
    }

    #[test]
    fn either_byte_order_with_or_without_a_leading_byte_reads_the_same() {
        let le = parse_atheros(&record_bytes(2, 1, 56, ByteOrder::Little), None);
        for (lead, order) in [
            (None, ByteOrder::Big),
            (Some(0xffu8), ByteOrder::Big),
            (Some(0x00), ByteOrder::Little),
        ] {
            let mut bytes: Vec<u8> = lead.into_iter().collect();
            bytes.extend(record_bytes(2, 1, 56, order).repeat(2));
            let c = parse_atheros(&bytes, None);
            assert_eq!((c.order, c.leading_byte), (order, lead.is_some()));
            assert_eq!(c.records.len(), 2);
            assert_eq!(c.records[1].csi, le.records[0].csi);
            assert!(looks_like_atheros(&bytes));
            assert_eq!(c.bytes_accounted(), bytes.len() as u64);
        }
    }

    #[test]
    fn a_record_whose_lengths_disagree_ends_the_reading_with_every_byte_accounted_for() {
        let mut bytes = record_bytes(3, 3, 56, ByteOrder::Little).repeat(3);
        let second = bytes.len() / 3;
        bytes[second + 10] ^= 0x01; // the second record's CSI length
        let c = parse_atheros(&bytes, Some(ByteOrder::Little));
        assert_eq!(c.records.len(), 1);
        let tail = c.tail.clone().unwrap();
        assert_eq!(tail.0, second as u64);
        assert!(tail.2.contains("not an Atheros record"), "{}", tail.2);
        assert_eq!(c.bytes_accounted(), bytes.len() as u64);
        assert!(!looks_like_atheros(
            b"\x71\x07hello, world, this is no record at all"
        ));
    }
}
