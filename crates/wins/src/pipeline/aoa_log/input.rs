//! The input of a per-packet AoA run (`wins aoa`, `wins calibrate`, Python's `wins.aoa`): an
//! Intel 5300 log with its channel and array, or one AP of a dataset folder (whose
//! `dataset.toml` gives both), with the `[aoa]` settings; and the run itself
//! ([`AoaInput::estimate`]): the chains' curvature matched on the records, then every record's
//! AoA ([`super::estimate_log`]).

use std::path::PathBuf;

use super::{AoaLogError, AoaLogSummary, AoaMode, PacketAoa, estimate_log, match_chain_curvature};
use crate::aoa::estimator::{AoaError, AoaEstimator};
use crate::aoa::{AoaConfig, Correction};
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{CsiLog, CsiRecord, ReadError, Skip, read_log, why_no_records};
use crate::dataset::{Dataset, DatasetError};
use crate::rig::array::{CHANNEL_64_HZ, half_wavelength_m};
use crate::rig::channel::wifi_channel_hz;
use crate::rig::{ArrayGeometry, ChainCalibration};

/// The warning of a log's AoA without a calibration.
pub const UNCALIBRATED: &str = "uncalibrated chains: the curvature is measured from the log, but \
     the uniform phase step between chains is not, so angles are offset on real hardware";

/// What to read: a log (with its channel and array, defaults channel 64 and half a wavelength)
/// or a dataset folder (with the AP's name; the channel and array are the dataset's).
#[derive(Clone, Debug, Default)]
pub struct AoaSpec {
    /// The `.dat` log, or a dataset folder.
    pub file: PathBuf,
    /// The AP of a dataset folder.
    pub ap: Option<String>,
    /// A log's Wi-Fi channel (1–14, 32–177).
    pub channel: Option<u32>,
    /// A log's channel centre frequency, Hz (instead of `channel`).
    pub center_freq_hz: Option<f64>,
    /// A log's antenna spacing, m.
    pub spacing_m: Option<f64>,
    /// The `[aoa]` settings.
    pub config: AoaConfig,
}

/// Why the input cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum AoaInputError {
    /// The options do not fit the input.
    #[error("{0}")]
    Options(String),
    /// The log holds no CSI record (what it is instead, when recognized).
    #[error("{0}")]
    NoRecords(String),
    /// The log cannot be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The dataset cannot be loaded.
    #[error(transparent)]
    Dataset(#[from] Box<DatasetError>),
    /// The estimator cannot be set up.
    #[error(transparent)]
    Aoa(#[from] AoaError),
    /// The records cannot be processed.
    #[error(transparent)]
    Log(#[from] AoaLogError),
    /// No calibration came out of the packets.
    #[error(transparent)]
    Calibrate(#[from] crate::aoa::CalibrateError),
}

/// Where the records are.
#[derive(Debug)]
pub enum AoaSource {
    /// A log file, read whole.
    Log(CsiLog),
    /// A dataset and the index of its AP.
    Dataset {
        /// The dataset.
        dataset: Box<Dataset>,
        /// The AP.
        ap: usize,
    },
}

/// An opened input (module doc).
#[derive(Debug)]
pub struct AoaInput {
    /// The records' source.
    pub source: AoaSource,
    /// The array.
    pub geometry: ArrayGeometry,
    /// The carrier, Hz.
    pub center_freq_hz: f64,
    /// The settings.
    pub config: AoaConfig,
}

/// What an AoA run gives ([`AoaInput::estimate`]).
#[derive(Debug)]
pub struct AoaOutcome {
    /// One row per record, in order.
    pub rows: Vec<PacketAoa>,
    /// The counts.
    pub summary: AoaLogSummary,
    /// The chains' curvature measured on the records and what was applied.
    pub correction: Correction,
    /// The estimator as it ran (its calibration corrected), e.g. to draw a spectrum.
    pub estimator: AoaEstimator,
    /// The array's angle ambiguity, in words, when its antennas are further apart than half a
    /// wavelength.
    pub ambiguity: Option<String>,
}

impl AoaInput {
    /// Opens `spec` (module doc). Errors: options that do not fit the input (a channel for a
    /// dataset, no AP for a dataset, an unknown AP), an unreadable log or dataset, a log with
    /// no CSI record, an array that cannot be used on the carrier.
    pub fn open(spec: &AoaSpec) -> Result<Self, AoaInputError> {
        let options = |s: String| AoaInputError::Options(s);
        let file = spec.file.as_path();
        if !file.is_dir() {
            if spec.ap.is_some() {
                return Err(options(format!(
                    "an AP is for a dataset directory, {} is a file",
                    file.display()
                )));
            }
            let center_freq_hz = match (spec.channel, spec.center_freq_hz) {
                (Some(n), _) => wifi_channel_hz(n).ok_or_else(|| {
                    options(format!(
                        "channel {n} is not a Wi-Fi channel (1–14 at 2.4 GHz, 32–177 at 5 GHz)"
                    ))
                })?,
                (None, f) => f.unwrap_or(CHANNEL_64_HZ),
            };
            let geometry = ArrayGeometry {
                spacing_m: spec
                    .spacing_m
                    .unwrap_or_else(|| half_wavelength_m(center_freq_hz)),
                ..ArrayGeometry::default()
            };
            geometry.validate(center_freq_hz).map_err(|e| {
                options(format!(
                    "the array (its antenna spacing) cannot be used on this carrier: {e}"
                ))
            })?;
            let log = read_log(file)?;
            if log.records.is_empty() {
                return Err(AoaInputError::NoRecords(format!(
                    "{}: no CSI records ({} bytes): {}",
                    file.display(),
                    log.bytes,
                    why_no_records(file)
                )));
            }
            return Ok(Self {
                source: AoaSource::Log(log),
                geometry,
                center_freq_hz,
                config: spec.config.clone(),
            });
        }
        if spec.center_freq_hz.is_some() || spec.channel.is_some() || spec.spacing_m.is_some() {
            return Err(options(
                "the channel, the centre frequency and the spacing come from the dataset's \
                 dataset.toml"
                    .into(),
            ));
        }
        let dataset = Dataset::load(file).map_err(Box::new)?;
        let card = dataset.manifest.array.card;
        if card != CaptureFormat::Intel5300 {
            return Err(options(format!(
                "{} is a dataset of {card} logs: run wins aoa on an AP's log itself \
                 (wins aoa LOG --csi-format {card} --channel N)",
                file.display()
            )));
        }
        let names: Vec<&str> = dataset.aps.iter().map(|a| a.name.as_str()).collect();
        let Some(name) = &spec.ap else {
            return Err(options(format!(
                "{} is a dataset: name its AP ({})",
                file.display(),
                names.join(", ")
            )));
        };
        let ap = names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| AoaLogError::UnknownAp {
                ap: name.clone(),
                known: names.join(", "),
            })?;
        Ok(Self {
            geometry: dataset.manifest.array.geometry,
            center_freq_hz: dataset.manifest.channel.center_freq_hz,
            source: AoaSource::Dataset {
                dataset: Box::new(dataset),
                ap,
            },
            config: spec.config.clone(),
        })
    }

    /// The CSI records, in order.
    pub fn records(&self) -> Vec<&CsiRecord> {
        match &self.source {
            AoaSource::Log(log) => log.records.iter().collect(),
            AoaSource::Dataset { dataset, ap } => dataset
                .aps
                .get(*ap)
                .map(|a| {
                    a.packets
                        .iter()
                        .filter_map(|p| p.record.intel5300())
                        .collect()
                })
                .unwrap_or_default(),
        }
    }

    /// The stretches the log reader skipped (non-CSI records among them).
    pub fn skips(&self) -> &[Skip] {
        match &self.source {
            AoaSource::Log(log) => &log.skips,
            AoaSource::Dataset { dataset, ap } => {
                dataset.aps.get(*ap).map_or(&[], |a| a.skips.as_slice())
            }
        }
    }

    /// Every record's AoA with `calibration` (none: the chains' curvature is measured on the
    /// records, their uniform step is not), each packet's direct path chosen by `mode`.
    pub fn estimate(
        &self,
        calibration: Option<ChainCalibration>,
        mode: AoaMode,
    ) -> Result<AoaOutcome, AoaInputError> {
        let has_prior = calibration.is_some();
        let mut estimator = AoaEstimator::new(
            &self.config,
            self.geometry,
            self.center_freq_hz,
            calibration,
        )?;
        let ambiguity = estimator.ambiguity().map(|a| a.to_string());
        let records = self.records();
        let correction = match_chain_curvature(records.iter().copied(), &mut estimator, has_prior)?;
        let (rows, summary) = estimate_log(records.iter().copied(), &estimator, mode)?;
        Ok(AoaOutcome {
            rows,
            summary,
            correction,
            estimator,
            ambiguity,
        })
    }
}
