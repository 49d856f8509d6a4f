//! The settings of the chain resolution and what it reports.

use serde::{Deserialize, Serialize};

use super::super::{Config, PacketLog, Pipeline, StageTiming};
use crate::check::Problems;
use crate::fusion::choice::EstimatorKind;
use crate::fusion::pose::PoseEstimate;
use crate::rig::ArrayGeometry;

/// Settings of the in-flight resolution of the chain offsets (`[pipeline.chains]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChainOffsetsConfig {
    /// Resolve the offsets from the flight (three-antenna arrays, the nonlinear estimator);
    /// `false` uses the stored calibration (or none) as it is.
    pub resolve: bool,
    /// Packets (all APs) over which the curvature is measured before the hypotheses start.
    pub curvature_packets: usize,
    /// A hypothesis converged this long is compared with the others and the best kept, s.
    pub decide_after_s: f64,
    /// The same without a stored calibration, s: each hypothesis refines its step with the
    /// trajectory (the bearings' common offset, [`crate::fusion::nonlinear`]) and needs longer
    /// (measured: 5 s kept hypotheses that converged early on a wrong step).
    pub decide_after_uncalibrated_s: f64,
    /// A hypothesis converged while no other is must have been converged this long (in total)
    /// before it is kept, s.
    pub decide_alone_after_s: f64,
    /// Hypotheses of the uniform step without a stored calibration (evenly around the circle).
    pub uncalibrated_hypotheses: usize,
    /// The curvature keeps being measured over every packet of the flight (the motion averages
    /// the reflections out, which a drone at rest on the ground does not); every this many
    /// packets it is applied again when it moved.
    pub curvature_refresh_packets: usize,
    /// Without a stored calibration, the kept step (refined by its window) is flown again from
    /// the start of the flight when the decision comes within this flight time, s (the inputs
    /// are kept until then); 0 turns the second pass off.
    pub second_pass_max_s: f64,
    /// The prior σ of the bearings' common `sin θ` offset in the second pass.
    pub second_pass_sin_bias_sigma: f64,
}

impl Default for ChainOffsetsConfig {
    fn default() -> Self {
        Self {
            resolve: true,
            curvature_packets: 200,
            decide_after_s: 5.0,
            decide_after_uncalibrated_s: 15.0,
            decide_alone_after_s: 10.0,
            uncalibrated_hypotheses: 8,
            curvature_refresh_packets: 250,
            second_pass_max_s: 120.0,
            second_pass_sin_bias_sigma: 0.03,
        }
    }
}

impl ChainOffsetsConfig {
    /// Every setting in its range, under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.require(
            (1..=100_000).contains(&self.curvature_packets),
            prefix,
            "curvature_packets",
            format!("{} is not in [1, 100000]", self.curvature_packets),
        );
        p.in_range(prefix, "decide_after_s", self.decide_after_s, 0.0, 600.0);
        p.in_range(
            prefix,
            "decide_after_uncalibrated_s",
            self.decide_after_uncalibrated_s,
            0.0,
            600.0,
        );
        p.in_range(
            prefix,
            "decide_alone_after_s",
            self.decide_alone_after_s,
            0.0,
            600.0,
        );
        p.require(
            (1..=1_000_000).contains(&self.curvature_refresh_packets),
            prefix,
            "curvature_refresh_packets",
            format!("{} is not in [1, 1000000]", self.curvature_refresh_packets),
        );
        p.in_range(
            prefix,
            "second_pass_max_s",
            self.second_pass_max_s,
            0.0,
            600.0,
        );
        p.in_range(
            prefix,
            "second_pass_sin_bias_sigma",
            self.second_pass_sin_bias_sigma,
            0.0,
            2.0,
        );
        p.require(
            (1..=36).contains(&self.uncalibrated_hypotheses),
            prefix,
            "uncalibrated_hypotheses",
            format!(
                "{} is not in [1, 36] (each runs a pipeline until the decision)",
                self.uncalibrated_hypotheses
            ),
        );
        p
    }
}

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
}

/// Whether the offsets are resolved from the flight for `config` on an array `geometry`: asked
/// for, three antennas, and the nonlinear estimator (the paper's tests its fit only when it
/// declares convergence: it converged on π aliases and fitted them better than the truth, so it
/// cannot choose).
pub fn resolves(config: &Config, geometry: ArrayGeometry) -> bool {
    config.pipeline.chains.resolve
        && geometry.num_antennas == 3
        && config.estimator == EstimatorKind::Nonlinear
}
