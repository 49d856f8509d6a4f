//! A dataset directory through the pipeline (a [`super::ChainResolver`] over [`super::Pipeline`]s): IMU
//! samples and every AP's packets merged by time (a packet before the IMU samples after it), as a
//! live driver would push them.

use nalgebra::Vector3;

use super::drive::{Collected, Flight, RunSink, drive};
use super::figure_data::RunFigures;
use super::{ChainReport, Config, PacketLog, PipelineError, PipelineStats, StageTiming};
use crate::dataset::checks::InputReport;
use crate::dataset::stream::{DatasetEvent, DatasetStream};
use crate::dataset::truth::Truth;
use crate::dataset::{BaroSample, Dataset, DatasetError, Manifest};
use crate::eval::{EvalOptions, Metrics};
use crate::fusion::estimator::{PoseEstimate, WinsStats};
use crate::rig::ChainCalibration;
use crate::rig::ImuNoise;
use crate::rig::Rig;
use crate::time::Timestamp;

/// Why a dataset cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The manifest has no IMU noise and none was given.
    #[error("the dataset states no IMU noise densities (dataset.toml [imu.noise]); give them")]
    NoImuNoise,
    /// No IMU samples.
    #[error("the dataset has no IMU samples")]
    NoImu,
    /// The pipeline cannot be built.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The dataset could not be read as it was replayed.
    #[error(transparent)]
    Dataset(#[from] Box<DatasetError>),
    /// The frames or packet rows could not be written as they were produced.
    #[error("writing the run's output: {0}")]
    Output(#[from] std::io::Error),
}

/// An estimated AP position.
#[derive(Clone, Debug, PartialEq)]
pub struct ApEstimate {
    /// The AP's name.
    pub name: String,
    /// Position in the estimator's world frame `w`, m.
    pub p_in_w: Vector3<f64>,
    /// Largest standard deviation of the position, m.
    pub sigma_m: f64,
}

/// Everything a replay produced.
#[derive(Clone, Debug)]
pub struct RunOutput {
    /// The pose of every solved frame, in time order (`converged` says which are usable).
    pub frames: Vec<PoseEstimate>,
    /// One row per packet, in processing order.
    pub packets: Vec<PacketLog>,
    /// The APs at the end of the run (in `w` of the last frame).
    pub aps: Vec<ApEstimate>,
    /// When the window reported convergence.
    pub converged_at: Option<Timestamp>,
    /// Packet counters.
    pub stats: PipelineStats,
    /// The estimator's counters.
    pub wins: WinsStats,
    /// Wall time per stage, s (over every chain-offset hypothesis run).
    pub timing: StageTiming,
    /// How the receive chains' offsets were resolved from the flight.
    pub chains: ChainReport,
    /// Wall time of the whole replay, s.
    pub wall_s: f64,
    /// Flight time replayed (first to last IMU sample), s.
    pub flight_s: f64,
    /// IMU samples the estimator refused (non-finite, out of order).
    pub imu_refused: u64,
    /// The run scored against the dataset's truth (`None`: no truth, or it could not be scored;
    /// then `warnings` and `evaluation` say why).
    pub metrics: Option<Metrics>,
    /// What became of the scoring against the truth.
    pub evaluation: Evaluation,
    /// The figures' data against the truth, with `metrics`.
    pub figures: Option<RunFigures>,
    /// What the input checks dropped, counted and found.
    pub inputs: InputReport,
    /// What limits the result, in words (input problems, no calibration, a run that cannot be
    /// scored).
    pub warnings: Vec<String>,
    /// When the frames and packet rows were written as they came ([`super::spool::Spool`]):
    /// what the run keeps of them (`frames` and `packets` are then empty).
    pub spooled: Option<super::spool::Spooled>,
}

/// What became of a run's scoring against its dataset's truth.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Evaluation {
    /// The dataset has no `truth/` folder (or the run was not scored).
    #[default]
    NoTruth,
    /// Scored: [`RunOutput::metrics`] holds the metrics.
    Scored,
    /// The truth was read but the run cannot be scored (it never converged, say): why.
    NotScored(String),
    /// The truth cannot be read (a malformed `truth/poses.tum`, say): why, naming the file.
    Failed(String),
}

impl std::fmt::Display for Evaluation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoTruth => write!(f, "no truth"),
            Self::Scored => write!(f, "ok"),
            Self::NotScored(why) => write!(f, "not scored: {why}"),
            Self::Failed(why) => write!(f, "failed: {why}"),
        }
    }
}

impl RunOutput {
    /// Flight time over wall time.
    pub fn realtime_factor(&self) -> f64 {
        self.flight_s / self.wall_s.max(1e-12)
    }

    /// Frames after convergence.
    pub fn converged_frames(&self) -> impl Iterator<Item = &PoseEstimate> {
        self.frames.iter().filter(|p| p.converged)
    }

    /// Scores the run against `truth` ([`RunOutput::score`]) and keeps the metrics and the
    /// figures' data; when it cannot be scored (it never converged, say), says why in
    /// `warnings` and `evaluation`.
    pub fn score_against(&mut self, truth: &Truth, options: &EvalOptions) {
        self.score_against_with(truth, options, true);
    }

    /// [`RunOutput::score_against`], the figures' data made only when `figures` is true.
    pub fn score_against_with(&mut self, truth: &Truth, options: &EvalOptions, figures: bool) {
        let scored = self.score(truth, options).and_then(|m| {
            let f = figures
                .then(|| self.figures(truth, &m, options))
                .transpose()?;
            Ok((f, m))
        });
        match scored {
            Ok((figures, metrics)) => {
                self.metrics = Some(metrics);
                self.figures = figures;
                self.evaluation = Evaluation::Scored;
            }
            Err(e) => {
                self.warnings.push(format!("cannot score the run: {e}"));
                self.evaluation = Evaluation::NotScored(e.to_string());
            }
        }
    }
}

/// The rig of a dataset: its manifest, with the IMU noise and calibration overridable.
pub fn rig_of(
    dataset: &Dataset,
    imu_noise: Option<ImuNoise>,
    calibration: Option<ChainCalibration>,
) -> Result<Rig, ReplayError> {
    rig_of_manifest(
        &dataset.manifest,
        dataset.calibration.as_ref(),
        imu_noise,
        calibration,
    )
}

/// The rig of a manifest and its calibration, with the IMU noise and calibration overridable.
pub fn rig_of_manifest(
    m: &Manifest,
    own_calibration: Option<&ChainCalibration>,
    imu_noise: Option<ImuNoise>,
    calibration: Option<ChainCalibration>,
) -> Result<Rig, ReplayError> {
    Ok(Rig {
        geometry: m.array.geometry,
        body_from_array: m.array.body_from_array(),
        center_freq_hz: m.channel.center_freq_hz,
        calibration: calibration.or_else(|| own_calibration.cloned()),
        imu_noise: imu_noise
            .or_else(|| m.imu.noise.clone())
            .ok_or(ReplayError::NoImuNoise)?,
        ap_names: m.aps.iter().map(|a| a.name.clone()).collect(),
    })
}

/// Replays `dataset` (in memory) through a pipeline for `rig`; the frames and packet rows are
/// kept in the output.
pub fn replay(dataset: &Dataset, rig: Rig, config: &Config) -> Result<RunOutput, ReplayError> {
    let (Some(first), Some(last)) = (dataset.imu.first(), dataset.imu.last()) else {
        return Err(ReplayError::NoImu);
    };
    let (baro, mut warnings) = baro_in_use(&dataset.baro, &dataset.inputs, config);
    // (time, 0 = packet / 1 = barometer / 2 = IMU, AP, index): packets and barometer samples
    // before IMU samples at the same time.
    let mut events: Vec<(Timestamp, u8, usize, usize)> = dataset
        .imu
        .iter()
        .enumerate()
        .map(|(i, s)| (s.t, 2, 0, i))
        .collect();
    events.extend(baro.iter().enumerate().map(|(i, b)| (b.t, 1, 0, i)));
    for (l, ap) in dataset.aps.iter().enumerate() {
        events.extend(ap.packets.iter().enumerate().map(|(i, p)| (p.t, 0, l, i)));
    }
    events.sort_unstable();
    let mut events = events.into_iter();
    let mut sink = Collected::default();
    let skips: Vec<(u64, u64)> = dataset
        .aps
        .iter()
        .map(|ap| (ap.skips.len() as u64, ap.skips.iter().map(|k| k.len).sum()))
        .collect();
    let flight = Flight {
        flight_s: last.t.secs_since(first.t),
        has_baro: !baro.is_empty(),
        inputs: &dataset.inputs,
    };
    let mut run = drive(config, rig, &flight, &mut sink, |pipeline| {
        let Some((_, kind, l, i)) = events.next() else {
            return Ok(None);
        };
        Ok(Some(if kind == 0 {
            let p = &dataset.aps[l].packets[i];
            pipeline.push_csi(l, p.t, &p.record)?
        } else if kind == 1 {
            pipeline.push_baro(baro[i].t, baro[i].altitude_m)?
        } else {
            pipeline.push_imu(&dataset.imu[i])?
        }))
    })?;
    set_skips(&mut run, &skips);
    run.frames = sink.frames;
    run.packets = sink.packets;
    warnings.append(&mut run.warnings);
    run.warnings = warnings;
    Ok(run)
}

/// Replays a checked dataset read as it is consumed ([`DatasetStream`]) through a pipeline for
/// `rig`: the frames and packet rows go to `sink` as they are produced (the output's `frames`
/// and `packets` stay empty).
pub fn replay_stream(
    stream: &DatasetStream,
    rig: Rig,
    config: &Config,
    sink: &mut dyn RunSink,
) -> Result<RunOutput, ReplayError> {
    let (first, last) = stream.imu_span;
    let (baro, mut warnings) = baro_in_use(&stream.baro, &stream.inputs, config);
    let mut events = stream.events(!baro.is_empty()).map_err(Box::new)?;
    let flight = Flight {
        flight_s: last.secs_since(first),
        has_baro: !baro.is_empty(),
        inputs: &stream.inputs,
    };
    let mut run = drive(config, rig, &flight, sink, |pipeline| {
        Ok(match events.next_event().map_err(Box::new)? {
            None => None,
            Some(DatasetEvent::Csi { ap, packet }) => {
                Some(pipeline.push_csi(ap, packet.t, &packet.record)?)
            }
            Some(DatasetEvent::Baro(b)) => Some(pipeline.push_baro(b.t, b.altitude_m)?),
            Some(DatasetEvent::Imu(s)) => Some(pipeline.push_imu(&s)?),
        })
    })?;
    set_skips(&mut run, &events.skips());
    warnings.append(&mut run.warnings);
    run.warnings = warnings;
    Ok(run)
}

/// The barometer's samples the run uses, and the input checks' warnings (with one more when the
/// settings leave the barometer out).
fn baro_in_use<'a>(
    baro: &'a [BaroSample],
    inputs: &InputReport,
    config: &Config,
) -> (&'a [BaroSample], Vec<String>) {
    let mut warnings = inputs.warnings.clone();
    if config.pipeline.use_barometer || baro.is_empty() {
        return (baro, warnings);
    }
    warnings.push(format!(
        "the barometer's {} samples were not used (pipeline.use_barometer = false)",
        baro.len()
    ));
    (&[], warnings)
}

/// Every AP's log skips `(stretches, bytes)` into the run's statistics.
fn set_skips(run: &mut RunOutput, skips: &[(u64, u64)]) {
    for (s, &(count, bytes)) in run.stats.per_ap.iter_mut().zip(skips) {
        s.log_skips = count;
        s.log_skipped_bytes = bytes;
    }
}
