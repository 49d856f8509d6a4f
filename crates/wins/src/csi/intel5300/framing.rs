//! Record framing of a CSI Tool log or `log_to_server` stream: `[u16 BE length][code][payload]`,
//! where the length counts the code byte and the payload.
//!
//! One pure function, [`step`], decides what the bytes at the front of a buffer are. It returns
//! [`Step::NeedMore`] whenever the answer could change with more bytes, so a stream fed in any
//! chunking makes exactly the decisions a reader of the whole file makes.
//!
//! Recovery from corrupt input: a CSI record is accepted only when its framing length, its header's
//! CSI length and its chain counts all agree. Another code is accepted as a well-framed non-CSI
//! record only when a plausible record starts right after it (or the stream ends there) and no
//! consistent CSI header starts inside the bytes it claims (decided as soon as such a header has
//! come, so a garbage length field never holds a stream back until its length is filled). Anything
//! else starts an *unframed* region that runs to the next offset where a consistent CSI header, or a
//! 0xC1 record followed by one, begins; the region is reported with its offset, length and the first
//! problem found, never dropped silently.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::bfee::parse_header;
use super::layout::{
    CODE_CSI, CODE_FRAME, CSI_PREFIX, HEADER_LEN, LEN_FIELD, NRX_AT, NTX_AT, packed_csi_len,
};
use super::record::BfeeHeader;

/// Longest unframed region reported as one skip. A longer run of garbage is reported in pieces, so a
/// stream of garbage (a wrong port, a wrong file) keeps the decoder's memory bounded.
pub const MAX_UNFRAMED: usize = 1 << 16;

/// Bytes that were skipped, where, and why.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Skip {
    /// Byte offset of the first skipped byte in the log or stream.
    pub offset: u64,
    /// Number of bytes skipped.
    pub len: u64,
    /// Why.
    pub reason: SkipReason,
}

/// Why bytes were skipped.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Error, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum SkipReason {
    /// A well-framed record that does not carry CSI (0xC1 frame records, or another code).
    #[error("non-CSI record, code 0x{code:02X}")]
    NonCsi {
        /// Its code byte.
        code: u8,
    },
    /// Bytes that do not frame as records, up to the next plausible record.
    #[error("unframed bytes ({cause})")]
    Unframed {
        /// The first problem found at the region's start.
        cause: FramingError,
    },
    /// The log or stream ends inside a record.
    #[error("truncated tail: the record needs {needed} bytes")]
    TruncatedTail {
        /// Bytes the record would need, from its length field (at least the 3 of its framing).
        needed: u64,
    },
}

/// What was wrong where framing failed.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Error, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "problem")]
pub enum FramingError {
    /// A length field of 0 (a record has at least its code byte).
    #[error("zero-length record")]
    ZeroLength,
    /// A CSI record too short to hold its 20-byte header.
    #[error("CSI record of length {field_len} cannot hold its header")]
    CsiTooShort {
        /// The framing length.
        field_len: u16,
    },
    /// Chain counts outside 1–3.
    #[error("CSI header with nrx = {nrx}, ntx = {ntx}")]
    BadChains {
        /// Receive chains.
        nrx: u8,
        /// Transmit streams.
        ntx: u8,
    },
    /// The header's CSI length disagrees with its chain counts.
    #[error("CSI header says {len} bytes of CSI, nrx·ntx needs {expected}")]
    CsiLenMismatch {
        /// From the header.
        len: u16,
        /// `60·nrx·ntx + 12`.
        expected: u16,
    },
    /// The framing length disagrees with the header.
    #[error("record length {field_len} disagrees with its CSI header (needs {expected})")]
    RecordLenMismatch {
        /// From the framing.
        field_len: u16,
        /// `1 + 20 + 60·nrx·ntx + 12`.
        expected: u16,
    },
    /// A consistent CSI header starts inside the record: a CSI record cut short by the next one, or a
    /// garbage length field spanning real records.
    #[error("record overlaps a CSI record starting {next_at} bytes in")]
    OverlapsCsi {
        /// Bytes from the cut record's start to the record inside it.
        next_at: u64,
    },
    /// A record that claims more bytes than the log holds, while a valid record starts inside it.
    #[error("record with code 0x{code:02X} needs {needed} bytes, past the end of the log")]
    PastEnd {
        /// Its code byte.
        code: u8,
        /// Bytes it claims, framing included.
        needed: u64,
    },
    /// A non-CSI record after which no plausible record starts.
    #[error("record with code 0x{code:02X} is not followed by a valid record")]
    NoRecordFollows {
        /// Its code byte.
        code: u8,
    },
}

/// What the bytes at the front of a buffer are.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Step {
    /// The decision needs more bytes (never returned at end of stream).
    NeedMore,
    /// The buffer is empty and the stream has ended.
    End,
    /// A CSI record of `len` bytes; its packed CSI is `buf[CSI_PREFIX..len]`.
    Csi { len: usize, header: BfeeHeader },
    /// `len` bytes to skip.
    Skip { len: usize, reason: SkipReason },
}

/// Decides what starts at `buf[0]`. `eof` says no bytes will follow `buf`. `scan_from` remembers how
/// far a resynchronization scan got when it ran out of bytes; reset it to 0 after consuming.
pub(crate) fn step(buf: &[u8], eof: bool, scan_from: &mut usize) -> Step {
    if buf.is_empty() {
        return if eof { Step::End } else { Step::NeedMore };
    }
    match probe(buf, eof) {
        Probe::NeedMore => Step::NeedMore,
        Probe::Csi { len, header } => Step::Csi { len, header },
        Probe::Other { len, code } => Step::Skip {
            len,
            reason: SkipReason::NonCsi { code },
        },
        // At end of stream, a record that runs past the end is a truncated tail only if no
        // record starts inside it; otherwise it was garbage with a length field (or a cut record
        // followed by a restarted log) and the bytes up to that record are unframed.
        Probe::Truncated { needed } => match resync(buf, true, scan_from) {
            Scan::Found(len) if len < buf.len() => Step::Skip {
                len,
                reason: SkipReason::Unframed {
                    cause: FramingError::PastEnd {
                        code: buf.get(LEN_FIELD).copied().unwrap_or_default(),
                        needed: needed as u64,
                    },
                },
            },
            _ => Step::Skip {
                len: buf.len(),
                reason: SkipReason::TruncatedTail {
                    needed: needed as u64,
                },
            },
        },
        Probe::Bad(cause) => match resync(buf, eof, scan_from) {
            Scan::NeedMore => Step::NeedMore,
            Scan::Found(len) => Step::Skip {
                len,
                reason: SkipReason::Unframed { cause },
            },
        },
    }
}

enum Probe {
    NeedMore,
    Csi { len: usize, header: BfeeHeader },
    Other { len: usize, code: u8 },
    Truncated { needed: usize },
    Bad(FramingError),
}

fn field_len(buf: &[u8]) -> Option<usize> {
    Some(usize::from(u16::from_be_bytes([
        *buf.first()?,
        *buf.get(1)?,
    ])))
}

/// Validates a CSI record's framing against its header; `buf` starts at the length field and holds
/// at least [`CSI_PREFIX`] bytes.
fn check_csi_header(buf: &[u8]) -> Result<(usize, BfeeHeader), FramingError> {
    let field_len = field_len(buf).unwrap_or(0);
    let Some(bytes) = buf
        .get(LEN_FIELD + 1..CSI_PREFIX)
        .and_then(|b| <&[u8; HEADER_LEN]>::try_from(b).ok())
    else {
        return Err(FramingError::CsiTooShort {
            field_len: field_len as u16,
        });
    };
    // Chain counts first: the cheapest rejection of a false candidate during scans.
    let (nrx, ntx) = (bytes[NRX_AT], bytes[NTX_AT]);
    if !(1..=3).contains(&nrx) || !(1..=3).contains(&ntx) {
        return Err(FramingError::BadChains { nrx, ntx });
    }
    let (header, len) = parse_header(bytes);
    let expected = packed_csi_len(header.nrx, header.ntx);
    if usize::from(len) != expected {
        return Err(FramingError::CsiLenMismatch {
            len,
            expected: expected as u16,
        });
    }
    if field_len != 1 + HEADER_LEN + expected {
        return Err(FramingError::RecordLenMismatch {
            field_len: field_len as u16,
            expected: (1 + HEADER_LEN + expected) as u16,
        });
    }
    Ok((LEN_FIELD + field_len, header))
}

fn probe(buf: &[u8], eof: bool) -> Probe {
    let need = |needed: usize| {
        if eof {
            Probe::Truncated { needed }
        } else {
            Probe::NeedMore
        }
    };
    let (Some(flen), Some(&code)) = (field_len(buf), buf.get(LEN_FIELD)) else {
        return need(LEN_FIELD + 1);
    };
    if flen == 0 {
        return Probe::Bad(FramingError::ZeroLength);
    }
    let total = LEN_FIELD + flen;
    if code == CODE_CSI {
        if flen < 1 + HEADER_LEN {
            return Probe::Bad(FramingError::CsiTooShort {
                field_len: flen as u16,
            });
        }
        if buf.len() < CSI_PREFIX {
            return need(total);
        }
        return match check_csi_header(buf) {
            Err(e) => Probe::Bad(e),
            Ok(_) if buf.len() < total => need(total),
            Ok((len, header)) => match embedded_csi_start(&buf[..len], CSI_PREFIX) {
                Some(at) => Probe::Bad(FramingError::OverlapsCsi { next_at: at as u64 }),
                None => Probe::Csi { len, header },
            },
        };
    }
    // A consistent CSI header inside the bytes the record claims makes it garbage, whatever
    // follows: decided on the bytes already here, so a garbage length field does not hold a
    // live stream's records back until its 64 KiB have come.
    let claimed = buf.get(..total).unwrap_or(buf);
    if let Some(at) = embedded_csi_start(claimed, LEN_FIELD + 1) {
        return Probe::Bad(FramingError::OverlapsCsi { next_at: at as u64 });
    }
    let Some(rest) = buf.get(total..) else {
        return need(total);
    };
    match plausible_start(rest, eof) {
        Plausible::NeedMore => Probe::NeedMore,
        Plausible::Yes => Probe::Other { len: total, code },
        Plausible::No => Probe::Bad(FramingError::NoRecordFollows { code }),
    }
}

/// Where a consistent CSI header starts inside `record`, at or after byte `first` and wholly inside
/// it. For a CSI record that means it was cut short and another one follows; for any other record,
/// that its length field is garbage spanning real records. Looks only at the record's own bytes, so
/// a live stream gets each record without waiting for the next. A cut in the last 22 bytes of a
/// record is not seen here; the record after it is then reported as unframed.
fn embedded_csi_start(record: &[u8], first: usize) -> Option<usize> {
    let last = record.len().checked_sub(CSI_PREFIX)?;
    let codes = record.get(first + LEN_FIELD..=last + LEN_FIELD)?;
    memchr::memchr_iter(CODE_CSI, codes)
        .map(|i| first + i)
        .find(|&k| record.get(k..).is_some_and(|r| check_csi_header(r).is_ok()))
}

enum Plausible {
    Yes,
    No,
    NeedMore,
}

/// Whether a record plausibly starts at `buf[0]`: a consistent CSI header, or a 0xC1 record.
/// At end of stream a partial start counts as plausible (it is reported as a truncated tail next).
fn plausible_start(buf: &[u8], eof: bool) -> Plausible {
    let partial = if eof {
        Plausible::Yes
    } else {
        Plausible::NeedMore
    };
    let (Some(flen), Some(&code)) = (field_len(buf), buf.get(LEN_FIELD)) else {
        return partial;
    };
    match code {
        _ if flen == 0 => Plausible::No,
        CODE_CSI if buf.len() < CSI_PREFIX => partial,
        CODE_CSI if check_csi_header(buf).is_ok() => Plausible::Yes,
        CODE_FRAME => Plausible::Yes,
        _ => Plausible::No,
    }
}

enum Scan {
    NeedMore,
    /// Resume at this offset (the end of the buffer at end of stream).
    Found(usize),
}

/// Finds the next offset after 0 where a consistent CSI header starts, or a 0xC1 record whose
/// successor is a consistent CSI header and inside which none starts.
fn resync(buf: &[u8], eof: bool, scan_from: &mut usize) -> Scan {
    let mut k = (*scan_from).max(1);
    while k < buf.len() {
        if k >= MAX_UNFRAMED {
            return Scan::Found(k);
        }
        match resync_candidate(&buf[k..]) {
            Some(true) => return Scan::Found(k),
            Some(false) => k += 1,
            None if eof => k += 1,
            None => {
                *scan_from = k;
                return Scan::NeedMore;
            }
        }
    }
    if eof {
        Scan::Found(buf.len())
    } else {
        *scan_from = k;
        Scan::NeedMore
    }
}

/// `Some(accept)`, or `None` when the candidate needs more bytes to judge.
fn resync_candidate(buf: &[u8]) -> Option<bool> {
    let code = *buf.get(LEN_FIELD)?;
    match code {
        CODE_CSI => {
            buf.get(CSI_PREFIX - 1)?;
            Some(check_csi_header(buf).is_ok())
        }
        CODE_FRAME => {
            let flen = field_len(buf)?;
            if flen == 0 {
                return Some(false);
            }
            // As in `probe`: a CSI header inside the bytes it claims refuses it at once.
            let claimed = buf.get(..LEN_FIELD + flen).unwrap_or(buf);
            if embedded_csi_start(claimed, LEN_FIELD + 1).is_some() {
                return Some(false);
            }
            let next = buf.get(LEN_FIELD + flen..)?;
            next.get(CSI_PREFIX - 1)?;
            Some(check_csi_header(next).is_ok())
        }
        _ => Some(false),
    }
}
