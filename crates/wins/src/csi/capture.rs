//! A capture's summary as `wins csi info` prints it, in the format its first bytes say
//! ([`CaptureFormat::detect`]; a file no format recognizes is read as an Intel 5300 CSI Tool
//! log, whose reader names what it is) or the one the user names.

use std::fmt;
use std::io;
use std::path::Path;

use super::atheros::{AtherosSummary, read_atheros};
use super::feitcsi::{FeitSummary, read_feitcsi};
use super::format::CaptureFormat;
use super::intel5300::{LogSummary, ReadError, why_no_records};
use super::nexmon::{NexmonError, NexmonSummary, read_nexmon};
use super::picoscenes::{PicoSummary, read_picoscenes};

/// A capture's summary, by the format it is in.
#[derive(Clone, Debug, PartialEq)]
pub enum CaptureSummary {
    /// An Intel 5300 CSI Tool log (boxed: its summary is the largest).
    Intel5300(Box<LogSummary>),
    /// A Nexmon pcap.
    Nexmon(NexmonSummary),
    /// A FeitCSI file.
    FeitCsi(FeitSummary),
    /// A PicoScenes file.
    PicoScenes(PicoSummary),
    /// An Atheros CSI Tool log.
    Atheros(AtherosSummary),
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
    /// The summary of the capture at `path`, in `format` or else the one its first bytes say.
    pub fn of_path(path: &Path, format: Option<CaptureFormat>) -> Result<Self, CaptureError> {
        let io = |source| CaptureError::Io {
            path: path.display().to_string(),
            source,
        };
        Ok(match CaptureFormat::resolve(path, format).map_err(io)? {
            CaptureFormat::Nexmon => Self::Nexmon(NexmonSummary::of(&read_nexmon(path)?)),
            CaptureFormat::FeitCsi => {
                Self::FeitCsi(FeitSummary::of(&read_feitcsi(path).map_err(io)?))
            }
            CaptureFormat::PicoScenes => {
                Self::PicoScenes(PicoSummary::of(&read_picoscenes(path).map_err(io)?))
            }
            CaptureFormat::Atheros => {
                Self::Atheros(AtherosSummary::of(&read_atheros(path, None).map_err(io)?))
            }
            CaptureFormat::Intel5300 => Self::Intel5300(Box::new(LogSummary::from_path(path)?)),
        })
    }

    /// The key its JSON goes under beside the file's name (`summary` for an Intel 5300 log).
    pub fn json_key(&self) -> &'static str {
        match self {
            Self::Intel5300(_) => "summary",
            Self::Nexmon(_) => "nexmon",
            Self::FeitCsi(_) => "feitcsi",
            Self::PicoScenes(_) => "picoscenes",
            Self::Atheros(_) => "atheros",
        }
    }

    /// Its JSON.
    pub fn to_json(&self) -> serde_json::Result<serde_json::Value> {
        match self {
            Self::Intel5300(s) => serde_json::to_value(s.as_ref()),
            Self::Nexmon(s) => serde_json::to_value(s),
            Self::FeitCsi(s) => serde_json::to_value(s),
            Self::PicoScenes(s) => serde_json::to_value(s),
            Self::Atheros(s) => serde_json::to_value(s),
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
            Self::FeitCsi(s) if s.records == 0 => Some(format!(
                "{}: no FeitCSI records: {}",
                path.display(),
                s.tail.as_deref().unwrap_or("empty")
            )),
            Self::PicoScenes(s) if s.with_csi == 0 => Some(format!(
                "{}: no PicoScenes frame with CSI: {}",
                path.display(),
                s.tail.as_deref().unwrap_or("no CSI segment")
            )),
            Self::Atheros(s) if s.with_csi == 0 => Some(format!(
                "{}: no Atheros record with CSI: {}",
                path.display(),
                s.tail.as_deref().unwrap_or("no record holds CSI")
            )),
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
            Self::PicoScenes(s) => write!(f, "{s}"),
            Self::Atheros(s) => write!(f, "{s}"),
        }
    }
}
