//! A dataset directory through the pipeline (a [`ChainResolver`] over [`super::Pipeline`]s): IMU
//! samples and every AP's packets merged by time (a packet before the IMU samples after it), as a
//! live driver would push them.

use std::time::Instant;

use nalgebra::Vector3;

use super::figure_data::RunFigures;
use super::{
    ChainReport, ChainResolver, Config, PacketLog, PipelineError, PipelineStats, StageTiming,
};
use crate::dataset::Dataset;
use crate::dataset::checks::InputReport;
use crate::dataset::truth::Truth;
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
        let scored = self
            .score(truth, options)
            .and_then(|m| Ok((self.figures(truth, &m, options)?, m)));
        match scored {
            Ok((figures, metrics)) => {
                self.metrics = Some(metrics);
                self.figures = Some(figures);
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
    let m = &dataset.manifest;
    Ok(Rig {
        geometry: m.array.geometry,
        body_from_array: m.array.body_from_array(),
        center_freq_hz: m.channel.center_freq_hz,
        calibration: calibration.or_else(|| dataset.calibration.clone()),
        imu_noise: imu_noise
            .or_else(|| m.imu.noise.clone())
            .ok_or(ReplayError::NoImuNoise)?,
        ap_names: m.aps.iter().map(|a| a.name.clone()).collect(),
    })
}

/// Replays `dataset` through a pipeline for `rig`.
pub fn replay(dataset: &Dataset, rig: Rig, config: &Config) -> Result<RunOutput, ReplayError> {
    let (Some(first), Some(last)) = (dataset.imu.first(), dataset.imu.last()) else {
        return Err(ReplayError::NoImu);
    };
    let flight_s = last.t.secs_since(first.t);
    let started = Instant::now();
    let mut warnings = dataset.inputs.warnings.clone();
    let baro = if config.pipeline.use_barometer || dataset.baro.is_empty() {
        &dataset.baro[..]
    } else {
        warnings.push(format!(
            "the barometer's {} samples were not used (pipeline.use_barometer = false)",
            dataset.baro.len()
        ));
        &[][..]
    };
    let mut pipeline = ChainResolver::new(config, rig, !baro.is_empty())?;
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
    let mut frames = Vec::new();
    let mut packets = Vec::new();
    let mut imu_refused = 0;
    let mut keep = |r: super::Released| {
        frames.extend(r.frames);
        packets.extend(r.packets);
        imu_refused += r.imu_refused;
    };
    for (_, kind, l, i) in events {
        if kind == 0 {
            let p = &dataset.aps[l].packets[i];
            keep(pipeline.push_csi(l, p.t, &p.record)?);
        } else if kind == 1 {
            keep(pipeline.push_baro(baro[i].t, baro[i].altitude_m)?);
        } else {
            keep(pipeline.push_imu(&dataset.imu[i])?);
        }
    }
    let done = pipeline.finish()?;
    keep(done.released);
    let wins = done.pipeline.wins();
    let aps = done
        .pipeline
        .rig()
        .ap_names
        .iter()
        .enumerate()
        .filter_map(|(l, name)| {
            let (p_in_w, sigma_m) = wins.ap_in_w(l)?;
            Some(ApEstimate {
                name: name.clone(),
                p_in_w,
                sigma_m,
            })
        })
        .collect();
    Ok(RunOutput {
        frames,
        packets,
        aps,
        converged_at: wins.converged_at(),
        stats: {
            let mut stats = done.pipeline.stats().clone();
            for (s, ap) in stats.per_ap.iter_mut().zip(&dataset.aps) {
                s.log_skips = ap.skips.len() as u64;
                s.log_skipped_bytes = ap.skips.iter().map(|k| k.len).sum();
            }
            stats
        },
        wins: wins.stats(),
        timing: done.timing,
        chains: done.report,
        wall_s: started.elapsed().as_secs_f64(),
        flight_s,
        imu_refused,
        metrics: None,
        evaluation: Evaluation::NoTruth,
        figures: None,
        inputs: dataset.inputs.clone(),
        warnings,
    })
}
