//! The `[pipeline]` section of the configuration tree: the settings of the real-time pipeline
//! ([`crate::pipeline::Pipeline`]) between the AoA stage and the estimator, and its
//! `[pipeline.chains]` table, the in-flight resolution of the receive chains' offsets
//! ([`crate::pipeline::chains`]). They live here, not with the pipeline, because the pipeline is
//! built from the whole tree ([`super::Config`]).

use serde::{Deserialize, Serialize};

use crate::aoa::spotfi::MIN_GROUP_SIZE;
use crate::check::Problems;

/// Settings of the pipeline between the AoA stage and the estimator: per-AP tracks (SpotFi start,
/// PAoA gates) and the bearings handed to the window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// Packets of an AP whose SpotFi direct path starts its track (paper: 10).
    pub init_packets: usize,
    /// Standard deviation given to every accepted bearing, degrees. PAoA's errors on the
    /// simulated multipath are heavy-tailed (median 1.7°, 90th percentile 5.5°): 2° made the
    /// window declare convergence too early and diverge; 3° does not.
    pub bearing_sigma_deg: f64,
    /// Frame grid, ms: bearings are grouped into frames this far apart (0: every packet is a
    /// frame). 20 ms keeps one AP's 50 packets/s one per frame.
    pub frame_period_ms: f64,
    /// Consecutive packets without a credible peak after which an AP's track starts over.
    pub max_misses: usize,
    /// After convergence, bearings further than this from the state's prediction are dropped,
    /// degrees.
    pub gate_deg: f64,
    /// The state gate in σ instead of degrees (0: off, `gate_deg` applies): a bearing is dropped
    /// when `|sin θ − s_pred|` exceeds this many σ of the bearing (`bearing_sigma_deg` through
    /// the cone model) and of the state's prediction combined, `σ_pred` from the window's joint
    /// covariance of the newest pose, the AP and the bearings' common offset
    /// ([`crate::fusion::nonlinear::NonlinearWindow::predicted_sin`]; 0 for the paper's window).
    pub gate_sigmas: f64,
    /// After this many gated packets in a row of one AP the next is fed anyway (the state, not
    /// the AoA, is then the suspect).
    pub max_gated_in_row: usize,
    /// Packets further than this from the track's own prediction (the last track angle turned
    /// by the gyro) are dropped as jumps to another path, degrees.
    pub track_gate_deg: f64,
    /// After this many packets off the track in a row, the track starts over from SpotFi.
    pub max_off_track_in_row: usize,
    /// An AP silent for longer than this (an outage), s: its track starts over from SpotFi,
    /// and the state's gate is not applied to it until one of its bearings falls within the
    /// gate (the state was dead reckoned across the silence).
    pub max_silence_s: f64,
    /// How far the track follows each accepted angle (1: to the raw angle, the paper's
    /// Algorithm 1; smaller: a first-order filter against multipath jitter).
    pub track_gain: f64,
    /// Before convergence, how fast the track learns the rate of change of its angle not due
    /// to the turns: the share of the innovation the rate takes per second, 1/s (0: no rate, a
    /// first-order filter that trails a moving AP, the more the slower the packets come).
    pub track_rate_gain_hz: f64,
    /// Before convergence the state cannot tell front from back: assume front (the paper's
    /// set-up), flagged in the packet log. `false` drops bearings until convergence, which
    /// never comes with one AP.
    pub assume_front_until_converged: bool,
    /// Use the dataset's barometer (`baro.csv`) when it has one; `false` runs on the cone model
    /// alone (the barometer's samples are counted in the run's warnings).
    pub use_barometer: bool,
    /// The receive chains' offsets resolved from the flight ([`crate::pipeline::chains`]).
    pub chains: ChainOffsetsConfig,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            init_packets: 10,
            bearing_sigma_deg: 3.0,
            frame_period_ms: 20.0,
            max_misses: 25,
            gate_deg: 5.0,
            gate_sigmas: 0.0,
            max_gated_in_row: 10,
            track_gate_deg: 10.0,
            max_off_track_in_row: 10,
            max_silence_s: 1.0,
            track_gain: 0.3,
            track_rate_gain_hz: 0.5,
            assume_front_until_converged: true,
            use_barometer: true,
            chains: ChainOffsetsConfig::default(),
        }
    }
}

impl PipelineConfig {
    /// Every setting in its range, under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.require(
            (MIN_GROUP_SIZE..=1000).contains(&self.init_packets),
            prefix,
            "init_packets",
            format!(
                "{} is not in [{MIN_GROUP_SIZE}, 1000] (SpotFi needs two packets)",
                self.init_packets
            ),
        );
        p.in_range(
            prefix,
            "bearing_sigma_deg",
            self.bearing_sigma_deg,
            0.01,
            90.0,
        );
        p.in_range(prefix, "frame_period_ms", self.frame_period_ms, 0.0, 1000.0);
        p.at_least(prefix, "max_misses", self.max_misses, 1);
        p.in_range(prefix, "gate_deg", self.gate_deg, 0.01, 180.0);
        p.in_range(prefix, "gate_sigmas", self.gate_sigmas, 0.0, 100.0);
        p.in_range(prefix, "track_gate_deg", self.track_gate_deg, 0.01, 180.0);
        p.at_least(prefix, "max_off_track_in_row", self.max_off_track_in_row, 1);
        p.in_range(prefix, "max_silence_s", self.max_silence_s, 0.001, 1e9);
        p.require(
            self.track_gain > 0.0 && self.track_gain <= 1.0,
            prefix,
            "track_gain",
            format!("{} is not in (0, 1]", self.track_gain),
        );
        p.in_range(
            prefix,
            "track_rate_gain_hz",
            self.track_rate_gain_hz,
            0.0,
            20.0,
        );
        p.extend(self.chains.problems(&format!("{prefix}.chains")));
        p
    }
}

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
