//! What a file is when it does not read as a CSI Tool log: another capture format named by its
//! first bytes, or a CSI Tool log whose records a modified logger changed (extra bytes in every
//! CSI record, or in front of every record).

use std::io::{self, Read};
use std::path::Path;

use crate::csi::atheros::looks_like_atheros;
use crate::csi::feitcsi::looks_like_feitcsi;
use crate::csi::picoscenes::looks_like_picoscenes;

use super::layout::{CODE_CSI, CODE_FRAME, HEADER_LEN, LEN_FIELD, packed_csi_len};

/// Bytes read to identify a file: enough for a few hundred records.
const SAMPLE_BYTES: u64 = 1 << 16;

/// Most bytes a modified logger is looked for in front of every record.
const MAX_PREFIX: usize = 16;

/// Records a framing walk must cover to name a layout.
const MIN_RECORDS: usize = 8;

/// What a file that is not a plain CSI Tool log looks like.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Identified {
    /// Another format, named by its magic bytes (`"a pcap capture"`).
    Foreign(&'static str),
    /// CSI Tool records whose CSI records each hold `extra` bytes more than the CSI Tool's
    /// layout (a logger that adds fields to the record).
    LongerCsiRecords {
        /// Extra bytes per CSI record.
        extra: usize,
    },
    /// CSI Tool records each preceded by `prefix` bytes the CSI Tool does not write.
    PrefixedRecords {
        /// Bytes in front of every record.
        prefix: usize,
    },
}

impl Identified {
    /// The finding, in words.
    pub fn describe(&self) -> String {
        match self {
            Self::Foreign(what) => format!("{what}, not an Intel 5300 CSI Tool log"),
            Self::LongerCsiRecords { extra } => format!(
                "written by a modified CSI Tool: its records frame as the CSI Tool's, but every CSI \
                 record holds {extra} bytes more than the CSI Tool's layout (a header of \
                 {HEADER_LEN} bytes, then the CSI) says"
            ),
            Self::PrefixedRecords { prefix } => format!(
                "written by a modified logger: every record is preceded by {prefix} bytes the CSI \
                 Tool does not write (a timestamp, often)"
            ),
        }
    }
}

/// Why the file at `path` gave no CSI record, in words: what it is when it is recognized
/// ([`identify`]), else that none of its bytes frame as CSI Tool records.
pub fn why_no_records(path: &Path) -> String {
    match identify(path) {
        Ok(Some(found)) => found.describe(),
        _ => "none of its bytes frame as Intel 5300 CSI Tool records".into(),
    }
}

/// Identifies the file at `path` from its first 64 KiB (`None`: nothing recognized).
pub fn identify(path: &Path) -> io::Result<Option<Identified>> {
    let mut head = Vec::new();
    crate::io_safety::open_regular(path)?
        .take(SAMPLE_BYTES)
        .read_to_end(&mut head)?;
    Ok(identify_bytes(&head))
}

/// [`identify`] on the file's first bytes.
pub fn identify_bytes(head: &[u8]) -> Option<Identified> {
    if let Some(what) = magic(head) {
        return Some(Identified::Foreign(what));
    }
    if let Some(extra) = longer_csi_records(head) {
        return Some(Identified::LongerCsiRecords { extra });
    }
    if looks_like_atheros(head) {
        return Some(Identified::Foreign(
            "an Atheros CSI Tool log (`wins csi info`, `check`, `export` and `wins aoa` read it; `wins calibrate` and the estimator, with `[array] card` in dataset.toml, take it; `wins csi stats` does not)",
        ));
    }
    (1..=MAX_PREFIX)
        .find(|&p| {
            walk(head, p).is_some_and(|w| w.records >= MIN_RECORDS && w.csi_extra == Some(0))
        })
        .map(|prefix| Identified::PrefixedRecords { prefix })
}

/// Formats named by their first bytes.
fn magic(head: &[u8]) -> Option<&'static str> {
    let starts = |m: &[u8]| head.starts_with(m);
    if starts(&[0xd4, 0xc3, 0xb2, 0xa1])
        || starts(&[0xa1, 0xb2, 0xc3, 0xd4])
        || starts(&[0x4d, 0x3c, 0xb2, 0xa1])
        || starts(&[0xa1, 0xb2, 0x3c, 0x4d])
    {
        return Some(
            "a pcap capture (Nexmon writes its CSI as UDP packets in one: `wins csi info`, `check`, `export` and `wins aoa` read it; `wins calibrate` and the estimator, with `[array] card` in dataset.toml, take it; `wins csi stats` does not)",
        );
    }
    if looks_like_picoscenes(head) {
        return Some(
            "a PicoScenes file (`wins csi info`, `check`, `export` and `wins aoa` read it; `wins calibrate` and the estimator, with `[array] card` in dataset.toml, take it; `wins csi stats` does not)",
        );
    }
    if looks_like_feitcsi(head) {
        return Some(
            "a FeitCSI file of an Intel AX200/AX210 (`wins csi info`, `check`, `export` and `wins aoa` read it; `wins calibrate` and the estimator, with `[array] card` in dataset.toml, take it; `wins csi stats` does not)",
        );
    }
    if starts(&[0x0a, 0x0d, 0x0d, 0x0a]) {
        return Some("a pcapng capture (wins does not read it)");
    }
    if starts(&[0x1f, 0x8b]) {
        return Some("a gzip-compressed file (decompress it first)");
    }
    if starts(b"PK\x03\x04") {
        return Some("a zip archive (extract the log first)");
    }
    if starts(b"MATLAB") {
        return Some("a MATLAB .mat file (the CSI Tool's output as MATLAB read it, not its log)");
    }
    let text = head.len() >= 16
        && head
            .iter()
            .take(4096)
            .all(|&b| b.is_ascii_graphic() || b.is_ascii_whitespace());
    text.then_some("a text file (CSV or JSON, not a binary CSI log)")
}

/// How a framing walk over the records went.
struct Walk {
    /// Records walked.
    records: usize,
    /// The CSI records' bytes beyond the CSI Tool's layout, when all of them agree.
    csi_extra: Option<usize>,
}

/// Walks `head` as `[prefix bytes][u16 BE length][code][payload]` records with codes 0xBB or
/// 0xC1 only, checking nothing else; `None` when a record breaks the walk before the sample's end
/// (a record cut by the sample's end is fine).
fn walk(head: &[u8], prefix: usize) -> Option<Walk> {
    let (mut at, mut records) = (0, 0);
    let mut extras: Option<Option<usize>> = None;
    while at + prefix + LEN_FIELD < head.len() {
        let len_at = at + prefix;
        let len = usize::from(u16::from_be_bytes([head[len_at], head[len_at + 1]]));
        let code = head[len_at + LEN_FIELD];
        if len == 0 || !(code == CODE_CSI || code == CODE_FRAME) {
            return None;
        }
        let end = len_at + LEN_FIELD + len;
        if code == CODE_CSI {
            let payload = &head[len_at + LEN_FIELD + 1..end.min(head.len())];
            let (Some(&nrx), Some(&ntx)) = (payload.get(8), payload.get(9)) else {
                break;
            };
            if !(1..=3).contains(&nrx) || !(1..=3).contains(&ntx) {
                return None;
            }
            let layout = HEADER_LEN + packed_csi_len(nrx, ntx);
            let extra = (len - 1).checked_sub(layout);
            extras = Some(match extras {
                None => extra,
                Some(e) if e == extra => e,
                Some(_) => None,
            });
        }
        records += 1;
        at = end;
    }
    Some(Walk {
        records,
        csi_extra: extras.flatten(),
    })
}

/// The extra bytes of every CSI record when the records frame from the start with no prefix but
/// every CSI record is longer than the CSI Tool's layout by the same amount.
fn longer_csi_records(head: &[u8]) -> Option<usize> {
    let w = walk(head, 0)?;
    (w.records >= MIN_RECORDS)
        .then_some(w.csi_extra)
        .flatten()
        .filter(|&e| e > 0)
}

/// Whether `head`, a file's first bytes, frames from its first byte as CSI Tool records (up
/// to the sample's end) and holds at least one.
pub fn looks_like_csi_tool(head: &[u8]) -> bool {
    walk(head, 0).is_some_and(|w| w.records >= 1)
}
