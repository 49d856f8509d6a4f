//! What a run produced ([`RunOutput`]), its scoring's outcome ([`Evaluation`]) and why a
//! dataset cannot be replayed ([`ReplayError`]): the types the replay, its driver and the
//! writers of its outputs share.

use nalgebra::{Matrix3, Vector3};

use crate::dataset::DatasetError;
use crate::dataset::checks::InputReport;
use crate::eval::Metrics;
use crate::fusion::nonlinear::PhaseChange;
use crate::fusion::pose::PoseEstimate;
use crate::fusion::stats::EstimatorStats;
use crate::pipeline::{ChainReport, PacketLog, PipelineError, PipelineStats, StageTiming};
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
    /// Marginal covariance of the position in `w`, m².
    pub covariance_in_w: Matrix3<f64>,
}

/// Everything a replay produced.
#[derive(Clone, Debug)]
pub struct RunOutput {
    /// The pose of every solved frame, in time order (`converged` says which are usable).
    pub frames: Vec<PoseEstimate>,
    /// Beside `frames`: whether each is one a flight controller is sent (converged, and fresh
    /// when it was released: [`crate::pipeline::Released::is_sent`]), as `wins live` sends
    /// them. Those are the causal estimate; the converged frames also hold what was made in
    /// hindsight (the chain-offset resolution's held and flown-again frames).
    pub sent: Vec<bool>,
    /// One row per packet, in processing order.
    pub packets: Vec<PacketLog>,
    /// The APs at the end of the run (in `w` of the last frame).
    pub aps: Vec<ApEstimate>,
    /// When the window reported convergence.
    pub converged_at: Option<Timestamp>,
    /// The time of the first frame a flight controller is sent (`None`: none).
    pub first_sent: Option<Timestamp>,
    /// Packet counters.
    pub stats: PipelineStats,
    /// The estimator's counters.
    pub wins: EstimatorStats,
    /// The estimator's phases: when and why each began (empty for the paper's estimator).
    pub phases: Vec<PhaseChange>,
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
    /// What the input checks dropped, counted and found.
    pub inputs: InputReport,
    /// How much of the flight after convergence the poses cover.
    pub coverage: super::coverage::Coverage,
    /// What limits the result, in words (input problems, no calibration, a run that cannot be
    /// scored).
    pub warnings: Vec<String>,
    /// When the frames and packet rows were written as they came ([`super::spool::Spool`]):
    /// what the run keeps of them (`frames` and `packets` are then empty).
    pub spooled: Option<super::spooled::Spooled>,
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

    /// The frames a flight controller is sent ([`RunOutput::sent`]).
    pub fn sent_frames(&self) -> impl Iterator<Item = &PoseEstimate> {
        self.frames
            .iter()
            .zip(&self.sent)
            .filter(|(_, sent)| **sent)
            .map(|(f, _)| f)
    }
}
