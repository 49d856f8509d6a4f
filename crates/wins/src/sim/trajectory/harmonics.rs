//! The sum-of-sinusoids paths (circle, figure-eight, random flight, hover): the terms
//! `A sin(ω t + φ)`, their exact evaluation with derivatives and bounds, and the draw of the
//! random flight.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

use super::Translation;

/// Smallest relative weight of a random harmonic's amplitude (weights are drawn in
/// `[MIN_HARMONIC_WEIGHT, 1)` before normalisation), so no drawn harmonic is negligible.
const MIN_HARMONIC_WEIGHT: f64 = 0.1;

/// Draws the random flight described at [`super::TrajectoryConfig::RandomSmooth`].
///
/// Draw order (part of the reproducibility contract): for each axis x, y, z, for each harmonic,
/// period, phase, weight.
pub(super) fn random_smooth(
    min_m: Vector3<f64>,
    max_m: Vector3<f64>,
    max_speed_m_s: f64,
    num_harmonics: usize,
    (min_period_s, max_period_s): (f64, f64),
    seed: u64,
) -> Harmonics {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let half_width_m = (max_m - min_m) / 2.0;
    let mut harmonics = Vec::with_capacity(3 * num_harmonics);
    for axis in 0..3 {
        let start = harmonics.len();
        let mut weight_sum = 0.0;
        for _ in 0..num_harmonics {
            // u ∈ [0, 1): avoids `random_range` panicking on an empty range when min == max.
            let period_s = min_period_s + (max_period_s - min_period_s) * rng.random::<f64>();
            let phase_rad = TAU * rng.random::<f64>();
            let weight = MIN_HARMONIC_WEIGHT + (1.0 - MIN_HARMONIC_WEIGHT) * rng.random::<f64>();
            weight_sum += weight;
            let mut amplitude_m = Vector3::zeros();
            amplitude_m[axis] = weight;
            harmonics.push(Harmonic {
                amplitude_m,
                omega_rad_s: TAU / period_s,
                phase_rad,
            });
        }
        // Σ_k A_k = half-width: |p − c| ≤ half-width on this axis for all t.
        for h in &mut harmonics[start..] {
            h.amplitude_m *= half_width_m[axis] / weight_sum;
        }
    }
    let mut trajectory = Harmonics {
        center_m: (min_m + max_m) / 2.0,
        harmonics,
    };
    let speed_bound_m_s = trajectory.speed_bound_m_s();
    if speed_bound_m_s > max_speed_m_s {
        // Shrinking about the centre keeps the flight in the box.
        let scale = max_speed_m_s / speed_bound_m_s;
        for h in &mut trajectory.harmonics {
            h.amplitude_m *= scale;
        }
    }
    trajectory
}

/// One term `A sin(ω t + φ)` of a trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Harmonic {
    /// Vector amplitude `A` in `w`, m.
    pub(super) amplitude_m: Vector3<f64>,
    /// Angular frequency `ω`, rad/s (may be negative).
    pub(super) omega_rad_s: f64,
    /// Phase `φ`, rad.
    pub(super) phase_rad: f64,
}

/// `p(t) = c + Σ_k A_k sin(ω_k t + φ_k)`.
#[derive(Clone, Debug)]
pub(super) struct Harmonics {
    /// Offset `c` in `w`, m.
    pub(super) center_m: Vector3<f64>,
    /// The sinusoids.
    pub(super) harmonics: Vec<Harmonic>,
}

impl Harmonics {
    pub(super) fn at(&self, t_s: f64) -> Translation {
        let mut tr = Translation {
            p_b_in_w: self.center_m,
            v_b_in_w: Vector3::zeros(),
            a_b_in_w: Vector3::zeros(),
            j_b_in_w: Vector3::zeros(),
        };
        for h in &self.harmonics {
            let w = h.omega_rad_s;
            let (s, c) = (w * t_s + h.phase_rad).sin_cos();
            tr.p_b_in_w += h.amplitude_m * s;
            tr.v_b_in_w += h.amplitude_m * (w * c);
            tr.a_b_in_w -= h.amplitude_m * (w * w * s);
            tr.j_b_in_w -= h.amplitude_m * (w * w * w * c);
        }
        tr
    }

    /// Bound on the norm of the `order`-th derivative over all time:
    /// `|(Σ_k |A_xk| |ω_k|ⁿ, Σ_k |A_yk| |ω_k|ⁿ, Σ_k |A_zk| |ω_k|ⁿ)|`.
    pub(super) fn derivative_bound(&self, order: i32) -> f64 {
        self.harmonics
            .iter()
            .map(|h| h.amplitude_m.abs() * h.omega_rad_s.abs().powi(order))
            .sum::<Vector3<f64>>()
            .norm()
    }

    pub(super) fn speed_bound_m_s(&self) -> f64 {
        self.derivative_bound(1)
    }
}
