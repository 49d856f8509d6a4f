//! Which card's tool wrote a capture, told from its first bytes (a pcap: Nexmon; a FeitCSI
//! record header: an AX200/AX210; anything else is read as an Intel 5300 CSI Tool log), and its
//! summary as `wins csi info` prints it.

use std::fmt;
use std::io::{self, Read};
use std::path::Path;

use super::feitcsi::{FeitSummary, looks_like_feitcsi, read_feitcsi};
use super::intel5300::{LogSummary, ReadError, why_no_records};
use super::nexmon::pcap::looks_like_pcap;
use super::nexmon::{NexmonError, NexmonSummary, read_nexmon};

/// Bytes read to tell the format.
const HEAD_BYTES: u64 = 1 << 16;

/// A capture's summary, by the format it is in.
#[derive(Clone, Debug, PartialEq)]
pub enum CaptureSummary {
    /// An Intel 5300 CSI Tool log (boxed: its summary is the largest).
    Intel5300(Box<LogSummary>),
    /// A Nexmon pcap.
    Nexmon(NexmonSummary),
    /// A FeitCSI file.
    FeitCsi(FeitSummary),
}

/// Why a capture cannot be summarized.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The file cannot be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: io::Error,
    },
    /// The Intel 5300 reader failed.
    #[error(transparent)]
    Intel5300(#[from] ReadError),
    /// The Nexmon reader failed.
    #[error(transparent)]
    Nexmon(#[from] NexmonError),
}

impl CaptureSummary {
    /// The summary of the capture at `path`, in the format its first bytes say (module doc).
    pub fn of_path(path: &Path) -> Result<Self, CaptureError> {
        let io = |source| CaptureError::Io {
            path: path.display().to_string(),
            source,
        };
        let mut head = Vec::new();
        crate::io_safety::open_regular(path)
            .and_then(|f| f.take(HEAD_BYTES).read_to_end(&mut head))
            .map_err(io)?;
        if looks_like_pcap(&head) {
            return Ok(Self::Nexmon(NexmonSummary::of(&read_nexmon(path)?)));
        }
        if looks_like_feitcsi(&head) {
            return Ok(Self::FeitCsi(FeitSummary::of(
                &read_feitcsi(path).map_err(io)?,
            )));
        }
        Ok(Self::Intel5300(Box::new(LogSummary::from_path(path)?)))
    }

    /// The key its JSON goes under beside the file's name (`summary` for an Intel 5300 log).
    pub fn json_key(&self) -> &'static str {
        match self {
            Self::Intel5300(_) => "summary",
            Self::Nexmon(_) => "nexmon",
            Self::FeitCsi(_) => "feitcsi",
        }
    }

    /// Its JSON.
    pub fn to_json(&self) -> serde_json::Result<serde_json::Value> {
        match self {
            Self::Intel5300(s) => serde_json::to_value(s.as_ref()),
            Self::Nexmon(s) => serde_json::to_value(s),
            Self::FeitCsi(s) => serde_json::to_value(s),
        }
    }

    /// Why the capture at `path` gave nothing to read, when it did not.
    pub fn why_empty(&self, path: &Path) -> Option<String> {
        match self {
            Self::Intel5300(s) if s.csi_records == 0 => Some(format!(
                "{}: no CSI records: {}",
                path.display(),
                why_no_records(path)
            )),
            Self::Nexmon(s) if s.packets == 0 => {
                Some(format!("{}: no Nexmon CSI packets", path.display()))
            }
            _ => None,
        }
    }
}

impl fmt::Display for CaptureSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Intel5300(s) => write!(f, "{s}"),
            Self::Nexmon(s) => write!(f, "{s}"),
            Self::FeitCsi(s) => write!(f, "{s}"),
        }
    }
}
