//! The part of the receive chains' phase offsets that any capture reveals by itself, with no
//! known angle: the offsets' *curvature* `γ = φ₀ − 2·φ₁ + φ₂` over a three-antenna array.
//!
//! MUSIC smooths over the two antenna pairs (0, 1) and (1, 2) of the array: it assumes that the
//! second pair sees the same phase step as the first. A path at electrical angle `ψ` (the phase
//! step between neighbouring antennas, `2π·d·sin θ/λ`) gives the pairs the phase steps
//! `ψ + φ₁ − φ₀` and `ψ + φ₂ − φ₁`; their difference is `γ` whatever the angle. When `γ ≠ 0`
//! every path splits into two steering vectors and the spectrum's peaks wander from packet to
//! packet. Per packet `z = (Σ_k H₂ₖ·H̄₁ₖ)·conj(Σ_k H₁ₖ·H̄₀ₖ)` has the phase `γ` for a single
//! path; the circular mean of `z/|z|` over packets (and, in flight, over poses, which averages
//! the reflections out) measures it. The other part of the offsets, the *linear* one
//! (`φ₁ − φ₀` with `φ₂ − φ₁` equal to it), is a uniform phase step: it shifts every angle and
//! cannot be told from the angle without a reference (a calibration at a known angle, or the
//! motion).
//!
//! The Intel 5300's offsets change when the NIC restarts, by multiples of π at 5 GHz (π/2 at
//! 2.4 GHz) per chain ([`restart_step_rad`]). A stored calibration keeps its continuous part and
//! takes from the flight only which multiple of the step the curvature moved by
//! ([`ChainCurvature::corrected`]).

use num_complex::Complex64;
use std::f64::consts::{FRAC_PI_2, PI};

use crate::csi::sanitize::wrap;
use crate::rig::ChainCalibration;

/// Carriers below this are 2.4 GHz Wi-Fi, Hz.
const BAND_SPLIT_HZ: f64 = 4.0e9;

/// The step by which a chain's phase offset can change when the NIC restarts: π at 5 GHz, π/2 at
/// 2.4 GHz (the PLL's divider starts in one of 2 or 4 states).
pub fn restart_step_rad(center_freq_hz: f64) -> f64 {
    if center_freq_hz < BAND_SPLIT_HZ {
        FRAC_PI_2
    } else {
        PI
    }
}

/// The curvature of a calibration's offsets, `φ₀ − 2·φ₁ + φ₂` (three antennas; `None` otherwise).
pub fn curvature_of(calibration: &ChainCalibration) -> Option<f64> {
    match calibration.phase_offsets_rad[..] {
        [p0, p1, p2] => Some(wrap(p0 - 2.0 * p1 + p2)),
        _ => None,
    }
}

/// The running measurement of the curvature over packets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChainCurvature {
    /// Sum of the packets' unit phasors.
    sum: Complex64,
    /// Packets measured.
    pub packets: usize,
}

impl ChainCurvature {
    /// Adds one packet's raw CSI (row-major, three antennas of equal length; before any
    /// calibration). Returns false (and adds nothing) for another antenna count or a packet
    /// without signal on a chain.
    pub fn push(&mut self, csi: &[Complex64], num_antennas: usize) -> bool {
        if num_antennas != 3 || csi.is_empty() || !csi.len().is_multiple_of(3) {
            return false;
        }
        let k = csi.len() / 3;
        let pair = |a: usize, b: usize| -> Complex64 {
            (0..k).map(|i| csi[b * k + i] * csi[a * k + i].conj()).sum()
        };
        let z = pair(1, 2) * pair(0, 1).conj();
        let norm = z.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return false;
        }
        self.sum += z / norm;
        self.packets += 1;
        true
    }

    /// The measured curvature, rad in (−π, π] (`None` before the first packet).
    pub fn curvature_rad(&self) -> Option<f64> {
        (self.packets > 0).then(|| self.sum.arg())
    }

    /// Mean resultant length of the packets' phasors in [0, 1]: 1 when every packet agrees.
    pub fn agreement(&self) -> f64 {
        if self.packets == 0 {
            0.0
        } else {
            self.sum.norm() / self.packets as f64
        }
    }

    /// `prior` with its curvature made to agree with the measurement. With a prior, by the
    /// multiple of `step_rad` nearest to the measured change, on chain 2 alone (what a restart
    /// does; the continuous part kept). Without one (the identity as prior), all of it, spread
    /// as `change/6·[1, −2, 1]` over the chains so that the mean phase step between neighbours
    /// (the linear part, which the capture cannot reveal, and so the angles) is unchanged.
    /// Without a measurement, or for an array that is not three antennas, `prior` as it is.
    pub fn corrected(
        &self,
        prior: &ChainCalibration,
        step_rad: f64,
        has_prior: bool,
    ) -> Correction {
        let (Some(measured), Some(before)) = (self.curvature_rad(), curvature_of(prior)) else {
            return Correction::none(prior);
        };
        let change = wrap(measured - before);
        let applied = if has_prior {
            (change / step_rad).round() * step_rad
        } else {
            change
        };
        let mut calibration = prior.clone();
        let spread = if has_prior {
            [0.0, 0.0, 1.0]
        } else {
            [1.0 / 6.0, -2.0 / 6.0, 1.0 / 6.0]
        };
        // Nothing to apply: the prior bit for bit.
        if applied != 0.0 {
            for (phase, share) in calibration.phase_offsets_rad.iter_mut().zip(spread) {
                *phase = wrap(*phase + share * applied);
            }
        }
        Correction {
            calibration,
            measured_rad: Some(measured),
            prior_rad: Some(before),
            applied_rad: wrap(applied),
        }
    }
}

/// A calibration corrected by the measured curvature, with what was done.
#[derive(Clone, Debug, PartialEq)]
pub struct Correction {
    /// The calibration to use.
    pub calibration: ChainCalibration,
    /// The measured curvature, rad.
    pub measured_rad: Option<f64>,
    /// The prior's curvature, rad.
    pub prior_rad: Option<f64>,
    /// The change of the curvature applied (to chain 2 with a prior, spread over the chains
    /// without), rad.
    pub applied_rad: f64,
}

impl Correction {
    fn none(prior: &ChainCalibration) -> Self {
        Self {
            calibration: prior.clone(),
            measured_rad: None,
            prior_rad: curvature_of(prior),
            applied_rad: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CSI of paths `(gain, ψ, delay)` on three antennas with chain offsets `phi`.
    fn csi(paths: &[(f64, f64, f64)], phi: [f64; 3]) -> Vec<Complex64> {
        let mut out = Vec::new();
        for (m, p) in phi.iter().enumerate() {
            for k in 0..30 {
                let f = (k as f64 - 15.0) * 625e3;
                let v: Complex64 = paths
                    .iter()
                    .map(|&(g, psi, tau)| {
                        Complex64::from_polar(g, m as f64 * psi - std::f64::consts::TAU * f * tau)
                    })
                    .sum();
                out.push(v * Complex64::from_polar(1.0, *p));
            }
        }
        out
    }

    #[test]
    fn a_single_path_reveals_the_curvature_at_any_angle() {
        let phi = [0.4, -1.3, 2.9];
        let want = wrap(phi[0] - 2.0 * phi[1] + phi[2]);
        for psi in [-2.5, -0.3, 0.0, 1.1, 3.0] {
            let mut c = ChainCurvature::default();
            assert!(c.push(&csi(&[(1.0, psi, 20e-9)], phi), 3));
            let got = c.curvature_rad().unwrap();
            assert!(wrap(got - want).abs() < 1e-9, "ψ {psi}: {got} vs {want}");
            assert!((c.agreement() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_reflection_biases_one_packet_and_motion_averages_it_out() {
        let phi = [0.0, 0.7, -0.2];
        let want = wrap(phi[0] - 2.0 * phi[1] + phi[2]);
        let mut c = ChainCurvature::default();
        let mut worst: f64 = 0.0;
        for i in 0..200 {
            let psi = -2.0 + 0.02 * i as f64;
            let reflection = (0.4, 1.5 - 0.017 * i as f64, 45e-9);
            let one = csi(&[(1.0, psi, 10e-9), reflection], phi);
            let mut single = ChainCurvature::default();
            single.push(&one, 3);
            worst = worst.max(wrap(single.curvature_rad().unwrap() - want).abs());
            c.push(&one, 3);
        }
        let got = c.curvature_rad().unwrap();
        assert!(worst > 0.2, "a packet alone is biased: {worst}");
        assert!(wrap(got - want).abs() < 0.1 * worst, "{got} vs {want}");
    }

    #[test]
    fn a_prior_takes_only_the_restart_step_from_the_flight() {
        let prior = ChainCalibration {
            phase_offsets_rad: vec![0.0, 0.5, 1.2],
            ..ChainCalibration::identity(3)
        };
        // The NIC restarted with chain 2 flipped by π; the flight's multipath adds 0.2 rad.
        let actual = [0.0, 0.5, 1.2 + PI];
        let mut c = ChainCurvature::default();
        c.push(&csi(&[(1.0, 0.8, 0.0)], actual), 3);
        c.sum *= Complex64::from_polar(1.0, 0.2);
        let fix = c.corrected(&prior, restart_step_rad(5.32e9), true);
        assert!(
            (fix.applied_rad.abs() - PI).abs() < 1e-9,
            "{}",
            fix.applied_rad
        );
        assert!(wrap(fix.calibration.phase_offsets_rad[2] - actual[2]).abs() < 1e-9);
        assert_eq!(
            fix.calibration.phase_offsets_rad[..2],
            prior.phase_offsets_rad[..2]
        );
        // Without a prior the measured curvature is taken whole.
        let none = c.corrected(&ChainCalibration::identity(3), PI, false);
        let got = curvature_of(&none.calibration).unwrap();
        assert!(wrap(got - c.curvature_rad().unwrap()).abs() < 1e-9);
        // ... and the mean phase step between neighbours, which sets the angles, is unchanged.
        let p = &none.calibration.phase_offsets_rad;
        assert!(wrap(p[2] - p[0]).abs() < 1e-9, "{p:?}");
        // Two antennas: nothing to measure.
        assert!(!ChainCurvature::default().push(&csi(&[(1.0, 0.1, 0.0)], actual)[..60], 2));
        assert_eq!(restart_step_rad(2.437e9), FRAC_PI_2);
    }
}
