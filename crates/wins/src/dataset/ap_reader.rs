//! One AP's log read packet by packet in the card's format (`[array] card` in `dataset.toml`):
//! an Intel 5300 log streamed record by record as [`LogReader`] frames it, any other card's
//! capture through its reader ([`read_packets`]) whole, its packets then handed out one by one.
//!
//! What a card's reader could not make a packet of is counted: records it skipped (per reason)
//! and a tail it could not read, each as one skipped stretch and in the input report's warnings.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::vec;

use super::load::DatasetError;
use crate::csi::Received;
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{Event, LogReader, ReadError, Skip};
use crate::csi::packet::{CsiPacket, read_packets};
use crate::io_safety::open_regular;

/// What the reader gives next.
// Not boxed: most packets are Intel 5300 records, and a box would cost each an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub(super) enum ApEvent {
    /// A packet.
    Packet(Received),
    /// A stretch of a 5300 log skipped, as its reader lists it.
    Skipped(Skip),
    /// At the end of another card's capture: the records its reader could not use, and its unread
    /// tail as one more.
    Lost(u64),
}

/// One AP's log, packet by packet.
#[derive(Debug)]
pub(super) enum ApReader {
    /// An Intel 5300 log, streamed.
    Intel5300 {
        reader: LogReader<File>,
        path: PathBuf,
    },
    /// Another card's capture, read whole.
    Card {
        packets: vec::IntoIter<CsiPacket>,
        /// Records not made packets, and the unread tail as one more; handed out at the end.
        lost: u64,
    },
}

impl ApReader {
    /// Opens the log at `path` written by `card`. A file that another card's tool wrote is an
    /// error naming both; `warnings` gets what another card's reader could not read.
    pub fn open(
        path: &Path,
        card: CaptureFormat,
        ap: &str,
        warnings: Option<&mut Vec<String>>,
    ) -> Result<Self, DatasetError> {
        let detected = CaptureFormat::of_path(path).map_err(ReadError::io(path))?;
        if let Some(found) = detected.filter(|f| *f != card) {
            return Err(DatasetError::Card {
                path: path.to_path_buf(),
                card,
                found,
            });
        }
        if card == CaptureFormat::Intel5300 {
            let file = open_regular(path).map_err(ReadError::io(path))?;
            return Ok(Self::Intel5300 {
                reader: LogReader::new(file),
                path: path.to_path_buf(),
            });
        }
        let (_, read) = read_packets(path, Some(card)).map_err(|source| DatasetError::Capture {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        let lost = read.skipped.values().sum::<u64>() + u64::from(read.lost.is_some());
        if let Some(w) = warnings {
            for (why, n) in &read.skipped {
                w.push(format!("AP {ap}: {n} {card} records not used: {why}"));
            }
            if let Some(tail) = &read.lost {
                w.push(format!(
                    "AP {ap}: the end of its {card} log was not read: {tail}"
                ));
            }
        }
        Ok(Self::Card {
            packets: read.packets.into_iter(),
            lost,
        })
    }
}

impl Iterator for ApReader {
    type Item = Result<ApEvent, DatasetError>;

    fn next(&mut self) -> Option<Self::Item> {
        match self {
            Self::Intel5300 { reader, path } => reader.next().map(|event| {
                Ok(match event.map_err(ReadError::io(path))? {
                    Event::Csi(record) => ApEvent::Packet(Received::Intel5300(*record)),
                    Event::Skipped(s) => ApEvent::Skipped(s),
                })
            }),
            Self::Card { packets, lost } => match packets.next() {
                Some(p) => Some(Ok(ApEvent::Packet(Received::Card(p)))),
                None => (*lost > 0).then(|| Ok(ApEvent::Lost(std::mem::take(lost)))),
            },
        }
    }
}
