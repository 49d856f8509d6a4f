//! The pcap container (the classic format, not pcapng): the global header in either byte order,
//! with micro- or nanosecond timestamps, and its records one at a time, every byte accounted
//! for (a record cut by the end of the file is reported, never read past).

use std::fmt;

/// Bytes of the global header.
pub const GLOBAL_HEADER_LEN: usize = 24;
/// Bytes of a record header.
pub const RECORD_HEADER_LEN: usize = 16;
/// Largest record a capture may claim (pcap's own limit for Ethernet captures is far below).
pub const MAX_RECORD_LEN: u32 = 1 << 18;
/// Link type of Ethernet frames (`LINKTYPE_ETHERNET`).
pub const LINKTYPE_ETHERNET: u32 = 1;

/// Why a file is not a pcap capture this reader takes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PcapError {
    /// Fewer bytes than the global header.
    #[error("{len} bytes: shorter than a pcap global header ({GLOBAL_HEADER_LEN} bytes)")]
    Short {
        /// Bytes in the file.
        len: usize,
    },
    /// The magic number is none of pcap's four.
    #[error("magic number {magic:#010x}: not a pcap capture (pcapng is not read)")]
    Magic {
        /// The first four bytes, big-endian.
        magic: u32,
    },
    /// Another link type than Ethernet.
    #[error("link type {linktype}: Nexmon's captures are Ethernet (link type 1)")]
    LinkType {
        /// The link type of the file.
        linktype: u32,
    },
}

/// Whether `head`, a file's first bytes, starts as a classic pcap capture (any byte order or
/// time unit).
pub fn looks_like_pcap(head: &[u8]) -> bool {
    head.get(..4).is_some_and(|m| {
        let magic = u32::from_be_bytes([m[0], m[1], m[2], m[3]]);
        [0xd4c3_b2a1, 0xa1b2_c3d4, 0x4d3c_b2a1, 0xa1b2_3c4d].contains(&magic)
    })
}

/// The global header's facts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PcapHeader {
    /// Fields are little-endian.
    pub little_endian: bool,
    /// Timestamps' second part is in nanoseconds (else microseconds).
    pub nanoseconds: bool,
    /// The link type.
    pub linktype: u32,
}

/// One record of a capture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PcapRecord<'a> {
    /// Byte offset of its record header in the file.
    pub offset: u64,
    /// Seconds of its timestamp.
    pub ts_sec: u32,
    /// Sub-second part, µs (or ns with [`PcapHeader::nanoseconds`]).
    pub ts_frac: u32,
    /// Bytes captured (those of `data`).
    pub caplen: u32,
    /// Bytes the packet had on the wire.
    pub wirelen: u32,
    /// The captured bytes.
    pub data: &'a [u8],
}

/// What the walk over the records met besides whole records.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PcapTail {
    /// The file ends inside a record (header or data): so many bytes from `offset`.
    Cut {
        /// Offset of the cut record.
        offset: u64,
        /// Bytes left from it.
        len: u64,
    },
    /// A record claims more bytes than any capture holds: the rest of the file is not read.
    Oversized {
        /// Offset of the record.
        offset: u64,
        /// Bytes from it to the end.
        len: u64,
        /// Its claimed length.
        claimed: u32,
    },
}

impl fmt::Display for PcapTail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cut { offset, len } => {
                write!(
                    f,
                    "offset {offset}: a record cut by the end of the file ({len} bytes)"
                )
            }
            Self::Oversized {
                offset,
                len,
                claimed,
            } => write!(
                f,
                "offset {offset}: a record claims {claimed} bytes: the last {len} bytes are not read"
            ),
        }
    }
}

/// The records of a capture held in memory.
#[derive(Clone, Debug)]
pub struct PcapWalk<'a> {
    bytes: &'a [u8],
    header: PcapHeader,
    at: usize,
    /// What ended the walk early, once it has.
    pub tail: Option<PcapTail>,
}

impl<'a> PcapWalk<'a> {
    /// The walk over `bytes`, a whole capture. Errors: not a classic pcap capture of Ethernet
    /// frames.
    pub fn new(bytes: &'a [u8]) -> Result<Self, PcapError> {
        let head = bytes
            .get(..GLOBAL_HEADER_LEN)
            .ok_or(PcapError::Short { len: bytes.len() })?;
        let magic = u32::from_be_bytes([head[0], head[1], head[2], head[3]]);
        let (little_endian, nanoseconds) = match magic {
            0xd4c3_b2a1 => (true, false),
            0xa1b2_c3d4 => (false, false),
            0x4d3c_b2a1 => (true, true),
            0xa1b2_3c4d => (false, true),
            _ => return Err(PcapError::Magic { magic }),
        };
        let header = PcapHeader {
            little_endian,
            nanoseconds,
            linktype: read_u32(&head[20..24], little_endian),
        };
        if header.linktype != LINKTYPE_ETHERNET {
            return Err(PcapError::LinkType {
                linktype: header.linktype,
            });
        }
        Ok(Self {
            bytes,
            header,
            at: GLOBAL_HEADER_LEN,
            tail: None,
        })
    }

    /// The global header.
    pub fn header(&self) -> PcapHeader {
        self.header
    }
}

impl<'a> Iterator for PcapWalk<'a> {
    type Item = PcapRecord<'a>;

    fn next(&mut self) -> Option<PcapRecord<'a>> {
        let rest = self.bytes.get(self.at..)?;
        if rest.is_empty() || self.tail.is_some() {
            return None;
        }
        let offset = self.at as u64;
        let cut = |len: usize| PcapTail::Cut {
            offset,
            len: len as u64,
        };
        let Some(h) = rest.get(..RECORD_HEADER_LEN) else {
            self.tail = Some(cut(rest.len()));
            return None;
        };
        let le = self.header.little_endian;
        let (ts_sec, ts_frac) = (read_u32(&h[0..4], le), read_u32(&h[4..8], le));
        let (caplen, wirelen) = (read_u32(&h[8..12], le), read_u32(&h[12..16], le));
        if caplen > MAX_RECORD_LEN {
            self.tail = Some(PcapTail::Oversized {
                offset,
                len: rest.len() as u64,
                claimed: caplen,
            });
            return None;
        }
        let end = RECORD_HEADER_LEN + caplen as usize;
        let Some(data) = rest.get(RECORD_HEADER_LEN..end) else {
            self.tail = Some(cut(rest.len()));
            return None;
        };
        self.at += end;
        Some(PcapRecord {
            offset,
            ts_sec,
            ts_frac,
            caplen,
            wirelen,
            data,
        })
    }
}

/// A `u32` of four bytes in the file's byte order.
fn read_u32(b: &[u8], little_endian: bool) -> u32 {
    let a = [b[0], b[1], b[2], b[3]];
    if little_endian {
        u32::from_le_bytes(a)
    } else {
        u32::from_be_bytes(a)
    }
}
