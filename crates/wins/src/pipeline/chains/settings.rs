//! The settings of the chain resolution and what it reports.

use serde::Serialize;

use super::super::{PacketLog, Pipeline, StageTiming};
use crate::config::Config;
use crate::csi::format::CaptureFormat;
use crate::fusion::choice::EstimatorKind;
use crate::fusion::pose::PoseEstimate;
use crate::rig::Rig;
use crate::time::Timestamp;

/// What the resolution did (in `stats.json` as `chain_offsets`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ChainReport {
    /// Whether the offsets were resolved from the flight (else the calibration was used as is).
    pub resolved: bool,
    /// Whether a stored calibration was the prior.
    pub had_calibration: bool,
    /// Packets the curvature was measured on.
    pub curvature_packets: usize,
    /// The measured curvature `φ₀ − 2φ₁ + φ₂`, degrees.
    pub curvature_measured_deg: Option<f64>,
    /// Agreement of the packets' curvature phasors in [0, 1].
    pub curvature_agreement: f64,
    /// The change of the curvature applied to match it, degrees.
    pub curvature_applied_deg: f64,
    /// Times the curvature was applied again during the flight (it moved as the flight went on).
    pub curvature_updates: usize,
    /// The uniform steps tried, degrees.
    pub hypotheses_deg: Vec<f64>,
    /// With a prior, the change of chain 2's offset each hypothesis makes (a restart's step: the
    /// measured curvature's nearest and the next), degrees, beside `hypotheses_deg`.
    pub hypotheses_curvature_deg: Vec<f64>,
    /// The step kept, degrees (`None` while undecided).
    pub chosen_deg: Option<f64>,
    /// The change of chain 2's offset kept, degrees.
    pub chosen_curvature_deg: Option<f64>,
    /// Flight time of the decision, s from the first IMU sample.
    pub decided_at_s: Option<f64>,
    /// Each hypothesis's robust cost per bearing at the decision (`None`: not converged).
    pub scores: Vec<Option<f64>>,
    /// The calibration the kept pipeline used.
    pub phase_offsets_rad: Vec<f64>,
    /// The bearings' common `sin θ` offset the window estimated at the end and its σ
    /// ([`crate::fusion::nonlinear::NonlinearConfig::sin_bias_sigma`]).
    pub sin_bias: Option<(f64, f64)>,
    /// Whether the kept step, refined by its window, was flown again from the start.
    pub second_pass: bool,
    /// The uniform step in the kept pipeline's calibration (`phase_offsets_rad`): the chosen
    /// one, or after a second pass the chosen one refined by its window, degrees.
    pub flown_deg: Option<f64>,
    /// The flown step refined by that offset (`Δφ = 2π·β·d/λ`), degrees.
    pub refined_deg: Option<f64>,
}

/// The end of a run ([`super::ChainResolver::finish`]).
#[derive(Debug)]
pub struct Finished {
    /// The pipeline kept.
    pub pipeline: Pipeline,
    /// What it still held.
    pub released: Released,
    /// What the resolution did.
    pub report: ChainReport,
    /// Wall time per stage over every hypothesis run.
    pub timing: StageTiming,
}

/// How old a frame may be, behind the newest IMU sample pushed when it is released, to be sent
/// to a flight controller, ns: the frames the chain-offset resolution holds come out in a burst
/// once it decides, and a flight controller has no use for the old ones.
pub const FRESH_NS: i64 = 250_000_000;

/// What a push released: the winner's frames and packet rows (held until the decision), and
/// IMU samples the estimator refused.
#[derive(Clone, Debug, Default)]
pub struct Released {
    /// Solved frames, in time order.
    pub frames: Vec<PoseEstimate>,
    /// Packet log rows.
    pub packets: Vec<PacketLog>,
    /// IMU samples refused.
    pub imu_refused: u64,
    /// The newest IMU sample pushed when these were released.
    pub newest_imu: Option<Timestamp>,
}

impl Released {
    /// Whether `frame` (one of `frames`) is fresh: at most [`FRESH_NS`] behind the newest IMU
    /// sample pushed when it was released.
    pub fn is_fresh(&self, frame: &PoseEstimate) -> bool {
        self.newest_imu
            .is_some_and(|t| t.as_nanos().saturating_sub(frame.t.as_nanos()) <= FRESH_NS)
    }

    /// Whether `frame` (one of `frames`) is what a flight controller is sent: converged and
    /// fresh. The poses sent are the causal estimate: each made from the inputs before it and
    /// sent as it was made.
    pub fn is_sent(&self, frame: &PoseEstimate) -> bool {
        frame.converged && self.is_fresh(frame)
    }
}

/// Whether the offsets are resolved from the flight for `config` on `rig`: asked for, an Intel
/// 5300 (its restart steps are the model of how a calibration goes wrong) or another card without
/// a calibration (the uniform steps around the circle, on the curvature measured over its own
/// subcarriers; another card's calibration is applied as it is), three antennas, and the
/// nonlinear estimator (the paper's tests its fit only when it
/// declares convergence: it converged on π aliases and fitted them better than the truth, so it
/// cannot choose).
pub fn resolves(config: &Config, rig: &Rig) -> bool {
    config.pipeline.chains.resolve
        && (rig.card == CaptureFormat::Intel5300 || rig.calibration.is_none())
        && rig.geometry.num_antennas == 3
        && config.estimator == EstimatorKind::Nonlinear
}
