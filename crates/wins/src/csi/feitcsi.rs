//! FeitCSI files (Intel AX200/AX210): records of the 272-byte Intel CSI header
//! ([`IntelCsiHeader`]) and the CSI, as FeitCSI documents them ("CSI format"). The CSI: `int16`
//! real then imaginary per value, receive chain, then transmit stream, then subcarrier (fastest).
//! The carrier frequency and the subcarrier indices are not in the file.
//!
//! Every byte is in a record or in the reported tail: a record whose CSI size does not match its
//! shape, or that the end of the file cuts, ends the reading there. Notes on the format and on
//! where the public readers disagree: `../shared/data/feitcsi/README.md`.

use std::path::Path;

use num_complex::Complex;

use super::iwlmvm::{IWL_HEADER_LEN, IntelCsiHeader, csi_values};
use super::report::{count, counts, lost, mac, read_whole};

/// Bytes of a record's header.
pub const FEIT_HEADER_LEN: usize = IWL_HEADER_LEN;

/// One FeitCSI record.
#[derive(Clone, Debug, PartialEq)]
pub struct FeitRecord {
    /// Byte offset of its header.
    pub offset: u64,
    /// Its header.
    pub header: IntelCsiHeader,
    /// The CSI, receive chain, transmit stream, subcarrier (fastest).
    pub csi: Vec<Complex<i16>>,
}

impl FeitRecord {
    /// The value of chain `rx`, stream `tx`, subcarrier `sc`.
    pub fn csi_at(&self, rx: usize, tx: usize, sc: usize) -> Option<Complex<i16>> {
        self.header.csi_at(&self.csi, rx, tx, sc)
    }
}

/// A whole FeitCSI file read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeitCapture {
    /// The records, in file order.
    pub records: Vec<FeitRecord>,
    /// Where the reading stopped before the end, the bytes left, and why.
    pub tail: Option<super::report::Tail>,
    /// Bytes in the file.
    pub bytes: u64,
}

impl FeitCapture {
    /// What was not read at the end of the file, in words (`None`: all of it was read).
    pub fn lost(&self) -> Option<String> {
        lost(self.tail.as_ref())
    }
}

/// Reads the FeitCSI file at `path` (a regular file).
pub fn read_feitcsi(path: &Path) -> std::io::Result<FeitCapture> {
    Ok(parse_feitcsi(&read_whole(path)?))
}

/// [`read_feitcsi`] of a file held in memory.
pub fn parse_feitcsi(bytes: &[u8]) -> FeitCapture {
    let mut capture = FeitCapture {
        bytes: bytes.len() as u64,
        ..FeitCapture::default()
    };
    let mut at = 0usize;
    while at < bytes.len() {
        match record(&bytes[at..], at as u64) {
            Ok((r, len)) => {
                capture.records.push(r);
                at += len;
            }
            Err(why) => {
                capture.tail = Some((at as u64, (bytes.len() - at) as u64, why));
                break;
            }
        }
    }
    capture
}

/// The one record a datagram of FeitCSI's UDP stream holds (`feitcsi --udp-socket` sends each
/// record as the file would hold it, in a datagram of its own), or why the datagram is not one.
pub fn parse_datagram(bytes: &[u8]) -> Result<FeitRecord, String> {
    let (r, len) = record(bytes, 0)?;
    if len != bytes.len() {
        return Err(format!(
            "a record of {len} bytes in a datagram of {}",
            bytes.len()
        ));
    }
    Ok(r)
}

/// The record at the start of `rest` and its length, or why there is none.
fn record(rest: &[u8], offset: u64) -> Result<(FeitRecord, usize), String> {
    let header = IntelCsiHeader::parse(rest)
        .map_err(|why| why.replace("not an Intel CSI header", "not a FeitCSI header"))?;
    let values = header.values();
    if header.csi_size as usize != values * 4 {
        return Err(format!(
            "a CSI size of {} bytes, where {} × {} × {} values take {}",
            header.csi_size,
            header.num_rx,
            header.num_tx,
            header.num_subcarriers,
            values * 4
        ));
    }
    let end = FEIT_HEADER_LEN + values * 4;
    let data = rest
        .get(FEIT_HEADER_LEN..end)
        .ok_or_else(|| format!("a record cut by the end of the file ({} bytes)", rest.len()))?;
    let record = FeitRecord {
        offset,
        header,
        csi: csi_values(data),
    };
    Ok((record, end))
}

/// Appends `r` as FeitCSI writes it: its header ([`IntelCsiHeader::encode`], the CSI size set to
/// the values'), then each value as `int16` real and imaginary, little-endian.
pub fn encode_record(r: &FeitRecord, out: &mut Vec<u8>) {
    let header = IntelCsiHeader {
        csi_size: (r.csi.len() * 4) as u32,
        ..r.header.clone()
    };
    out.extend(header.encode());
    for v in &r.csi {
        out.extend(v.re.to_le_bytes());
        out.extend(v.im.to_le_bytes());
    }
}

/// Whether `head`, a file's first bytes, starts with a FeitCSI record header whose CSI size
/// fits its shape.
pub fn looks_like_feitcsi(head: &[u8]) -> bool {
    match record(head, 0) {
        Ok(_) => true,
        Err(why) => why.starts_with("a record cut") && head.len() >= FEIT_HEADER_LEN,
    }
}

/// What a FeitCSI file holds, as `wins csi info` prints it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FeitSummary {
    /// Bytes in the file.
    pub bytes: u64,
    /// Records.
    pub records: u64,
    /// Records per shape, `"rx x tx x subcarriers"`.
    pub shapes: std::collections::BTreeMap<String, u64>,
    /// Records per format and width (`"HT 20 MHz"`).
    pub formats: std::collections::BTreeMap<String, u64>,
    /// Records per transmitter.
    pub transmitters: std::collections::BTreeMap<String, u64>,
    /// Where the reading stopped before the end, and why.
    pub tail: Option<String>,
}

impl FeitSummary {
    /// The summary of `capture`.
    pub fn of(capture: &FeitCapture) -> Self {
        let mut s = Self {
            bytes: capture.bytes,
            records: capture.records.len() as u64,
            tail: capture.lost(),
            ..Self::default()
        };
        for r in &capture.records {
            let h = &r.header;
            let shape = format!("{}x{}x{}", h.num_rx, h.num_tx, h.num_subcarriers);
            count(&mut s.shapes, shape);
            let format = format!("{} {} MHz", h.format().name(), h.width_mhz());
            count(&mut s.formats, format);
            count(&mut s.transmitters, mac(&h.source_mac));
        }
        s
    }
}

impl std::fmt::Display for FeitSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{:<12}FeitCSI (Intel AX200/AX210)", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        writeln!(f, "{:<12}{}", "records", self.records)?;
        writeln!(
            f,
            "{:<12}{} (rx x tx x subcarriers)",
            "shape",
            counts(&self.shapes)
        )?;
        writeln!(f, "{:<12}{}", "frames", counts(&self.formats))?;
        writeln!(f, "{:<12}{}", "transmitter", counts(&self.transmitters))?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}

/// A two-chain HT20 record of 56 subcarriers, its clock `mu_clock` (tests).
#[cfg(test)]
pub(crate) fn test_record(mu_clock: u32) -> FeitRecord {
    FeitRecord {
        offset: 0,
        header: IntelCsiHeader {
            csi_size: 0,
            ftm_clock: 7 + mu_clock,
            num_rx: 2,
            num_tx: 1,
            num_subcarriers: 56,
            rssi: [40, 42],
            source_mac: [2, 0, 0, 0, 0, 1],
            mu_clock,
            rate_flags: 0xc200,
        },
        csi: (0..112)
            .map(|i| Complex::new(i as i16 * 97 - 5000, 3000 - i as i16 * 41))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_records_read_back_equal() {
        let records: Vec<FeitRecord> = (0..2u32)
            .map(|k| test_record(1_000_000 + k * 20_000))
            .collect();
        let mut bytes = Vec::new();
        for r in &records {
            encode_record(r, &mut bytes);
        }
        let read = parse_feitcsi(&bytes);
        assert_eq!(read.lost(), None);
        assert_eq!(read.records.len(), 2);
        for (a, b) in read.records.iter().zip(&records) {
            assert_eq!(a.csi, b.csi);
            assert_eq!(a.header.csi_size, 112 * 4);
            assert_eq!(
                IntelCsiHeader {
                    csi_size: 0,
                    ..a.header.clone()
                },
                b.header
            );
        }
    }

    /// A datagram is one whole record: one cut short, or with bytes after its record, is not.
    #[test]
    fn a_datagram_holds_exactly_one_record() {
        let mut bytes = Vec::new();
        encode_record(&test_record(5), &mut bytes);
        let r = parse_datagram(&bytes).unwrap();
        assert_eq!((r.header.mu_clock, r.csi.len()), (5, 112));
        let cut = parse_datagram(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(cut.contains("cut"), "{cut}");
        let mut longer = bytes.clone();
        longer.push(0);
        let extra = parse_datagram(&longer).unwrap_err();
        assert!(extra.contains("in a datagram of"), "{extra}");
        assert!(parse_datagram(b"stop").is_err());
    }
}
