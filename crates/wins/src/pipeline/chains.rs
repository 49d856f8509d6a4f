//! The receive chains' phase offsets resolved from the flight itself ([`ChainResolver`]): a
//! stored calibration is a prior, not a requirement.
//!
//! An Intel 5300 draws new chain offsets at every start: each chain moves by a multiple of π at
//! 5 GHz (π/2 at 2.4 GHz, [`restart_step_rad`]), so a calibration made before the flight can be
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

use std::f64::consts::TAU;

mod inputs;
mod second_pass;
mod settings;

use self::inputs::{Input, append, feed};
use self::second_pass::{History, fly_again, with_curvature, with_step};

pub use self::settings::{ChainReport, Finished, Released, resolves};
use super::{Pipeline, PipelineError, StageTiming};
use crate::aoa::{AoaEstimator, ChainCurvature, Correction, raw_csi, restart_step_rad};
#[cfg(doc)]
use crate::config::ChainOffsetsConfig;
use crate::config::Config;
use crate::csi::intel5300::CsiRecord;
use crate::csi::sanitize::wrap;
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
        let resolve = resolves(config, rig.geometry);
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

    /// Integrates one IMU sample ([`Pipeline::push_imu`]).
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Released, PipelineError> {
        self.first_imu.get_or_insert(s.t);
        self.remember(Input::Imu(*s))
    }

    /// Queues a barometer altitude ([`Pipeline::push_baro`]); a refused one is counted there.
    pub fn push_baro(&mut self, t: Timestamp, altitude_m: f64) -> Result<Released, PipelineError> {
        self.remember(Input::Baro(t, altitude_m))
    }

    /// Processes one packet ([`Pipeline::push_csi`]).
    pub fn push_csi(
        &mut self,
        ap: usize,
        t: Timestamp,
        record: &CsiRecord,
    ) -> Result<Released, PipelineError> {
        // The curvature: with a prior measured once, to rank the restart steps; without one
        // measured over the whole flight and applied again as it moves.
        let measuring = matches!(self.stage, Stage::Measuring { .. });
        if self.report.resolved
            && (measuring || !self.report.had_calibration)
            && let Ok(csi) = raw_csi(record, self.config.aoa.tx, 3)
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
        self.remember(Input::Csi(ap, t, Box::new(record.clone())))
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

    /// Applies the measured curvature to the prior and starts one pipeline per step.
    fn start_hypotheses(&mut self) -> Result<Released, PipelineError> {
        let Stage::Measuring { queue, .. } =
            std::mem::replace(&mut self.stage, Stage::Testing(Vec::new()))
        else {
            return Ok(Released::default());
        };
        let has_prior = self.report.had_calibration;
        let correction = self.measure_curvature();
        // With a prior the measured curvature only ranks the restart's steps on chain 2: the
        // nearest and the next are both tried (at rest, reflections biased it by more than 90°).
        let curvatures = if has_prior {
            let step = restart_step_rad(self.rig.center_freq_hz);
            let nearest = correction.applied_rad;
            let change = correction
                .measured_rad
                .zip(correction.prior_rad)
                .map_or(0.0, |(m, p)| wrap(m - p));
            let side = if wrap(change - nearest) >= 0.0 {
                step
            } else {
                -step
            };
            // The prior's own curvature first (the fallback of a flight that ends undecided).
            let mut options = vec![nearest, wrap(nearest + side)];
            options.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
            options
        } else {
            self.base = correction.calibration;
            vec![0.0]
        };
        let n = if has_prior {
            (TAU / restart_step_rad(self.rig.center_freq_hz)).round() as usize
        } else {
            self.config.pipeline.chains.uncalibrated_hypotheses
        };
        let n = n.max(1);
        // The window refines the step around each hypothesis: its prior σ (as the bearings'
        // common sin θ offset) spans half the spacing between hypotheses without a calibration.
        let mut config = self.config.clone();
        if !has_prior {
            // A phase step Δφ moves sin θ by Δφ/2π·λ/d.
            let period = self.rig.geometry.alias_period(self.rig.center_freq_hz);
            let half_spacing = period / (2 * n) as f64;
            config.nonlinear.sin_bias_sigma = config.nonlinear.sin_bias_sigma.max(half_spacing);
        }
        let mut candidates = Vec::with_capacity(n * curvatures.len());
        for &curvature_rad in &curvatures {
            for k in 0..n {
                let step_rad = wrap(k as f64 * TAU / n as f64);
                let mut rig = self.rig.clone();
                rig.calibration = Some(with_step(
                    &with_curvature(&self.base, curvature_rad),
                    step_rad,
                ));
                candidates.push(Candidate {
                    pipeline: Pipeline::with_baro(&config, rig, self.has_baro)?,
                    curvature_rad,
                    step_rad,
                    held: Released::default(),
                    converged: false,
                    converged_s: 0.0,
                });
            }
        }
        self.report.hypotheses_deg = candidates.iter().map(|c| c.step_rad.to_degrees()).collect();
        self.report.hypotheses_curvature_deg = candidates
            .iter()
            .map(|c| c.curvature_rad.to_degrees())
            .collect();
        self.stage = Stage::Testing(candidates);
        let mut out = Released::default();
        for input in queue {
            append(&mut out, self.forward(input)?);
        }
        Ok(out)
    }

    /// The prior corrected by the curvature measured so far (recorded in the report).
    fn measure_curvature(&mut self) -> Correction {
        let step = restart_step_rad(self.rig.center_freq_hz);
        let correction = self
            .curvature
            .corrected(&self.prior, step, self.report.had_calibration);
        self.report.curvature_packets = self.curvature.packets;
        self.report.curvature_measured_deg = correction.measured_rad.map(f64::to_degrees);
        self.report.curvature_agreement = self.curvature.agreement();
        self.report.curvature_applied_deg = correction.applied_rad.to_degrees();
        correction
    }

    /// Applies the curvature measured so far to every pipeline running, when it moved by more
    /// than [`CURVATURE_TOLERANCE_RAD`].
    fn refresh_curvature(&mut self) -> Result<(), PipelineError> {
        let base = self.measure_curvature().calibration;
        let moved = base
            .phase_offsets_rad
            .iter()
            .zip(&self.base.phase_offsets_rad)
            .any(|(a, b)| wrap(a - b).abs() > CURVATURE_TOLERANCE_RAD);
        if !moved {
            return Ok(());
        }
        self.base = base;
        self.report.curvature_updates += 1;
        let apply = |p: &mut Pipeline, step_rad: f64| {
            p.set_chain_calibration(with_step(&self.base, step_rad))
        };
        match &mut self.stage {
            Stage::Measuring { .. } => {}
            Stage::Testing(candidates) => {
                for c in candidates.iter_mut() {
                    apply(&mut c.pipeline, c.step_rad)?;
                }
            }
            Stage::Decided(p) => {
                apply(p, self.step_rad)?;
            }
        }
        Ok(())
    }

    /// After an IMU sample: the decision, once one hypothesis has been converged long enough.
    fn maybe_decide(&mut self, input: &Input) -> Result<Released, PipelineError> {
        let Input::Imu(s) = input else {
            return Ok(Released::default());
        };
        let Stage::Testing(candidates) = &mut self.stage else {
            return Ok(Released::default());
        };
        let dt_s = self.last_imu.map_or(0.0, |t| s.t.secs_since(t).max(0.0));
        self.last_imu = Some(s.t);
        for c in candidates.iter_mut() {
            c.converged = c.pipeline.wins().is_converged();
            if c.converged {
                c.converged_s += dt_s;
            }
        }
        let chains = &self.config.pipeline.chains;
        let after_s = if self.report.had_calibration {
            chains.decide_after_s
        } else {
            chains.decide_after_uncalibrated_s
        };
        // A hypothesis converged alone must hold longer: a wrong restart step on chain 2
        // converged alone on the warehouse, 5 s before the right one.
        let converged = candidates.iter().filter(|c| c.converged).count();
        let needed_s = if converged >= 2 {
            after_s
        } else {
            after_s.max(chains.decide_alone_after_s)
        };
        let ripe = candidates.len() == 1
            || candidates
                .iter()
                .any(|c| c.converged && c.converged_s >= needed_s);
        if !ripe {
            return Ok(Released::default());
        }
        let scores: Vec<Option<f64>> = candidates
            .iter()
            .map(|c| {
                c.converged
                    .then(|| c.pipeline.wins().bearing_misfit().unwrap_or(f64::INFINITY))
            })
            .collect();
        let pick = scores
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.map(|s| (s, i)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map_or(0, |(_, i)| i);
        self.report.scores = scores;
        self.decide(pick, Some(s.t))
    }

    fn decide(&mut self, pick: usize, at: Option<Timestamp>) -> Result<Released, PipelineError> {
        let Stage::Testing(candidates) =
            std::mem::replace(&mut self.stage, Stage::Testing(Vec::new()))
        else {
            return Ok(Released::default());
        };
        let mut kept = None;
        for (i, c) in candidates.into_iter().enumerate() {
            if i == pick {
                kept = Some(c);
            } else {
                self.dropped_timing += c.pipeline.timing();
            }
        }
        let Some(c) = kept else {
            return Ok(Released::default());
        };
        self.report.chosen_deg = Some(c.step_rad.to_degrees());
        self.report.chosen_curvature_deg = Some(c.curvature_rad.to_degrees());
        self.report.decided_at_s = at.zip(self.first_imu).map(|(t, t0)| t.secs_since(t0));
        self.step_rad = c.step_rad;
        // Without a prior the kept step, refined by its window's common offset, is flown again
        // from the start: the hypotheses' early windows were pulled by steps up to half their
        // spacing off.
        if let Some(history) = self.history.take()
            && let Some((bias, _)) = c.pipeline.wins().sin_bias()
        {
            self.step_rad = self.refined(c.step_rad, bias);
            self.dropped_timing += c.pipeline.timing();
            let mut rig = self.rig.clone();
            rig.calibration = Some(with_step(&self.base, self.step_rad));
            let sigma = self.config.pipeline.chains.second_pass_sin_bias_sigma;
            let (pipeline, out) =
                fly_again(&self.config, rig, self.has_baro, sigma, &history.inputs)?;
            self.report.second_pass = true;
            self.stage = Stage::Decided(Box::new(pipeline));
            return Ok(out);
        }
        self.stage = Stage::Decided(Box::new(c.pipeline));
        Ok(c.held)
    }

    /// The uniform step `step_rad` moved by the bearings' common `sin θ` offset `sin_bias`
    /// (`Δφ = 2π·β·d/λ`), rad.
    fn refined(&self, step_rad: f64, sin_bias: f64) -> f64 {
        let period = self.rig.geometry.alias_period(self.rig.center_freq_hz);
        wrap(step_rad + TAU * sin_bias / period)
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
