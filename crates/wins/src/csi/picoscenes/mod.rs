//! PicoScenes `.csi` files (any card PicoScenes drives; wins reads the Intel AX200/AX210's
//! segments). Frame: `u32` length (the bytes after it), magic 0x20150315, `u16` frame version
//! (1), `u8` segment count; each segment: `u32` length (the bytes after it), `u8` name length,
//! the name (NUL-terminated), `u16` version, the body; then the 802.11 frame (MPDU) to the
//! frame's end. All little-endian.
//!
//! The segments wins reads ([`segments::KNOWN_VERSIONS`]) are parsed at their version, and any
//! other version of them ends the reading with an error that names it: a newer PicoScenes moves
//! fields, and a reader that guesses parses silently wrong. Segments wins does not read
//! (`ExtraInfo`, `PilotCSI`, …) are listed with their versions and skipped whole. Every byte is
//! in a frame or in the reported tail. Notes on the format and on where the public readers
//! disagree: `../shared/data/picoscenes/README.md`.

pub mod segments;
mod summary;

use std::path::Path;

use crate::csi::MacAddress;
use crate::csi::iwlmvm::IntelCsiHeader;
pub use segments::{KNOWN_VERSIONS, PicoCsi, RxsBasic};
pub use summary::PicoSummary;

/// The magic after a frame's length.
pub const FRAME_MAGIC: u32 = 0x2015_0315;
/// Bytes of a frame's header: length, magic, version, segment count.
const FRAME_HEADER_LEN: usize = 11;
/// The frame versions this reader knows.
const KNOWN_FRAME_VERSIONS: [u16; 1] = [1];

/// One PicoScenes frame.
#[derive(Clone, Debug, PartialEq)]
pub struct PicoFrame {
    /// Byte offset of its length field.
    pub offset: u64,
    /// Bytes it takes in the file.
    pub len: u64,
    /// The frame version.
    pub frame_version: u16,
    /// Every segment's name and version, in file order.
    pub segments: Vec<(String, u16)>,
    /// The receiver's report.
    pub rxs_basic: Option<RxsBasic>,
    /// The Intel CSI header (`MVMExtra`).
    pub mvm_extra: Option<IntelCsiHeader>,
    /// The CSI.
    pub csi: Option<PicoCsi>,
    /// The 802.11 frame.
    pub mpdu: Vec<u8>,
}

impl PicoFrame {
    /// The MPDU's frame control field.
    pub fn frame_control(&self) -> Option<u16> {
        Some(u16::from_le_bytes(self.mpdu.get(..2)?.try_into().ok()?))
    }

    /// The MPDU's receiver (addr1).
    pub fn receiver(&self) -> Option<MacAddress> {
        self.mpdu.get(4..10)?.try_into().ok()
    }

    /// The MPDU's transmitter (addr2); control frames with one address (CTS, ACK) have none.
    pub fn transmitter(&self) -> Option<MacAddress> {
        let fc = self.frame_control()?;
        let (kind, subtype) = ((fc >> 2) & 3, (fc >> 4) & 0xf);
        if kind == 1 && matches!(subtype, 12 | 13) {
            return None;
        }
        self.mpdu.get(10..16)?.try_into().ok()
    }

    /// The MPDU's sequence control (none in control frames).
    pub fn seq_ctl(&self) -> Option<u16> {
        if (self.frame_control()? >> 2) & 3 == 1 {
            return None;
        }
        Some(u16::from_le_bytes(self.mpdu.get(22..24)?.try_into().ok()?))
    }
}

/// A whole PicoScenes file read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PicoCapture {
    /// The frames, in file order.
    pub frames: Vec<PicoFrame>,
    /// Where the reading stopped before the end, the bytes left, and why.
    pub tail: Option<crate::csi::report::Tail>,
    /// Bytes in the file.
    pub bytes: u64,
}

impl PicoCapture {
    /// What was not read at the end of the file, in words (`None`: all of it was read).
    pub fn lost(&self) -> Option<String> {
        crate::csi::report::lost(self.tail.as_ref())
    }

    /// Bytes in the frames and the tail: the file's size when every byte is accounted for.
    pub fn bytes_accounted(&self) -> u64 {
        self.frames.iter().map(|f| f.len).sum::<u64>() + self.tail.as_ref().map_or(0, |t| t.1)
    }
}

/// Reads the PicoScenes file at `path` (a regular file).
pub fn read_picoscenes(path: &Path) -> std::io::Result<PicoCapture> {
    Ok(parse_picoscenes(&crate::csi::report::read_whole(path)?))
}

/// [`read_picoscenes`] of a file held in memory.
pub fn parse_picoscenes(bytes: &[u8]) -> PicoCapture {
    let mut capture = PicoCapture {
        bytes: bytes.len() as u64,
        ..PicoCapture::default()
    };
    let mut at = 0usize;
    while at < bytes.len() {
        match frame(&bytes[at..], at as u64) {
            Ok(f) => {
                at += f.len as usize;
                capture.frames.push(f);
            }
            Err(why) => {
                capture.tail = Some((at as u64, (bytes.len() - at) as u64, why));
                break;
            }
        }
    }
    capture
}

/// Whether `head`, a file's first bytes, starts with a PicoScenes frame header.
pub fn looks_like_picoscenes(head: &[u8]) -> bool {
    head.get(4..8)
        .is_some_and(|m| m == FRAME_MAGIC.to_le_bytes().as_slice())
}

/// The frame at the start of `rest`, or why there is none.
fn frame(rest: &[u8], offset: u64) -> Result<PicoFrame, String> {
    let h = rest.get(..FRAME_HEADER_LEN).ok_or_else(|| {
        format!(
            "a frame header cut by the end of the file ({} bytes)",
            rest.len()
        )
    })?;
    let u32_at = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
    if u32_at(4) != FRAME_MAGIC {
        return Err(format!(
            "not a PicoScenes frame: magic {:#010x}, not {FRAME_MAGIC:#010x}",
            u32_at(4)
        ));
    }
    let frame_version = u16::from_le_bytes([h[8], h[9]]);
    if !KNOWN_FRAME_VERSIONS.contains(&frame_version) {
        return Err(format!(
            "a PicoScenes frame of version {frame_version}, which this reader does not know \
             (it knows {KNOWN_FRAME_VERSIONS:?})"
        ));
    }
    let len = 4 + u32_at(0) as usize;
    if len < FRAME_HEADER_LEN {
        return Err(format!(
            "a PicoScenes frame of {len} bytes, shorter than its header"
        ));
    }
    let body = rest.get(FRAME_HEADER_LEN..len).ok_or_else(|| {
        format!(
            "a frame cut by the end of the file ({} of {len} bytes)",
            rest.len()
        )
    })?;
    let mut out = PicoFrame {
        offset,
        len: len as u64,
        frame_version,
        segments: Vec::new(),
        rxs_basic: None,
        mvm_extra: None,
        csi: None,
        mpdu: Vec::new(),
    };
    let mut at = 0usize;
    for index in 0..h[10] {
        let (name, version, seg_body, seg_len) =
            segment(&body[at..]).map_err(|why| format!("segment {index} of the frame: {why}"))?;
        let unknown = || {
            let known: Vec<u16> = KNOWN_VERSIONS
                .iter()
                .filter(|(n, _)| *n == name)
                .map(|(_, v)| *v)
                .collect();
            format!(
                "a {name} segment of version {version}, which this reader does not know (it \
                 knows {known:?}): the file was written by another PicoScenes version"
            )
        };
        match (name.as_str(), version) {
            ("RxSBasic", 3) => out.rxs_basic = Some(RxsBasic::parse_v3(seg_body)?),
            ("MVMExtra", 1) => out.mvm_extra = Some(segments::parse_mvm_extra_v1(seg_body)?),
            ("CSI", 4) => out.csi = Some(PicoCsi::parse_v4(seg_body)?),
            ("RxSBasic" | "MVMExtra" | "CSI", _) => return Err(unknown()),
            _ => {}
        }
        out.segments.push((name, version));
        at += seg_len;
    }
    out.mpdu = body[at..].to_vec();
    Ok(out)
}

/// The segment at the start of `rest`: its name, version, body and the bytes it takes.
fn segment(rest: &[u8]) -> Result<(String, u16, &[u8], usize), String> {
    let cut = || {
        format!(
            "a segment cut by its frame's end ({} bytes left)",
            rest.len()
        )
    };
    let len = 4 + u32::from_le_bytes(
        rest.get(..4)
            .ok_or_else(cut)?
            .try_into()
            .map_err(|_| cut())?,
    ) as usize;
    let seg = rest.get(..len).ok_or_else(cut)?;
    let name_len = usize::from(*seg.get(4).ok_or_else(cut)?);
    let name_bytes = seg.get(5..5 + name_len).ok_or_else(cut)?;
    let version_bytes = seg.get(5 + name_len..7 + name_len).ok_or_else(cut)?;
    let name: String = String::from_utf8_lossy(name_bytes)
        .trim_end_matches('\0')
        .to_string();
    let version = u16::from_le_bytes([version_bytes[0], version_bytes[1]]);
    Ok((name, version, &seg[7 + name_len..], len))
}
