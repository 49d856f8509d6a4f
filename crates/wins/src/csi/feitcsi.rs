//! FeitCSI files (Intel AX200/AX210): records of a 272-byte header and the CSI, as FeitCSI
//! documents them ("CSI format"). Header, little-endian: the CSI's size @0, the FTM clock @8,
//! receive chains @46, transmit streams @47, subcarriers @52, the two chains' RSSI @60 and @64,
//! the transmitter @68, a microsecond clock @88 (as CSIKit reads it), the rate flags @92. The CSI:
//! `int16` real then imaginary per value, receive chain, then transmit stream, then subcarrier
//! (fastest). The carrier frequency and the subcarrier indices are not in the file.
//!
//! Every byte is in a record or in the reported tail: a record whose CSI size does not match its
//! shape, or that the end of the file cuts, ends the reading there. Notes on the format and on
//! where the public readers disagree: `../shared/data/feitcsi/README.md`.

use std::path::Path;

use num_complex::Complex;

use crate::csi::intel5300::MacAddress;

/// Bytes of a record's header.
pub const FEIT_HEADER_LEN: usize = 272;
/// Most receive chains or transmit streams a record may claim.
const MAX_CHAINS: u8 = 4;
/// Most subcarriers a record may claim (a 320 MHz EHT channel has 3 984 tones).
const MAX_SUBCARRIERS: u32 = 4096;

/// The frame format of bits 8–10 of the rate flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeitFormat {
    /// 802.11b.
    Cck,
    /// 802.11a/g.
    LegacyOfdm,
    /// 802.11n.
    Ht,
    /// 802.11ac.
    Vht,
    /// 802.11ax.
    He,
    /// 802.11be.
    Eht,
    /// Another value.
    Other(u8),
}

impl FeitFormat {
    /// Its name as CSIKit prints it (`"HT"`, `"HE"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::Cck => "CCK",
            Self::LegacyOfdm => "LEGACY_OFDM",
            Self::Ht => "HT",
            Self::Vht => "VHT",
            Self::He => "HE",
            Self::Eht => "EHT",
            Self::Other(_) => "OTHER",
        }
    }
}

/// One FeitCSI record.
#[derive(Clone, Debug, PartialEq)]
pub struct FeitRecord {
    /// Byte offset of its header.
    pub offset: u64,
    /// The FTM clock (3.125 ns ticks, wrapping at 2³²).
    pub ftm_clock: u32,
    /// Receive chains.
    pub num_rx: u8,
    /// Transmit streams.
    pub num_tx: u8,
    /// Subcarriers.
    pub num_subcarriers: u32,
    /// RSSI of chains 1 and 2 (positive numbers, as the file holds them).
    pub rssi: [u32; 2],
    /// The transmitter.
    pub source_mac: MacAddress,
    /// The microsecond clock CSIKit reads @88.
    pub mu_clock: u32,
    /// The raw rate flags.
    pub rate_flags: u32,
    /// The CSI, receive chain, transmit stream, subcarrier (fastest).
    pub csi: Vec<Complex<i16>>,
}

impl FeitRecord {
    /// MCS (bits 0–3).
    pub fn mcs(&self) -> u8 {
        (self.rate_flags & 0xf) as u8
    }

    /// The frame format (bits 8–10).
    pub fn format(&self) -> FeitFormat {
        match (self.rate_flags >> 8) & 7 {
            0 => FeitFormat::Cck,
            1 => FeitFormat::LegacyOfdm,
            2 => FeitFormat::Ht,
            3 => FeitFormat::Vht,
            4 => FeitFormat::He,
            5 => FeitFormat::Eht,
            other => FeitFormat::Other(other as u8),
        }
    }

    /// Channel width, MHz (`20 << n`, n from bits 11–13).
    pub fn width_mhz(&self) -> u32 {
        20 << ((self.rate_flags >> 11) & 7)
    }

    /// Whether antenna A (bit 14) and B (bit 15) received it.
    pub fn antennas(&self) -> (bool, bool) {
        (
            self.rate_flags & (1 << 14) != 0,
            self.rate_flags & (1 << 15) != 0,
        )
    }

    /// LDPC coding (bit 16).
    pub fn ldpc(&self) -> bool {
        self.rate_flags & (1 << 16) != 0
    }

    /// Spatial streams: 2 with bit 17, else 1.
    pub fn spatial_streams(&self) -> u8 {
        if self.rate_flags & (1 << 17) != 0 {
            2
        } else {
            1
        }
    }

    /// Beamformed (bit 19).
    pub fn beamforming(&self) -> bool {
        self.rate_flags & (1 << 19) != 0
    }

    /// The value of chain `rx`, stream `tx`, subcarrier `sc`.
    pub fn csi_at(&self, rx: usize, tx: usize, sc: usize) -> Option<Complex<i16>> {
        let (ntx, nsc) = (usize::from(self.num_tx), self.num_subcarriers as usize);
        (tx < ntx && sc < nsc)
            .then(|| self.csi.get((rx * ntx + tx) * nsc + sc).copied())
            .flatten()
    }
}

/// A whole FeitCSI file read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeitCapture {
    /// The records, in file order.
    pub records: Vec<FeitRecord>,
    /// Where the reading stopped before the end, the bytes left, and why.
    pub tail: Option<(u64, u64, String)>,
    /// Bytes in the file.
    pub bytes: u64,
}

impl FeitCapture {
    /// What was not read at the end of the file, in words (`None`: all of it was read).
    pub fn lost(&self) -> Option<String> {
        self.tail
            .as_ref()
            .map(|(at, len, why)| format!("offset {at}: {len} bytes not read: {why}"))
    }
}

/// Reads the FeitCSI file at `path` (a regular file).
pub fn read_feitcsi(path: &Path) -> std::io::Result<FeitCapture> {
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut crate::io_safety::open_regular(path)?, &mut bytes)?;
    Ok(parse_feitcsi(&bytes))
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

/// The record at the start of `rest` and its length, or why there is none.
fn record(rest: &[u8], offset: u64) -> Result<(FeitRecord, usize), String> {
    let h = rest
        .get(..FEIT_HEADER_LEN)
        .ok_or_else(|| format!("a header cut by the end of the file ({} bytes)", rest.len()))?;
    let u32_at = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
    let (csi_size, num_rx, num_tx, num_subcarriers) = (u32_at(0), h[46], h[47], u32_at(52));
    if !(1..=MAX_CHAINS).contains(&num_rx)
        || !(1..=MAX_CHAINS).contains(&num_tx)
        || !(1..=MAX_SUBCARRIERS).contains(&num_subcarriers)
    {
        return Err(format!(
            "not a FeitCSI header: {num_rx} receive chains, {num_tx} streams, {num_subcarriers} \
             subcarriers"
        ));
    }
    let values = usize::from(num_rx) * usize::from(num_tx) * num_subcarriers as usize;
    if csi_size as usize != values * 4 {
        return Err(format!(
            "a CSI size of {csi_size} bytes, where {num_rx} × {num_tx} × {num_subcarriers} \
             values take {}",
            values * 4
        ));
    }
    let end = FEIT_HEADER_LEN + values * 4;
    let data = rest
        .get(FEIT_HEADER_LEN..end)
        .ok_or_else(|| format!("a record cut by the end of the file ({} bytes)", rest.len()))?;
    let csi = data
        .chunks_exact(4)
        .map(|v| {
            Complex::new(
                i16::from_le_bytes([v[0], v[1]]),
                i16::from_le_bytes([v[2], v[3]]),
            )
        })
        .collect();
    let record = FeitRecord {
        offset,
        ftm_clock: u32_at(8),
        num_rx,
        num_tx,
        num_subcarriers,
        rssi: [u32_at(60), u32_at(64)],
        source_mac: [h[68], h[69], h[70], h[71], h[72], h[73]],
        mu_clock: u32_at(88),
        rate_flags: u32_at(92),
        csi,
    };
    Ok((record, end))
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
            let shape = format!("{}x{}x{}", r.num_rx, r.num_tx, r.num_subcarriers);
            *s.shapes.entry(shape).or_default() += 1;
            let format = format!("{} {} MHz", r.format().name(), r.width_mhz());
            *s.formats.entry(format).or_default() += 1;
            let mac: Vec<String> = r.source_mac.iter().map(|b| format!("{b:02x}")).collect();
            *s.transmitters.entry(mac.join(":")).or_default() += 1;
        }
        s
    }
}

impl std::fmt::Display for FeitSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list = |m: &std::collections::BTreeMap<String, u64>| {
            let items: Vec<String> = m.iter().map(|(k, v)| format!("{k}: {v}")).collect();
            if items.is_empty() {
                "-".to_string()
            } else {
                items.join(", ")
            }
        };
        writeln!(f, "{:<12}FeitCSI (Intel AX200/AX210)", "format")?;
        writeln!(f, "{:<12}{} bytes", "size", self.bytes)?;
        writeln!(f, "{:<12}{}", "records", self.records)?;
        writeln!(
            f,
            "{:<12}{} (rx x tx x subcarriers)",
            "shape",
            list(&self.shapes)
        )?;
        writeln!(f, "{:<12}{}", "frames", list(&self.formats))?;
        writeln!(f, "{:<12}{}", "transmitter", list(&self.transmitters))?;
        if let Some(t) = &self.tail {
            writeln!(f, "{:<12}{t}", "lost")?;
        }
        Ok(())
    }
}
