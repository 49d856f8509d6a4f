//! Which card's tool wrote a capture, told from its first bytes or named by the user.

use std::fmt;
use std::io::{self, Read};
use std::path::Path;
use std::str::FromStr;

use super::atheros::looks_like_atheros;
use super::feitcsi::looks_like_feitcsi;
use super::intel5300::looks_like_csi_tool;
use super::nexmon::pcap::looks_like_pcap;
use super::picoscenes::looks_like_picoscenes;

/// Bytes read to tell the format.
pub const HEAD_BYTES: u64 = 1 << 16;

/// A CSI capture format.
/// In files (`dataset.toml`, JSON) by its [`CaptureFormat::name`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CaptureFormat {
    /// The Linux 802.11n CSI Tool's log (Intel 5300).
    #[default]
    Intel5300,
    /// A pcap of nexmon_csi's UDP packets (Broadcom).
    Nexmon,
    /// FeitCSI's file (Intel AX200/AX210).
    FeitCsi,
    /// A PicoScenes `.csi` file.
    PicoScenes,
    /// The Atheros CSI Tool's log (ath9k).
    Atheros,
}

impl CaptureFormat {
    /// Every format, in the order they are told apart.
    pub const ALL: [Self; 5] = [
        Self::Nexmon,
        Self::PicoScenes,
        Self::FeitCsi,
        Self::Intel5300,
        Self::Atheros,
    ];

    /// Its name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Intel5300 => "intel5300",
            Self::Nexmon => "nexmon",
            Self::FeitCsi => "feitcsi",
            Self::PicoScenes => "picoscenes",
            Self::Atheros => "atheros",
        }
    }

    /// The tool and card, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Intel5300 => "an Intel 5300 CSI Tool log",
            Self::Nexmon => "a Nexmon pcap (Broadcom)",
            Self::FeitCsi => "a FeitCSI file (Intel AX200/AX210)",
            Self::PicoScenes => "a PicoScenes file",
            Self::Atheros => "an Atheros CSI Tool log (ath9k)",
        }
    }

    /// The format `head`, a file's first bytes, is in: the first of [`CaptureFormat::ALL`] whose
    /// first record parses and agrees with itself (`None`: none does).
    pub fn detect(head: &[u8]) -> Option<Self> {
        Self::ALL.into_iter().find(|f| match f {
            Self::Nexmon => looks_like_pcap(head),
            Self::PicoScenes => looks_like_picoscenes(head),
            Self::FeitCsi => looks_like_feitcsi(head),
            Self::Intel5300 => looks_like_csi_tool(head),
            Self::Atheros => looks_like_atheros(head),
        })
    }

    /// The format of `file` when it is a capture of another card than the Intel 5300
    /// (`forced`, else told from its first bytes): the captures the packet path takes. `None`
    /// for an Intel 5300 log, a file no format recognizes, and a folder (a dataset).
    pub fn other_card(file: &Path, forced: Option<Self>) -> Option<Self> {
        let format = match forced {
            Some(f) => Some(f),
            None if file.is_file() => Self::of_path(file).ok().flatten(),
            None => None,
        };
        format.filter(|f| *f != Self::Intel5300)
    }

    /// `forced`, else the format the file at `path` is told to be, else (none recognized) an
    /// Intel 5300 log, whose reader names what the file is.
    pub fn resolve(path: &Path, forced: Option<Self>) -> io::Result<Self> {
        match forced {
            Some(f) => Ok(f),
            None => Ok(Self::of_path(path)?.unwrap_or(Self::Intel5300)),
        }
    }

    /// [`CaptureFormat::detect`] on the file at `path`.
    pub fn of_path(path: &Path) -> io::Result<Option<Self>> {
        let mut head = Vec::new();
        crate::io_safety::open_regular(path)?
            .take(HEAD_BYTES)
            .read_to_end(&mut head)?;
        Ok(Self::detect(&head))
    }
}

impl fmt::Display for CaptureFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for CaptureFormat {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for CaptureFormat {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

impl FromStr for CaptureFormat {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|f| f.name()).collect();
                format!("unknown CSI format {s:?}: one of {}", names.join(", "))
            })
    }
}
