//! The receive chains' phase offsets resolved from the flight itself ([`ChainResolver`]): a
//! stored calibration is a prior, not a requirement.
//!
//! An Intel 5300 draws new chain offsets at every start: each chain moves by a multiple of π at
//! 5 GHz (π/2 at 2.4 GHz, [`crate::aoa::restart_step_rad`]), so a calibration made before the flight can be
//! off by those steps. Over a three-antenna array the offsets have two parts
//! ([`crate::aoa::ChainCurvature`]):
//!
//! 1. the *curvature* `φ₀ − 2φ₁ + φ₂`, which any capture reveals: measured over the first
//!    [`ChainOffsetsConfig::curvature_packets`] packets (all APs pooled; the inputs wait in a
//!    queue meanwhile);
//! 2. the *uniform step* `s` (chain `m` moved by `m·s`), which shifts every angle and which no
//!    single packet can reveal.
//!
//! Each hypothesis runs as its own [`Pipeline`], side by side on the same inputs: with a prior,
//! the multiples of the restart step for the uniform step (2 at 5 GHz, 4 at 2.4 GHz) times two
//! restart steps on chain 2, the measured curvature's nearest and the next (at rest on the
//! ground, reflections biased the measurement by more than 90°); without a prior,
//! [`ChainOffsetsConfig::uncalibrated_hypotheses`] uniform steps around the circle on the
//! measured curvature (re-measured as the flight goes on), each refined by the window (the
//! bearings' common `sin θ` offset, a state of the nonlinear window with a prior σ of half the
//! hypotheses' spacing). The hypothesis whose bearings the IMU's motion explains wins: once a
//! converged one has been converged for [`ChainOffsetsConfig::decide_after_s`] in total
//! ([`ChainOffsetsConfig::decide_alone_after_s`] while no other is), the converged one whose
//! window explains its bearings best ([`Estimator::bearing_misfit`]) is kept and the others are
//! dropped. A wrong
//! step puts every bearing at an alias (`sin θ ± 1` for π), which a trajectory explains only
//! while the AP stays on one side of broadside: such hypotheses rarely converge, and less well.
//!
//! Until the decision nothing is released: the frames and packet rows of every hypothesis are
//! held, and the winner's are released at once. Without a prior the kept step, refined by its
//! window's common offset, is first flown again from the start of the flight
//! ([`ChainOffsetsConfig::second_pass_max_s`]; the inputs are kept until the decision): the
//! hypotheses' early windows were pulled by steps up to half their spacing off, and the second
//! pass converges as early as a calibrated run. A flight that ends undecided keeps the
//! hypothesis converged longest, else the prior's.
//!
//! Only with the nonlinear estimator: the paper's tests its fit only when it declares convergence,
//! and it converged on π aliases, fitting them better than the right step; with it the
//! calibration is applied as it is.

mod decide;
mod inputs;
mod second_pass;
mod settings;

use self::inputs::{Input, append, feed};
use self::second_pass::History;

pub use self::settings::{ChainReport, FRESH_NS, Finished, Released, resolves};
use super::{Pipeline, PipelineError, StageTiming};
use crate::aoa::{AoaEstimator, ChainCurvature, received_csi};
#[cfg(doc)]
use crate::config::ChainOffsetsConfig;
use crate::config::Config;
use crate::csi::Received;
#[cfg(doc)]
use crate::fusion::choice::Estimator;
use crate::imu::ImuSample;
use crate::rig::{ChainCalibration, Rig};
use crate::time::Timestamp;

struct Candidate {
    pipeline: Pipeline,
    /// Change of chain 2's offset from the prior (a restart step; 0 without a prior, whose
    /// curvature is in the base).
    curvature_rad: f64,
    step_rad: f64,
    held: Released,
    /// Whether it is converged (and fits its bearings) now.
    converged: bool,
    /// Flight time it has been converged so far, s (restarts do not reset it).
    converged_s: f64,
}

enum Stage {
    Measuring { queue: Vec<Input>, packets: usize },
    Testing(Vec<Candidate>),
    Decided(Box<Pipeline>),
}

/// What the estimate is doing, for a status line ([`ChainResolver::state`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "stage", rename_all = "snake_case")]
pub enum EstimateState {
    /// Nothing estimated yet: before the pipeline is built, or while the chains' curvature is
    /// measured.
    #[default]
    Starting,
    /// The chains' offsets are being decided: `converged` of the `hypotheses` have converged;
    /// their poses are held until one is kept.
    Deciding {
        /// Hypotheses converged now.
        converged: usize,
        /// Hypotheses flown.
        hypotheses: usize,
    },
    /// The offsets are decided; whether the estimate is converged now.
    Tracking {
        /// Converged now (not lost).
        converged: bool,
    },
}

/// A [`Pipeline`] whose chain offsets are resolved from the flight (module doc). Same push API;
/// each push returns what it released.
pub struct ChainResolver {
    config: Config,
    rig: Rig,
    has_baro: bool,
    prior: ChainCalibration,
    /// The curvature over every packet so far.
    curvature: ChainCurvature,
    /// The prior with the curvature applied (each hypothesis adds its uniform step).
    base: ChainCalibration,
    stage: Stage,
    report: ChainReport,
    first_imu: Option<Timestamp>,
    last_imu: Option<Timestamp>,
    /// The newest IMU sample pushed (what [`Released::is_fresh`] measures against).
    newest_imu: Option<Timestamp>,
    dropped_timing: StageTiming,
    /// Every input since the start, kept until the decision to fly the kept step again from the
    /// start (without a prior; `None` once longer than [`ChainOffsetsConfig::second_pass_max_s`]).
    history: Option<History>,
    /// The uniform step of the kept pipeline, rad.
    step_rad: f64,
}

impl std::fmt::Debug for ChainResolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ChainResolver")
            .field("report", &self.report)
            .finish_non_exhaustive()
    }
}

impl ChainResolver {
    /// A resolver for `rig` (its calibration, if any, is the prior). With resolution off, or an
    /// array that is not three antennas, one pipeline on the rig's calibration as it is.
    pub fn new(config: &Config, rig: Rig, has_baro: bool) -> Result<Self, PipelineError> {
        config.validate()?;
        let prior = AoaEstimator::new(
            &config.aoa,
            rig.geometry,
            rig.center_freq_hz,
            rig.calibration.clone(),
        )?
        .calibration()
        .clone();
        let resolve = resolves(config, &rig);
        let had_calibration = rig.calibration.is_some();
        let report = ChainReport {
            resolved: resolve,
            had_calibration,
            ..ChainReport::default()
        };
        let stage = if resolve {
            Stage::Measuring {
                queue: Vec::new(),
                packets: 0,
            }
        } else {
            Stage::Decided(Box::new(Pipeline::with_baro(
                config,
                rig.clone(),
                has_baro,
            )?))
        };
        Ok(Self {
            config: config.clone(),
            rig,
            has_baro,
            base: prior.clone(),
            prior,
            curvature: ChainCurvature::default(),
            stage,
            report,
            first_imu: None,
            last_imu: None,
            newest_imu: None,
            dropped_timing: StageTiming::default(),
            history: History::new(resolve && !had_calibration, &config.pipeline.chains),
            step_rad: 0.0,
        })
    }

    /// What the resolution did so far.
    pub fn report(&self) -> &ChainReport {
        &self.report
    }

    /// The kept pipeline's estimator statistics, once the offsets are decided (`None` before:
    /// nothing is released then).
    pub fn decided_stats(&self) -> Option<crate::fusion::stats::EstimatorStats> {
        match &self.stage {
            Stage::Decided(p) => Some(p.wins().stats()),
            _ => None,
        }
    }

    /// AP `l`'s position in the world and its σ, m, as the kept pipeline has it now (`None`
    /// before the decision, or while it has not placed the AP).
    pub fn decided_ap_in_w(&self, l: usize) -> Option<crate::fusion::pose::ApInWorld> {
        match &self.stage {
            Stage::Decided(p) => p.wins().ap_in_w(l),
            _ => None,
        }
    }

    /// What the estimate is doing now.
    pub fn state(&self) -> EstimateState {
        match &self.stage {
            Stage::Measuring { .. } => EstimateState::Starting,
            Stage::Testing(c) => EstimateState::Deciding {
                converged: c.iter().filter(|c| c.converged).count(),
                hypotheses: c.len(),
            },
            Stage::Decided(p) => EstimateState::Tracking {
                converged: p.wins().is_converged(),
            },
        }
    }

    /// APs of the rig.
    pub fn ap_count(&self) -> usize {
        self.rig.ap_names.len()
    }

    /// Integrates one IMU sample ([`Pipeline::push_imu`]).
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Released, PipelineError> {
        self.first_imu.get_or_insert(s.t);
        self.newest_imu = Some(self.newest_imu.map_or(s.t, |t| t.max(s.t)));
        let released = self.remember(Input::Imu(*s));
        self.stamped(released)
    }

    /// `released`, with the newest IMU sample pushed.
    fn stamped(
        &self,
        released: Result<Released, PipelineError>,
    ) -> Result<Released, PipelineError> {
        released.map(|r| Released {
            newest_imu: self.newest_imu,
            ..r
        })
    }

    /// Queues a barometer altitude ([`Pipeline::push_baro`]); a refused one is counted there.
    pub fn push_baro(&mut self, t: Timestamp, altitude_m: f64) -> Result<Released, PipelineError> {
        let released = self.remember(Input::Baro(t, altitude_m));
        self.stamped(released)
    }

    /// Processes one packet ([`Pipeline::push_csi`]).
    pub fn push_csi(
        &mut self,
        ap: usize,
        t: Timestamp,
        record: &Received,
    ) -> Result<Released, PipelineError> {
        // The curvature: with a prior measured once, to rank the restart steps; without one
        // measured over the whole flight and applied again as it moves.
        let measuring = matches!(self.stage, Stage::Measuring { .. });
        if self.report.resolved
            && (measuring || !self.report.had_calibration)
            && let Some(csi) = self.chain_rows(record)
            && self.curvature.push(&csi, 3)
            && !measuring
            && self
                .curvature
                .packets
                .is_multiple_of(self.config.pipeline.chains.curvature_refresh_packets)
        {
            self.refresh_curvature()?;
        }
        if let Stage::Decided(p) = &mut self.stage {
            return Ok(Released {
                packets: vec![p.push_csi(ap, t, record)],
                ..Released::default()
            });
        }
        if let Stage::Measuring { packets, .. } = &mut self.stage {
            *packets += 1;
        }
        let released = self.remember(Input::Csi(ap, t, Box::new(record.clone())));
        self.stamped(released)
    }

    /// A packet's CSI of the configured stream per antenna, as the chains received it (the
    /// 5300's receiver response divided out when configured), for the curvature.
    fn chain_rows(&self, record: &Received) -> Option<Vec<num_complex::Complex64>> {
        let tx = self.config.aoa.tx;
        match record {
            Received::Intel5300(r) => {
                received_csi(r, tx, 3, self.config.aoa.remove_receiver_response).ok()
            }
            Received::Card(p) => p.antenna_rows(tx).filter(|_| p.num_rx() == 3),
        }
    }

    /// Keeps `input` for the second pass ([`History`]) and forwards it.
    fn remember(&mut self, input: Input) -> Result<Released, PipelineError> {
        if !matches!(self.stage, Stage::Decided(_)) {
            History::keep(&mut self.history, &input, self.first_imu);
        }
        self.forward(input)
    }

    /// Runs every pipeline's keyframe solve that is due ([`Pipeline::solve_pending`]).
    pub fn solve_pending(&mut self) {
        match &mut self.stage {
            Stage::Measuring { .. } => {}
            Stage::Testing(candidates) => {
                for c in candidates {
                    c.pipeline.solve_pending();
                }
            }
            Stage::Decided(p) => p.solve_pending(),
        }
    }

    /// The end of the inputs: starts the hypotheses if the curvature was still being measured,
    /// decides among them if they are still side by side (the one converged longest, else the
    /// prior's), and hands over the kept pipeline with what it still held.
    pub fn finish(mut self) -> Result<Finished, PipelineError> {
        self.solve_pending();
        let mut released = Released::default();
        if matches!(self.stage, Stage::Measuring { .. }) {
            released = self.start_hypotheses()?;
        }
        if let Stage::Testing(candidates) = &self.stage {
            let pick = candidates
                .iter()
                .enumerate()
                .max_by(|a, b| {
                    a.1.converged_s
                        .total_cmp(&b.1.converged_s)
                        .then(b.0.cmp(&a.0))
                })
                .map_or(0, |(i, _)| i);
            append(&mut released, self.decide(pick, None)?);
        }
        let timing = self.timing();
        if let Stage::Decided(p) = &self.stage {
            self.report.phase_offsets_rad = p.chain_calibration().phase_offsets_rad.clone();
            self.report.sin_bias = p.wins().sin_bias();
            let flown = self.step_rad;
            let refined = self.refined(flown, self.report.sin_bias.map_or(0.0, |(b, _)| b));
            self.report.flown_deg = self.report.chosen_deg.map(|_| flown.to_degrees());
            self.report.refined_deg = self.report.chosen_deg.map(|_| refined.to_degrees());
        }
        released.newest_imu = self.newest_imu;
        match self.stage {
            Stage::Decided(pipeline) => Ok(Finished {
                pipeline: *pipeline,
                released,
                report: self.report,
                timing,
            }),
            _ => Err(PipelineError::NoHypothesis),
        }
    }

    fn forward(&mut self, input: Input) -> Result<Released, PipelineError> {
        match &mut self.stage {
            Stage::Measuring { queue, packets, .. } => {
                let ready = *packets >= self.config.pipeline.chains.curvature_packets;
                queue.push(input);
                if ready {
                    return self.start_hypotheses();
                }
                Ok(Released::default())
            }
            Stage::Testing(candidates) => {
                for c in candidates.iter_mut() {
                    let r = feed(&mut c.pipeline, &input);
                    append(&mut c.held, r);
                }
                self.maybe_decide(&input)
            }
            Stage::Decided(p) => Ok(feed(p, &input)),
        }
    }

    /// Wall time per stage over every hypothesis run.
    pub fn timing(&self) -> StageTiming {
        let mut t = self.dropped_timing;
        match &self.stage {
            Stage::Measuring { .. } => {}
            Stage::Testing(c) => c.iter().for_each(|c| t += c.pipeline.timing()),
            Stage::Decided(p) => t += p.timing(),
        }
        t
    }
}

/// The curvature is applied again when it moved by more than this, rad (1°).
const CURVATURE_TOLERANCE_RAD: f64 = 0.017_453_292_519_943_295;

#[cfg(test)]
mod tests;
