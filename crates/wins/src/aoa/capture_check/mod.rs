//! Is a capture usable for angle of arrival? `wins csi check` reads an Intel 5300 CSI Tool log
//! and answers, before any flight, with a verdict in words and what to do for each thing that
//! decides it: the file itself, the antennas, the signal, the chains' phases (stable, or
//! jumping), the chains against a stored calibration, bandwidth and channel, the packets' rate
//! and gaps, and clipping (docs/DATASET.md, "Checking a capture").
//!
//! The measurements stream over the log (`measure`), so a long capture takes bounded memory
//! except for two phases per packet; a file that is not a CSI Tool log is named for what it is
//! (`crate::csi::intel5300::identify`), and the verdicts' thresholds are in `verdicts`.

mod cards;
mod measure;
mod phases;
#[cfg(test)]
mod tests;
mod verdicts;

use std::fmt;
use std::path::Path;

use serde::Serialize;

use crate::csi::intel5300::{Event, LogReader, LogSummary, ReadError};
use crate::rig::ChainCalibration;

pub use cards::{CardCheck, check_card};

pub use crate::csi::intel5300::{Identified, identify, identify_bytes};

/// Interquartile range of the phases between two chains about the value most packets share, on
/// the quarter-turn grid the 5300's steps fall on, rad (0 when empty).
pub(crate) fn phase_iqr_rad(angles: &[f64]) -> f64 {
    measure::spread(angles).map_or(0.0, |s| s.iqr_rad)
}

/// How a finding bears on AoA.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Fine for AoA.
    Good,
    /// Not measurable from this capture (or not given); says what would tell.
    Unknown,
    /// Usable, with a caveat the advice explains.
    Warning,
    /// AoA from this capture will be wrong or impossible until the advice is followed.
    Bad,
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Good => "good",
            Self::Unknown => "unknown",
            Self::Warning => "warning",
            Self::Bad => "bad",
        })
    }
}

/// One thing checked.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Finding {
    /// What was checked (`"antennas"`).
    pub topic: &'static str,
    /// Its verdict.
    pub verdict: Verdict,
    /// What was measured, in words with the numbers.
    pub measured: String,
    /// What to do about it (`None` when nothing needs doing).
    pub advice: Option<String>,
}

/// What the check needs beyond the log.
#[derive(Clone, Debug, Default)]
pub struct CheckOptions {
    /// The channel's centre frequency, Hz, when known (a CSI Tool log does not record it; it
    /// sets the chains' restart step, π at 5 GHz and π/2 at 2.4 GHz). `None`: 5 GHz assumed.
    pub center_freq_hz: Option<f64>,
    /// A stored calibration to check the chains against.
    pub calibration: Option<ChainCalibration>,
}

/// The check of one capture.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CaptureCheck {
    /// Every finding, in the order a user would fix them.
    pub findings: Vec<Finding>,
    /// The log's summary (`wins csi info`).
    pub summary: LogSummary,
}

impl CaptureCheck {
    /// The worst verdict of the findings that could be measured ([`Verdict::Unknown`] when none
    /// could); a capture is usable for AoA unless it is [`Verdict::Bad`].
    pub fn verdict(&self) -> Verdict {
        overall(&self.findings)
    }
}

impl fmt::Display for CaptureCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_findings(f, &self.findings)
    }
}

/// The worst verdict of the findings that could be measured ([`Verdict::Unknown`] when none
/// could).
fn overall(findings: &[Finding]) -> Verdict {
    findings
        .iter()
        .map(|f| f.verdict)
        .filter(|v| *v != Verdict::Unknown)
        .max()
        .unwrap_or(Verdict::Unknown)
}

/// The findings, one line each with its advice under it, and the overall verdict.
fn write_findings(f: &mut fmt::Formatter<'_>, findings: &[Finding]) -> fmt::Result {
    for finding in findings {
        writeln!(
            f,
            "{:<22} {:<8} {}",
            finding.topic, finding.verdict, finding.measured
        )?;
        if let Some(advice) = &finding.advice {
            writeln!(f, "{:<31} → {advice}", "")?;
        }
    }
    let verdict = overall(findings);
    let words = match verdict {
        Verdict::Bad => "not usable for AoA as it is (see the findings marked bad)",
        Verdict::Warning => "usable for AoA, with the warnings above",
        Verdict::Good | Verdict::Unknown => "usable for AoA",
    };
    writeln!(f, "{:<22} {:<8} {words}", "verdict", verdict)
}

/// Checks the log at `path`. Errors: the file cannot be opened or read (a file that opens but is
/// not a CSI Tool log is a finding, not an error).
pub fn check_capture(path: &Path, options: &CheckOptions) -> Result<CaptureCheck, ReadError> {
    let mut summary = LogSummary::new();
    let mut measured = measure::Measurements::default();
    for event in LogReader::open(path)? {
        let event = event.map_err(ReadError::io(path))?;
        if let Event::Csi(r) = &event {
            measured.add(r);
        }
        summary.add(&event);
    }
    let identified = if summary.csi_records == 0 || summary.lost_bytes > 0 {
        identify(path).map_err(ReadError::io(path))?
    } else {
        None
    };
    let findings = verdicts::findings(&summary, &measured, identified.as_ref(), options);
    Ok(CaptureCheck { findings, summary })
}

/// The check of a capture of any card.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Checked {
    /// An Intel 5300 CSI Tool log (or a file no format recognizes).
    Intel5300(Box<CaptureCheck>),
    /// Another card's capture.
    Card(CardCheck),
}

impl Checked {
    /// The worst verdict of the findings that could be measured.
    pub fn verdict(&self) -> Verdict {
        match self {
            Self::Intel5300(c) => c.verdict(),
            Self::Card(c) => c.verdict(),
        }
    }
}

impl fmt::Display for Checked {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Intel5300(c) => write!(f, "{c}"),
            Self::Card(c) => write!(f, "{c}"),
        }
    }
}

/// Why a capture cannot be checked at all.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The Intel 5300 log cannot be read.
    #[error(transparent)]
    Intel5300(#[from] ReadError),
    /// Another card's capture cannot be read.
    #[error(transparent)]
    Card(#[from] crate::csi::capture::CaptureError),
}

/// Checks the capture at `path`: another card's from its packets ([`check_card`]) when it is
/// one (`forced`, else told from its first bytes), else as an Intel 5300 log
/// ([`check_capture`]).
pub fn check_any(
    path: &Path,
    forced: Option<crate::csi::format::CaptureFormat>,
    options: &CheckOptions,
) -> Result<Checked, CheckError> {
    Ok(
        match crate::csi::format::CaptureFormat::other_card(path, forced) {
            Some(format) => Checked::Card(check_card(path, format)?),
            None => Checked::Intel5300(Box::new(check_capture(path, options)?)),
        },
    )
}

/// A finding.
fn finding(
    topic: &'static str,
    verdict: Verdict,
    measured: String,
    advice: Option<String>,
) -> Finding {
    Finding {
        topic,
        verdict,
        measured,
        advice,
    }
}

/// A share as a percentage with one decimal.
fn pct(share: f64) -> String {
    format!("{:.1} %", 100.0 * share)
}
