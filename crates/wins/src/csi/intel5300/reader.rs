//! Decoders over the framing core: a whole log in memory, a push-style stream (the CSI Tool's
//! `log_to_server` TCP stream uses the same framing), and a pull reader over any `io::Read`.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::bfee::unpack_csi;
use super::framing::{MAX_UNFRAMED, Skip, SkipReason, Step, step};
use super::layout::{CODE_FRAME, CSI_PREFIX, LEN_FIELD};
use super::record::CsiRecord;
use crate::time::MicrosUnwrapper;

/// One decoded item of a log: a CSI record, or bytes skipped with the reason.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A CSI record.
    Csi(Box<CsiRecord>),
    /// Skipped bytes.
    Skipped(Skip),
}

pub use crate::csi::MacAddress;

/// Offset of the transmitter address (`addr2`) in a 0xC1 frame record: its framing (length and
/// code, 3 bytes), then the 802.11 header's frame control (2), duration (2) and receiver address
/// (6).
const FRAME_TRANSMITTER_AT: usize = LEN_FIELD + 1 + 2 + 2 + 6;

/// State shared by every decoder: the timestamp unwrapper and the resynchronization scan.
#[derive(Clone, Debug, Default)]
struct Core {
    unwrapper: MicrosUnwrapper,
    scan_from: usize,
    /// The transmitter of a 0xC1 frame record just decoded, waiting for its CSI record.
    pending_transmitter: Option<MacAddress>,
    /// The transmitter of the last CSI record, when a frame record came right before it.
    last_transmitter: Option<MacAddress>,
}

impl Core {
    /// Decodes the item at the front of `buf` (which starts at stream offset `offset`).
    /// Returns the bytes consumed and the event, or `None` when more bytes are needed.
    fn next(&mut self, buf: &[u8], offset: u64, eof: bool) -> Option<(usize, Event)> {
        let (len, event) = match step(buf, eof, &mut self.scan_from) {
            Step::NeedMore | Step::End => return None,
            Step::Csi { len, header } => {
                let packed = buf.get(CSI_PREFIX..len)?;
                let csi = unpack_csi(&header, packed)?;
                let t = self.unwrapper.unwrap(header.timestamp_low);
                let rec = CsiRecord::from_parts(offset, t, header, csi);
                self.last_transmitter = self.pending_transmitter.take();
                (len, Event::Csi(Box::new(rec)))
            }
            Step::Skip { len, reason } => {
                // A frame record names the transmitter of the CSI record that follows it (the
                // CSI Tool logs the frame first); anything else in between breaks the pair.
                self.pending_transmitter = match reason {
                    SkipReason::NonCsi { code: CODE_FRAME } => buf
                        .get(FRAME_TRANSMITTER_AT..FRAME_TRANSMITTER_AT + 6)
                        .and_then(|a| a.try_into().ok()),
                    _ => None,
                };
                (
                    len,
                    Event::Skipped(Skip {
                        offset,
                        len: len as u64,
                        reason,
                    }),
                )
            }
        };
        self.scan_from = 0;
        Some((len, event))
    }
}

/// Decodes a complete log held in memory, without copying it.
#[derive(Clone, Debug)]
pub struct SliceDecoder<'a> {
    buf: &'a [u8],
    pos: usize,
    core: Core,
}

impl<'a> SliceDecoder<'a> {
    /// A decoder over the whole log.
    pub fn new(buf: &'a [u8]) -> Self {
        Self {
            buf,
            pos: 0,
            core: Core::default(),
        }
    }
}

impl Iterator for SliceDecoder<'_> {
    type Item = Event;

    fn next(&mut self) -> Option<Event> {
        let rest = self.buf.get(self.pos..)?;
        let (len, event) = self.core.next(rest, self.pos as u64, true)?;
        self.pos += len;
        Some(event)
    }
}

/// A push-style decoder for bytes that arrive in arbitrary chunks (a TCP stream, a growing file).
///
/// Feed bytes with [`push`](Self::push), take events with [`next_event`](Self::next_event) until it
/// returns `None`, and call [`finish`](Self::finish) when the stream ends so that a truncated tail is
/// reported. Yields exactly the events [`SliceDecoder`] yields on the concatenated bytes.
#[derive(Clone, Debug, Default)]
pub struct StreamDecoder {
    buf: Vec<u8>,
    start: usize,
    offset: u64,
    eof: bool,
    core: Core,
}

impl StreamDecoder {
    /// Most bytes the decoder holds before it decides, beyond the chunk just pushed: a record may
    /// claim up to 64 KiB and is judged once the next record's header is in, and a resynchronization
    /// scan reports at most [`MAX_UNFRAMED`] bytes at a time.
    pub const MAX_PENDING: usize = LEN_FIELD + u16::MAX as usize + CSI_PREFIX + MAX_UNFRAMED;

    /// A decoder at stream offset 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends bytes. Bytes pushed after [`finish`](Self::finish) are ignored.
    pub fn push(&mut self, bytes: &[u8]) {
        if self.eof {
            return;
        }
        if self.start > 0 && self.start >= self.buf.len() / 2 {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// Marks the end of the stream.
    pub fn finish(&mut self) {
        self.eof = true;
    }

    /// The next event, or `None` when more bytes are needed (or, after `finish`, at the end).
    pub fn next_event(&mut self) -> Option<Event> {
        let rest = self.buf.get(self.start..)?;
        let (len, event) = self.core.next(rest, self.offset, self.eof)?;
        self.start += len;
        self.offset += len as u64;
        Some(event)
    }

    /// The transmitter address of the CSI record [`next_event`](Self::next_event) returned
    /// last, when a 0xC1 frame record came right before it (the CSI Tool's logger writes the
    /// received frame's header ahead of its CSI when asked to); `None` otherwise.
    pub fn transmitter(&self) -> Option<MacAddress> {
        self.core.last_transmitter
    }

    /// Bytes received but not yet decided on.
    pub fn pending(&self) -> usize {
        self.buf.len() - self.start
    }

    /// Stream offset of the first undecided byte.
    pub fn offset(&self) -> u64 {
        self.offset
    }
}

/// Reads events from any `io::Read` in chunks, with bounded memory.
#[derive(Debug)]
pub struct LogReader<R> {
    inner: R,
    decoder: StreamDecoder,
    chunk: Vec<u8>,
}

/// Read chunk of [`LogReader`].
const CHUNK: usize = 1 << 16;

impl<R: Read> LogReader<R> {
    /// A reader over `inner`.
    pub fn new(inner: R) -> Self {
        Self {
            inner,
            decoder: StreamDecoder::new(),
            chunk: vec![0; CHUNK],
        }
    }
}

impl LogReader<File> {
    /// Opens a log file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, ReadError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(ReadError::io(path))?;
        Ok(Self::new(file))
    }
}

impl<R: Read> Iterator for LogReader<R> {
    type Item = io::Result<Event>;

    fn next(&mut self) -> Option<io::Result<Event>> {
        loop {
            if let Some(e) = self.decoder.next_event() {
                return Some(Ok(e));
            }
            if self.decoder.eof {
                return None;
            }
            match self.inner.read(&mut self.chunk) {
                Ok(0) => self.decoder.finish(),
                Ok(n) => self.decoder.push(&self.chunk[..n]),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

/// A whole log decoded: its CSI records and every skip, in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CsiLog {
    /// CSI records.
    pub records: Vec<CsiRecord>,
    /// Skipped byte ranges with reasons (non-CSI records included).
    pub skips: Vec<Skip>,
    /// Bytes in the log.
    pub bytes: u64,
}

impl CsiLog {
    /// Decodes a log held in memory.
    pub fn from_bytes(bytes: &[u8]) -> Self {
        let mut log = CsiLog {
            bytes: bytes.len() as u64,
            ..CsiLog::default()
        };
        for event in SliceDecoder::new(bytes) {
            match event {
                Event::Csi(r) => log.records.push(*r),
                Event::Skipped(s) => log.skips.push(s),
            }
        }
        log
    }
}

/// Failure to read a log (corrupt content is not an error: it is skipped and reported).
#[derive(Debug, Error)]
pub enum ReadError {
    /// The file could not be opened or read.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
}

impl ReadError {
    /// Wraps an I/O error on `path` (for `map_err`).
    pub fn io(path: &Path) -> impl FnOnce(io::Error) -> ReadError + '_ {
        move |source| ReadError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Reads and decodes a whole log file into memory (about 600 bytes per record; use [`LogReader`]
/// for long captures). The file must be a regular file (a device or a FIFO is refused); it is
/// decoded as it is read, so only its records are held, and skipped stretches that follow each
/// other with the same reason are merged into one (a long run of garbage is one skip).
pub fn read_log(path: impl AsRef<Path>) -> Result<CsiLog, ReadError> {
    let path = path.as_ref();
    let file = crate::io_safety::open_regular(path).map_err(ReadError::io(path))?;
    let bytes = file.metadata().map_err(ReadError::io(path))?.len();
    let mut log = CsiLog {
        bytes,
        ..CsiLog::default()
    };
    for event in LogReader::new(file) {
        match event.map_err(ReadError::io(path))? {
            Event::Csi(r) => log.records.push(*r),
            Event::Skipped(s) => match log.skips.last_mut() {
                Some(last) if last.offset + last.len == s.offset && last.reason == s.reason => {
                    last.len += s.len;
                }
                _ => log.skips.push(s),
            },
        }
    }
    Ok(log)
}
