//! The IMU's effective white noise, measured from its own samples (docs/ESTIMATOR.md, "The IMU's
//! noise from the data").
//!
//! A dataset's `[imu.noise]` is the datasheet's: the sensor's noise on a bench. On a flying
//! multirotor the samples also carry the rotors' vibration, which the flight controller's
//! low-pass leaves at 0.1–1 m/s² and 0.005–0.03 rad/s per axis, tens of times the datasheet's
//! white noise. Preintegration that trusts the datasheet then claims velocities and attitudes
//! far more precisely than the samples allow, and the window's covariance is overconfident.
//!
//! The meter measures, per block of [`BLOCK_S`], each channel's scatter about a parabola through
//! the block (the flight's own motion changes slowly over 0.1 s; the parabola takes it out):
//!
//! ```text
//! s²_c = Σ_i (x_ci − a_c − b_c t_i − c_c t_i²)² / (n − 3)   per channel c, least squares
//! v_a  = (s²_ax + s²_ay + s²_az) / 3                    accelerometer, per sample, per axis
//! v_g  = (s²_gx + s²_gy + s²_gz) / 3                    gyro
//! v̄   ← v̄ + (1 − e^{−T_block/τ}) (v − v̄)                 smoothed over the blocks, time constant τ
//! σ_eff = √(v̄ T_s)                                      as a white density (T_s the sample period)
//! ```
//!
//! and the estimator integrates with `max(σ_datasheet, σ_eff)`: the datasheet is a floor, never
//! lowered. Treating the vibration as white at its measured RMS is a model: its power sits in lines
//! and a band under the low-pass, not flat; for the 30 Hz two-pole low-pass and a broadband share
//! of a third, the white model's low-frequency density is of the same size as the broadband's own
//! (docs/ESTIMATOR.md gives the comparison). The scatter misses what lies under ~10 Hz of the
//! vibration, and counts the flight's own jerk within a block; both are small against the lines.

use super::ImuSample;
use crate::rig::ImuNoise;

/// Length of one block, s.
pub const BLOCK_S: f64 = 0.1;

/// Fewest samples that make a block (a parabola through fewer says little about the scatter).
const MIN_BLOCK_SAMPLES: usize = 6;

/// Spacing above which two samples are not in the same block (a gap), s.
const MAX_SPACING_S: f64 = 0.05;

/// The effective white noise of an IMU, measured from its samples (module doc).
#[derive(Clone, Debug)]
pub struct NoiseMeter {
    time_constant_s: f64,
    block: Vec<ImuSample>,
    /// Smoothed per-sample variances `[accelerometer, gyro]` and the sample period, s.
    smoothed: Option<([f64; 2], f64)>,
    blocks: u64,
}

impl NoiseMeter {
    /// A meter smoothing the blocks' variances with `time_constant_s`.
    pub fn new(time_constant_s: f64) -> Self {
        Self {
            time_constant_s: time_constant_s.max(BLOCK_S),
            block: Vec::with_capacity(64),
            smoothed: None,
            blocks: 0,
        }
    }

    /// Adds a sample; `true` when it closed a block and the estimate changed. A sample not after
    /// the previous one, or after a gap, starts a new block.
    pub fn push(&mut self, s: &ImuSample) -> bool {
        let mut changed = false;
        if let (Some(first), Some(last)) = (self.block.first(), self.block.last()) {
            let spacing = s.t.secs_since(last.t);
            if spacing <= 0.0 || spacing > MAX_SPACING_S {
                self.block.clear();
            } else if s.t.secs_since(first.t) >= BLOCK_S {
                changed = self.close();
                self.block.clear();
            }
        }
        self.block.push(*s);
        changed
    }

    /// Blocks measured so far.
    pub fn blocks(&self) -> u64 {
        self.blocks
    }

    /// The measured white densities `(accelerometer m/s²/√Hz, gyro rad/s/√Hz)`; `None` before
    /// the first block.
    pub fn densities(&self) -> Option<(f64, f64)> {
        self.smoothed
            .map(|([va, vg], ts)| ((va * ts).sqrt(), (vg * ts).sqrt()))
    }

    /// `floor` with its white densities raised to the measured ones where those are larger;
    /// everything else as in `floor`.
    pub fn effective(&self, floor: &ImuNoise) -> ImuNoise {
        let Some((a, g)) = self.densities() else {
            return floor.clone();
        };
        ImuNoise {
            accel_noise_density_m_s2_sqrt_hz: floor.accel_noise_density_m_s2_sqrt_hz.max(a),
            gyro_noise_density_rad_s_sqrt_hz: floor.gyro_noise_density_rad_s_sqrt_hz.max(g),
            ..floor.clone()
        }
    }

    /// Measures the block and folds it into the smoothed variances.
    fn close(&mut self) -> bool {
        let n = self.block.len();
        if n < MIN_BLOCK_SAMPLES {
            return false;
        }
        let (Some(first), Some(last)) = (self.block.first(), self.block.last()) else {
            return false;
        };
        let t0 = first.t;
        let span_s = last.t.secs_since(t0);
        let period_s = span_s / (n - 1) as f64;
        let t: Vec<f64> = self.block.iter().map(|s| s.t.secs_since(t0)).collect();
        let basis = parabola_basis(&t);
        let mut v = [0.0; 2];
        for c in 0..6 {
            let x: Vec<f64> = self
                .block
                .iter()
                .map(|s| {
                    if c < 3 {
                        s.accel_m_s2[c]
                    } else {
                        s.gyro_rad_s[c - 3]
                    }
                })
                .collect();
            v[c / 3] += scatter(&basis, x) / 3.0;
        }
        if !(v[0].is_finite() && v[1].is_finite() && period_s > 0.0) {
            return false;
        }
        self.blocks += 1;
        self.smoothed = Some(match self.smoothed {
            None => (v, period_s),
            Some((m, ts)) => {
                let k = 1.0 - (-span_s / self.time_constant_s).exp();
                (
                    [m[0] + k * (v[0] - m[0]), m[1] + k * (v[1] - m[1])],
                    ts + k * (period_s - ts),
                )
            }
        });
        true
    }
}

/// An orthonormal basis of `1, t, t²` over the block's own times (Gram–Schmidt, `t` centred);
/// fewer vectors when the times do not span them.
fn parabola_basis(t: &[f64]) -> Vec<Vec<f64>> {
    let tm = t.iter().sum::<f64>() / t.len() as f64;
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(3);
    for power in 0..3 {
        let mut v: Vec<f64> = t.iter().map(|ti| (ti - tm).powi(power)).collect();
        for q in &basis {
            let d: f64 = v.iter().zip(q).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(q).for_each(|(a, b)| *a -= d * b);
        }
        let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm > 0.0 {
            v.iter_mut().for_each(|a| *a /= norm);
            basis.push(v);
        }
    }
    basis
}

/// The scatter of `x` about its least-squares fit in `basis` ([`parabola_basis`]),
/// `Σ r² / (n − dim)`: the residual of the projection.
fn scatter(basis: &[Vec<f64>], mut x: Vec<f64>) -> f64 {
    for q in basis {
        let d: f64 = x.iter().zip(q).map(|(a, b)| a * b).sum();
        x.iter_mut().zip(q).for_each(|(a, b)| *a -= d * b);
    }
    x.iter().map(|a| a * a).sum::<f64>() / (x.len() - basis.len()) as f64
}

#[cfg(test)]
#[path = "noise_meter_tests.rs"]
mod tests;
