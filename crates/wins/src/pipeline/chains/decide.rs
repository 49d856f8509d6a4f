//! The hypotheses of the chains' offsets and the decision between them: one pipeline per
//! uniform step (and restart step) on the measured curvature, the converged one whose window
//! explains its bearings best kept.

use super::inputs::{Input, append};
use super::second_pass::{fly_again, with_curvature, with_step};
use super::{CURVATURE_TOLERANCE_RAD, Candidate, ChainResolver, Released, Stage};
use crate::aoa::{Correction, restart_step_rad};
use crate::csi::sanitize::wrap;
use crate::pipeline::{Pipeline, PipelineError};
use crate::time::Timestamp;
use std::f64::consts::TAU;

impl ChainResolver {
    /// Applies the measured curvature to the prior and starts one pipeline per step.
    pub(super) fn start_hypotheses(&mut self) -> Result<Released, PipelineError> {
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
    pub(super) fn measure_curvature(&mut self) -> Correction {
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
    pub(super) fn refresh_curvature(&mut self) -> Result<(), PipelineError> {
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
    pub(super) fn maybe_decide(&mut self, input: &Input) -> Result<Released, PipelineError> {
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

    pub(super) fn decide(
        &mut self,
        pick: usize,
        at: Option<Timestamp>,
    ) -> Result<Released, PipelineError> {
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
    pub(super) fn refined(&self, step_rad: f64, sin_bias: f64) -> f64 {
        let period = self.rig.geometry.alias_period(self.rig.center_freq_hz);
        wrap(step_rad + TAU * sin_bias / period)
    }
}
