//! The calibrations the hypotheses fly, and the second pass: without a prior, the kept step
//! (refined by its window) flown again from the start of the flight.

use super::super::{Pipeline, PipelineError};
use super::Released;
use super::inputs::{Input, append, feed};
use crate::config::ChainOffsetsConfig;
use crate::config::Config;
use crate::csi::sanitize::wrap;
use crate::rig::{ChainCalibration, Rig};
use crate::time::Timestamp;

/// Most inputs the history keeps (120 s at the 10 kHz the manifest allows): past it the second
/// pass is skipped, as past `second_pass_max_s`.
pub(crate) const MAX_HISTORY_INPUTS: usize = 1_200_000;
/// Most CSI records the history keeps (about 600 bytes each; 120 s at 2000 packets/s).
pub(crate) const MAX_HISTORY_PACKETS: usize = 240_000;

/// Every input since the start of the flight, kept until the decision for the second pass.
pub(super) struct History {
    pub(super) inputs: Vec<Input>,
    max_s: f64,
    packets: usize,
}

impl History {
    /// A history when `wanted` and the second pass is on.
    pub(super) fn new(wanted: bool, chains: &ChainOffsetsConfig) -> Option<Self> {
        (wanted && chains.second_pass_max_s > 0.0).then(|| Self {
            inputs: Vec::new(),
            max_s: chains.second_pass_max_s,
            packets: 0,
        })
    }

    /// Keeps `input` in `history`, or drops the history once the flight (from `first_imu`)
    /// is longer than its limit, or the history would hold more than [`MAX_HISTORY_INPUTS`]
    /// inputs or [`MAX_HISTORY_PACKETS`] records: the second pass is then skipped.
    pub(super) fn keep(history: &mut Option<Self>, input: &Input, first_imu: Option<Timestamp>) {
        let Some(h) = history else {
            return;
        };
        let too_long = match (input, first_imu) {
            (Input::Imu(s), Some(t0)) => s.t.secs_since(t0) > h.max_s,
            _ => false,
        };
        let is_packet = matches!(input, Input::Csi(..));
        let too_many =
            h.inputs.len() >= MAX_HISTORY_INPUTS || (is_packet && h.packets >= MAX_HISTORY_PACKETS);
        if too_long || too_many {
            *history = None;
        } else {
            h.packets += usize::from(is_packet);
            h.inputs.push(input.clone());
        }
    }
}

/// A pipeline for `rig` (its calibration the refined step) fed every input of `history`, with
/// the prior σ `sin_bias_sigma` on the bearings' common `sin θ` offset; and what it released.
pub(super) fn fly_again(
    config: &Config,
    rig: Rig,
    has_baro: bool,
    sin_bias_sigma: f64,
    history: &[Input],
) -> Result<(Pipeline, Released), PipelineError> {
    let mut config = config.clone();
    config.nonlinear.sin_bias_sigma = sin_bias_sigma;
    let mut pipeline = Pipeline::with_baro(&config, rig, has_baro)?;
    let mut out = Released::default();
    for input in history {
        append(&mut out, feed(&mut pipeline, input));
    }
    Ok((pipeline, out))
}

/// `base` with chain 2's offset moved by `curvature_rad` (a restart's step).
pub(super) fn with_curvature(base: &ChainCalibration, curvature_rad: f64) -> ChainCalibration {
    let mut calibration = base.clone();
    if curvature_rad != 0.0
        && let Some(phase) = calibration.phase_offsets_rad.get_mut(2)
    {
        *phase = wrap(*phase + curvature_rad);
    }
    calibration
}

/// `base` with the uniform step `step_rad` added (chain `m` moved by `m·step`).
pub(super) fn with_step(base: &ChainCalibration, step_rad: f64) -> ChainCalibration {
    let mut calibration = base.clone();
    if step_rad == 0.0 {
        return calibration;
    }
    for (m, phase) in calibration.phase_offsets_rad.iter_mut().enumerate() {
        *phase = wrap(*phase + m as f64 * step_rad);
    }
    calibration
}
