//! The uniform linear array and its steering vector: the one definition of the AoA sign.
//!
//! Array frame `a`: antennas on the `a_y` axis at `y_m = (m − (M−1)/2)·d`, normal `a_x`. With û the
//! unit vector from the array toward the source, expressed in `a`, the angle of arrival θ ∈
//! [−90°, 90°] satisfies `sin θ = û · ŷ_a` (positive toward `+a_y`). A plane wave from û reaches
//! antenna `m` *earlier* than the array centre by `y_m·sin θ / c` when `y_m·sin θ > 0`, so its
//! baseband phase relative to the centre is `exp(+j·2π·f·y_m·sin θ / c)`.
//!
//! A linear array measures only this cone angle: every direction with the same `û · ŷ_a` gives the
//! same steering vector. In particular a source behind the array (`û · x̂_a < 0`) looks like its
//! mirror image in front.

use crate::rig::array::{ArrayGeometry, SPEED_OF_LIGHT_M_S};
use nalgebra::Vector3;
use num_complex::Complex64;

/// The steering vector of the array (an inherent impl here so that the one definition of the AoA
/// sign lives beside its doc above).
impl ArrayGeometry {
    /// Phase (radians) of antenna `m` relative to the array centre for a plane wave of frequency
    /// `freq_hz` arriving at angle θ given as `sin_theta`: `+2π·f·y_m·sin θ / c`.
    pub fn antenna_phase_rad(&self, m: usize, freq_hz: f64, sin_theta: f64) -> f64 {
        std::f64::consts::TAU * freq_hz * self.antenna_y_m(m) * sin_theta / SPEED_OF_LIGHT_M_S
    }

    /// Steering vector: element `m` is `exp(+j·2π·f·y_m·sin θ / c)`, written into `out`
    /// (length M).
    pub fn steering_into(&self, freq_hz: f64, sin_theta: f64, out: &mut [Complex64]) {
        for (m, o) in out.iter_mut().enumerate().take(self.num_antennas) {
            *o = Complex64::from_polar(1.0, self.antenna_phase_rad(m, freq_hz, sin_theta));
        }
    }

    /// The steering vector as a new `Vec` (see [`ArrayGeometry::steering_into`]).
    pub fn steering(&self, freq_hz: f64, sin_theta: f64) -> Vec<Complex64> {
        let mut out = vec![Complex64::new(0.0, 0.0); self.num_antennas];
        self.steering_into(freq_hz, sin_theta, &mut out);
        out
    }
}

/// Phase (radians) that a delay `tof_s` puts on a tone `freq_hz`: `−2π·f·τ`. The simulator applies
/// it at each subcarrier's absolute frequency; MUSIC's ToF steering uses the subcarrier offsets
/// (the carrier part is common to all subcarriers and lands in the path gain).
pub fn tof_phase_rad(freq_hz: f64, tof_s: f64) -> f64 {
    -std::f64::consts::TAU * freq_hz * tof_s
}

/// sin θ for a direction toward the source expressed in the array frame (need not be unit
/// length; a zero vector gives 0).
pub fn sin_aoa(toward_source_in_a: &Vector3<f64>) -> f64 {
    let n = toward_source_in_a.norm();
    if n > 0.0 {
        (toward_source_in_a.y / n).clamp(-1.0, 1.0)
    } else {
        0.0
    }
}

/// The AoA θ ∈ [−π/2, π/2] for a direction toward the source in the array frame.
pub fn aoa_rad(toward_source_in_a: &Vector3<f64>) -> f64 {
    sin_aoa(toward_source_in_a).asin()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::array::CHANNEL_64_HZ;

    #[test]
    fn neighbouring_antennas_differ_by_two_pi_d_sin_theta_over_lambda() {
        let g = ArrayGeometry::default();
        let f = CHANNEL_64_HZ;
        let lambda = SPEED_OF_LIGHT_M_S / f;
        for deg in [-80.0_f64, -30.0, 0.0, 10.0, 45.0, 89.0] {
            let s = deg.to_radians().sin();
            let a = g.steering(f, s);
            let expected = std::f64::consts::TAU * g.spacing_m * s / lambda;
            for m in 1..3 {
                let d = (a[m] * a[m - 1].conj()).arg();
                assert!((d - expected).abs() < 1e-12, "{deg}: {d} vs {expected}");
            }
        }
    }

    #[test]
    fn a_source_toward_plus_y_is_a_positive_angle_and_leads_on_the_plus_y_antenna() {
        let u = Vector3::new(1.0, 1.0, 0.0);
        assert!((aoa_rad(&u) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        let a = ArrayGeometry::default().steering(CHANNEL_64_HZ, sin_aoa(&u));
        // The +y antenna leads its neighbour (π·sin 45° of phase at λ/2).
        assert!((a[2] * a[1].conj()).arg() > 0.0);
        // Behind the array: same cone angle.
        assert_eq!(aoa_rad(&Vector3::new(-1.0, 1.0, 0.0)), aoa_rad(&u));
        assert_eq!(sin_aoa(&Vector3::zeros()), 0.0);
    }
}
