//! ToF sanitization, SpotFi (Kotaru et al., SIGCOMM 2015) Algorithm 1: remove the packet's
//! sampling-time offset (and with it the common part of the ToF) by ONE straight-line fit of
//! phase against subcarrier frequency over all antennas (docs/DESIGN.md §3).
//!
//! Each antenna's phase is unwrapped along the subcarriers; antennas are aligned to within π of
//! antenna 0 at the first subcarrier; the line `ψ(Δf) = slope·Δf + offset` is fitted by least
//! squares to every (Δf_k, ψ_m,k) pair; `exp(−j·ψ(Δf_k))` multiplies every antenna. Because one
//! line serves all antennas, the inter-antenna phase (the AoA) survives unchanged.

use num_complex::Complex64;
use std::f64::consts::{PI, TAU};

/// The line removed from a packet: phase(Δf) = `slope_rad_per_hz`·Δf + `offset_rad`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearPhase {
    /// Phase slope over subcarrier frequency offset, rad/Hz.
    pub slope_rad_per_hz: f64,
    /// Phase at Δf = 0, rad.
    pub offset_rad: f64,
}

impl LinearPhase {
    /// The delay this slope amounts to, s: a delay τ gives phase −2π·Δf·τ, so τ = −slope/2π.
    /// It is the sampling-time offset plus the (power-weighted, roughly) mean path delay.
    pub fn delay_s(&self) -> f64 {
        -self.slope_rad_per_hz / TAU
    }
}

/// A packet that cannot be sanitized.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SanitizeError {
    /// `csi.len()` is not antennas × subcarriers.
    #[error("{len} CSI entries do not make {antennas} antennas × {subcarriers} subcarriers")]
    Shape {
        /// Entries given.
        len: usize,
        /// Antennas claimed.
        antennas: usize,
        /// Subcarrier offsets given.
        subcarriers: usize,
    },
    /// Fewer than two distinct subcarrier frequencies, or not increasing: no line to fit.
    #[error("subcarrier offsets must be at least two, strictly increasing and finite")]
    Offsets,
}

/// Sanitizes one packet in place. `csi` is row-major, antenna `m`'s subcarrier `k` at
/// `m·K + k` with `K = offsets_hz.len()`; `offsets_hz` are the subcarriers' frequency offsets
/// from the carrier (true indices × 312.5 kHz, [`crate::csi::Bandwidth::subcarrier_offsets_hz`]).
/// Returns the line removed.
pub fn sanitize(
    csi: &mut [Complex64],
    num_antennas: usize,
    offsets_hz: &[f64],
) -> Result<LinearPhase, SanitizeError> {
    let k_count = offsets_hz.len();
    if num_antennas == 0 || csi.len() != num_antennas * k_count {
        return Err(SanitizeError::Shape {
            len: csi.len(),
            antennas: num_antennas,
            subcarriers: k_count,
        });
    }
    let increasing = offsets_hz.windows(2).all(|w| w[1] > w[0]);
    if k_count < 2 || !increasing || offsets_hz.iter().any(|f| !f.is_finite()) {
        return Err(SanitizeError::Offsets);
    }

    // Sums for the least-squares line over all (Δf, ψ) pairs; Δf centred for conditioning.
    let f_mean = offsets_hz.iter().sum::<f64>() / k_count as f64;
    let (mut s_ff, mut s_fp, mut s_p) = (0.0, 0.0, 0.0);
    let mut first_phase_0 = 0.0;
    for (m, row) in csi.chunks_exact(k_count).enumerate() {
        let mut unwrapped = row[0].arg();
        if m == 0 {
            first_phase_0 = unwrapped;
        } else {
            // Align to within π of antenna 0 at the first subcarrier.
            unwrapped -= TAU * ((unwrapped - first_phase_0) / TAU).round();
        }
        for (k, v) in row.iter().enumerate() {
            if k > 0 {
                unwrapped += wrap(v.arg() - unwrapped);
            }
            let f = offsets_hz[k] - f_mean;
            s_ff += f * f;
            s_fp += f * unwrapped;
            s_p += unwrapped;
        }
    }
    let n = (num_antennas * k_count) as f64;
    // Each antenna contributes the same Δf values, so Σf over all pairs is 0 after centring.
    let slope = s_fp / s_ff;
    let line = LinearPhase {
        slope_rad_per_hz: slope,
        offset_rad: s_p / n - slope * f_mean,
    };
    for row in csi.chunks_exact_mut(k_count) {
        for (v, f) in row.iter_mut().zip(offsets_hz) {
            *v *= Complex64::from_polar(1.0, -(line.slope_rad_per_hz * f + line.offset_rad));
        }
    }
    Ok(line)
}

/// `x` wrapped to (−π, π].
pub(crate) fn wrap(x: f64) -> f64 {
    let y = (x + PI).rem_euclid(TAU) - PI;
    if y == -PI { PI } else { y }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csi::Bandwidth;

    /// Two paths, three antennas at λ/2, with a common linear phase (STO + ToF) and constant.
    fn channel(offsets: &[f64], delay_s: f64, common_rad: f64) -> Vec<Complex64> {
        let paths = [
            (1.0, 20f64.to_radians(), 30e-9),
            (0.4, -40f64.to_radians(), 55e-9),
        ];
        let mut out = Vec::new();
        for m in 0..3 {
            for &f in offsets {
                let mut h = Complex64::new(0.0, 0.0);
                for (a, theta, tau) in paths {
                    let phase = PI * (m as f64 - 1.0) * f64::sin(theta) - TAU * f * tau;
                    h += Complex64::from_polar(a, phase);
                }
                out.push(h * Complex64::from_polar(1.0, common_rad - TAU * f * delay_s));
            }
        }
        out
    }

    #[test]
    fn different_sampling_offsets_and_common_phases_sanitize_to_the_same_csi() {
        for bw in [Bandwidth::Ht20, Bandwidth::Ht40] {
            let offsets = bw.subcarrier_offsets_hz();
            let mut a = channel(&offsets, 10e-9, 0.3);
            let mut b = channel(&offsets, 90e-9, -2.9);
            let la = sanitize(&mut a, 3, &offsets).unwrap();
            let lb = sanitize(&mut b, 3, &offsets).unwrap();
            assert!(
                (lb.delay_s() - la.delay_s() - 80e-9).abs() < 1e-15,
                "{la:?} {lb:?}"
            );
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).norm() < 1e-12, "{bw:?}: {x} vs {y}");
            }
        }
    }

    #[test]
    fn inter_antenna_phase_survives_and_a_second_pass_removes_nothing() {
        let offsets = Bandwidth::Ht20.subcarrier_offsets_hz();
        let raw = channel(&offsets, 60e-9, 1.0);
        let mut s = raw.clone();
        sanitize(&mut s, 3, &offsets).unwrap();
        for k in 0..30 {
            for m in 1..3 {
                let before = raw[m * 30 + k] * raw[k].conj();
                let after = s[m * 30 + k] * s[k].conj();
                assert!((before - after).norm() < 1e-12);
            }
        }
        let again = sanitize(&mut s, 3, &offsets).unwrap();
        assert!(again.slope_rad_per_hz.abs() * 40e6 < 1e-9, "{again:?}");
        assert!(again.offset_rad.abs() < 1e-9, "{again:?}");
    }

    #[test]
    fn a_single_path_gives_back_its_delay() {
        let offsets = Bandwidth::Ht40.subcarrier_offsets_hz();
        let mut csi: Vec<Complex64> = (0..3)
            .flat_map(|m| {
                offsets.iter().map(move |f| {
                    Complex64::from_polar(2.0, 0.7 * m as f64 - TAU * f * 123e-9 + 0.4)
                })
            })
            .collect();
        let line = sanitize(&mut csi, 3, &offsets).unwrap();
        assert!(
            (line.delay_s() - 123e-9).abs() < 1e-15,
            "{}",
            line.delay_s()
        );
    }

    #[test]
    fn bad_shapes_are_errors() {
        let offsets = Bandwidth::Ht20.subcarrier_offsets_hz();
        let mut short = vec![Complex64::new(1.0, 0.0); 89];
        assert!(matches!(
            sanitize(&mut short, 3, &offsets),
            Err(SanitizeError::Shape { len: 89, .. })
        ));
        let mut one = vec![Complex64::new(1.0, 0.0); 3];
        assert_eq!(sanitize(&mut one, 3, &[0.0]), Err(SanitizeError::Offsets));
        let mut two = vec![Complex64::new(1.0, 0.0); 2];
        assert_eq!(
            sanitize(&mut two, 1, &[1.0, 0.0]),
            Err(SanitizeError::Offsets)
        );
        assert_eq!(wrap(3.0 * PI), PI);
        assert_eq!(wrap(-PI), PI);
    }
}
