//! The second-order Butterworth low-pass a flight controller runs on its IMU samples.
//!
//! Bilinear transform of `H(s) = ω_c² / (s² + √2 ω_c s + ω_c²)` with the cutoff pre-warped, as
//! PX4's `math::LowPassFilter2p` (the filter behind `IMU_ACCEL_CUTOFF` and `IMU_GYRO_CUTOFF`) and
//! ArduPilot's `LowPassFilter2p` compute it; with `Ω = tan(π f_c / f_s)` and
//! `c = 1 + √2 Ω + Ω²`:
//!
//! ```text
//! b0 = b2 = Ω²/c,   b1 = 2 b0,   a1 = 2(Ω² − 1)/c,   a2 = (1 − √2 Ω + Ω²)/c
//! y_k = b0 x_k + b1 x_{k−1} + b2 x_{k−2} − a1 y_{k−1} − a2 y_{k−2}
//! ```
//!
//! run in transposed direct form II. The gain is 1 at 0 Hz, `1/√2` at `f_c`, and falls as
//! `(f_c/f)²` above it.

use num_complex::Complex64;

/// A second-order Butterworth low-pass at a fixed sample rate, with its state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Butterworth2 {
    b0: f64,
    b1: f64,
    b2: f64,
    a1: f64,
    a2: f64,
    s1: f64,
    s2: f64,
}

impl Butterworth2 {
    /// The filter with cutoff `cutoff_hz` (−3 dB) at sample rate `sample_hz`, at rest. The cutoff
    /// must lie in `(0, sample_hz / 2)` (the caller validates it).
    pub(crate) fn new(cutoff_hz: f64, sample_hz: f64) -> Self {
        let omega = (std::f64::consts::PI * cutoff_hz / sample_hz).tan();
        let sqrt2 = std::f64::consts::SQRT_2;
        let c = 1.0 + sqrt2 * omega + omega * omega;
        let b0 = omega * omega / c;
        Self {
            b0,
            b1: 2.0 * b0,
            b2: b0,
            a1: 2.0 * (omega * omega - 1.0) / c,
            a2: (1.0 - sqrt2 * omega + omega * omega) / c,
            s1: 0.0,
            s2: 0.0,
        }
    }

    /// Filters one sample.
    pub(crate) fn step(&mut self, x: f64) -> f64 {
        let y = self.b0 * x + self.s1;
        self.s1 = self.b1 * x - self.a1 * y + self.s2;
        self.s2 = self.b2 * x - self.a2 * y;
        y
    }

    /// `|H(e^{jω})|` at `f_hz` for sample rate `sample_hz` (`ω = 2π f / f_s`).
    pub(crate) fn gain_at(&self, f_hz: f64, sample_hz: f64) -> f64 {
        let z_inv = Complex64::from_polar(1.0, -std::f64::consts::TAU * f_hz / sample_hz);
        let num = self.b0 + z_inv * (self.b1 + z_inv * self.b2);
        let den = 1.0 + z_inv * (self.a1 + z_inv * self.a2);
        (num / den).norm()
    }

    /// The noise gain `Σ h_k²`: the output variance for a unit-variance white input, from the
    /// stationary covariance `P = A P Aᵀ + B Bᵀ` of the state `s = (s1, s2)`
    /// (`s' = A s + B x`, `A = [[−a1, 1], [−a2, 0]]`, `B = (b1 − a1 b0, b2 − a2 b0)`), solved in
    /// closed form: `Var y = b0² + P₁₁`.
    pub(crate) fn noise_gain(&self) -> f64 {
        let (a1, a2) = (self.a1, self.a2);
        let big_b1 = self.b1 - a1 * self.b0;
        let big_b2 = self.b2 - a2 * self.b0;
        let lhs = 1.0 - a1 * a1 - a2 * a2 + 2.0 * a1 * a1 * a2 / (1.0 + a2);
        let rhs = big_b1 * big_b1 + big_b2 * big_b2 - 2.0 * a1 * big_b1 * big_b2 / (1.0 + a2);
        self.b0 * self.b0 + rhs / lhs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_is_one_at_dc_and_minus_3_db_at_the_cutoff() {
        let f = Butterworth2::new(30.0, 1600.0);
        assert!((f.gain_at(0.0, 1600.0) - 1.0).abs() < 1e-12);
        assert!((f.gain_at(30.0, 1600.0) - 0.5f64.sqrt()).abs() < 1e-12);
        // The bilinear transform maps f onto the analog response at the pre-warped frequency:
        // |H(f)|² = 1 / (1 + (tan(π f / f_s) / tan(π f_c / f_s))⁴).
        let warp = |f_hz: f64| (std::f64::consts::PI * f_hz / 1600.0).tan();
        for f_hz in [10.0, 95.0, 190.0, 300.0, 700.0] {
            let analog = 1.0 / (1.0 + (warp(f_hz) / warp(30.0)).powi(4)).sqrt();
            assert!(
                (f.gain_at(f_hz, 1600.0) / analog - 1.0).abs() < 1e-9,
                "{f_hz} Hz"
            );
        }
        // Two poles: (f_c/f)² well above the cutoff, less where the warp compresses it.
        assert!((f.gain_at(300.0, 1600.0) - 0.0078).abs() < 1e-4);
    }

    #[test]
    fn noise_gain_is_the_sum_of_the_squared_impulse_response() {
        for (fc, fs) in [(30.0, 1600.0), (30.0, 200.0), (90.0, 200.0), (5.0, 8000.0)] {
            let mut f = Butterworth2::new(fc, fs);
            let closed = f.noise_gain();
            let mut sum = 0.0;
            for k in 0..200_000 {
                let h = f.step(if k == 0 { 1.0 } else { 0.0 });
                sum += h * h;
            }
            assert!(
                (closed / sum - 1.0).abs() < 1e-9,
                "{fc}/{fs}: {closed} vs {sum}"
            );
        }
    }

    #[test]
    fn a_sine_comes_out_scaled_by_the_gain() {
        let (fc, fs, f0) = (30.0, 1600.0, 95.0);
        let mut f = Butterworth2::new(fc, fs);
        let mut power = 0.0;
        let n = 160_000;
        for k in 0..2 * n {
            let y = f.step((std::f64::consts::TAU * f0 * k as f64 / fs).sin());
            if k >= n {
                power += y * y;
            }
        }
        let rms = (power / n as f64).sqrt();
        let expected = f.gain_at(f0, fs) / 2f64.sqrt();
        assert!((rms / expected - 1.0).abs() < 1e-3, "{rms} vs {expected}");
    }
}
