//! The flight controller's barometer: altitude with white noise, a slow drift and a per-flight
//! offset.
//!
//! ```text
//! altitude_k = z_k + offset + d_k + n_k,    n_k ~ N(0, σ_n²)
//! d_{k+1}    = φ d_k + σ_d √(1 − φ²) w_k,   φ = exp(−Δt / τ),  w_k ~ N(0, 1),  d_0 ~ N(0, σ_d²)
//! offset     ~ N(0, σ_o²), drawn once per flight
//! ```
//!
//! `z` is the height of the body (IMU) origin above the floor. The drift is a first-order
//! Gauss–Markov process (weather and temperature: stationary standard deviation σ_d, correlation
//! time τ), discretized exactly, so its statistics do not depend on the rate.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::ConfigError;
use crate::dataset::baro_csv::BaroSample;
use crate::time::Timestamp;

/// The barometer of a scenario (TOML `[baro]`; absent: no `baro.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BaroConfig {
    /// Sample rate, Hz (1–200; flight controllers log 20–50 Hz).
    pub rate_hz: f64,
    /// Standard deviation of the white noise σ_n, m.
    pub noise_m: f64,
    /// Stationary standard deviation of the drift σ_d, m.
    pub drift_m: f64,
    /// Correlation time of the drift τ, s (> 0).
    pub drift_time_constant_s: f64,
    /// Standard deviation of the per-flight offset σ_o, m.
    pub offset_sigma_m: f64,
}

impl Default for BaroConfig {
    /// A flight-controller barometer (MS5611 class) in a still room: 25 Hz, 0.25 m noise, drift
    /// 0.3 m over minutes (τ = 120 s), offset 10 m.
    fn default() -> Self {
        Self {
            rate_hz: 25.0,
            noise_m: 0.25,
            drift_m: 0.3,
            drift_time_constant_s: 120.0,
            offset_sigma_m: 10.0,
        }
    }
}

/// What the barometer saw and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroTruth {
    /// Sample time.
    pub t: Timestamp,
    /// True height of the body origin above the floor, m.
    pub height_m: f64,
    /// The flight's offset, m.
    pub offset_m: f64,
    /// The drift at this sample, m.
    pub drift_m: f64,
}

impl BaroConfig {
    /// Checks the values; `field` is the dotted prefix (`baro`).
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        if !(self.rate_hz.is_finite() && (1.0..=200.0).contains(&self.rate_hz)) {
            return Err(ConfigError::new(
                format!("{field}.rate_hz"),
                format!("{} is not in [1, 200] Hz", self.rate_hz),
            ));
        }
        for (name, v) in [
            ("noise_m", self.noise_m),
            ("drift_m", self.drift_m),
            ("offset_sigma_m", self.offset_sigma_m),
        ] {
            if !(v.is_finite() && (0.0..=1000.0).contains(&v)) {
                return Err(ConfigError::new(
                    format!("{field}.{name}"),
                    format!("{v} is not in [0, 1000] m"),
                ));
            }
        }
        if !(self.drift_time_constant_s.is_finite() && self.drift_time_constant_s > 0.0) {
            return Err(ConfigError::new(
                format!("{field}.drift_time_constant_s"),
                format!("must be finite and > 0, got {}", self.drift_time_constant_s),
            ));
        }
        Ok(())
    }

    /// Sample period, integer ns.
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round().max(1.0) as i64
    }

    /// Samples over `[0, duration_ns]` of a flight whose body height is `height_m(t)`, drawing
    /// from `rng` (offset first, then the drift's start, then per sample the drift step and the
    /// noise).
    pub fn simulate(
        &self,
        duration_ns: i64,
        height_m: impl Fn(Timestamp) -> f64,
        rng: &mut impl Rng,
    ) -> (Vec<BaroSample>, Vec<BaroTruth>) {
        let mut normal = || -> f64 { StandardNormal.sample(rng) };
        let period_ns = self.period_ns();
        let phi = (-(period_ns as f64 * 1e-9) / self.drift_time_constant_s).exp();
        let step_sigma_m = self.drift_m * (1.0 - phi * phi).sqrt();
        let offset_m = self.offset_sigma_m * normal();
        let mut drift_m = self.drift_m * normal();
        let n = (duration_ns / period_ns + 1).max(0) as usize;
        let mut samples = Vec::with_capacity(n);
        let mut truth = Vec::with_capacity(n);
        for k in 0..n {
            let t = Timestamp(k as i64 * period_ns);
            if k > 0 {
                drift_m = phi * drift_m + step_sigma_m * normal();
            }
            let h = height_m(t);
            samples.push(BaroSample {
                t,
                altitude_m: h + offset_m + drift_m + self.noise_m * normal(),
            });
            truth.push(BaroTruth {
                t,
                height_m: h,
                offset_m,
                drift_m,
            });
        }
        (samples, truth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng;

    #[test]
    fn noise_and_drift_statistics_match_the_configuration() {
        let config = BaroConfig {
            rate_hz: 50.0,
            noise_m: 0.3,
            drift_m: 0.5,
            drift_time_constant_s: 30.0,
            offset_sigma_m: 10.0,
        };
        config.validate("baro").unwrap();
        // 10 h at 50 Hz: 1200 drift correlation times.
        let duration_ns = 36_000 * 1_000_000_000;
        let height = |t: Timestamp| 1.5 + 0.5 * (t.as_secs_f64() * 0.3).sin();
        let (samples, truth) = config.simulate(duration_ns, height, &mut rng::stream(3, "baro"));
        assert_eq!(samples.len(), 1_800_001);
        let offset = truth[0].offset_m;
        assert!(truth.iter().all(|r| r.offset_m == offset));
        let noise: Vec<f64> = samples
            .iter()
            .zip(&truth)
            .map(|(s, r)| s.altitude_m - r.height_m - r.offset_m - r.drift_m)
            .collect();
        let drift: Vec<f64> = truth.iter().map(|r| r.drift_m).collect();
        let std = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        let noise_std = std(&noise);
        assert!((noise_std - 0.3).abs() < 0.003, "noise σ {noise_std}");
        let drift_std = std(&drift);
        assert!((drift_std - 0.5).abs() < 0.05, "drift σ {drift_std}");
        // Autocorrelation of the drift at lag τ (1500 samples) is e⁻¹.
        let lag = 1500;
        let m = drift.iter().sum::<f64>() / drift.len() as f64;
        let cov = drift
            .iter()
            .zip(&drift[lag..])
            .map(|(a, b)| (a - m) * (b - m))
            .sum::<f64>()
            / (drift.len() - lag) as f64;
        let rho = cov / drift_std.powi(2);
        assert!((rho - (-1.0f64).exp()).abs() < 0.05, "ρ(τ) = {rho}");
        // The truth's height is the flight's.
        assert!(truth.iter().all(|r| r.height_m == height(r.t)));
        // Same seed, same draw; other seed, other offset.
        let (again, _) = config.simulate(1_000_000_000, height, &mut rng::stream(3, "baro"));
        assert_eq!(again[..], samples[..again.len()]);
        let (_, other) = config.simulate(1_000_000_000, height, &mut rng::stream(4, "baro"));
        assert_ne!(other[0].offset_m, offset);
    }

    #[test]
    fn validation_names_the_field() {
        let bad = |c: BaroConfig| c.validate("baro").unwrap_err().field;
        let d = BaroConfig::default();
        assert_eq!(
            bad(BaroConfig {
                rate_hz: 0.5,
                ..d.clone()
            }),
            "baro.rate_hz"
        );
        assert_eq!(
            bad(BaroConfig {
                noise_m: -1.0,
                ..d.clone()
            }),
            "baro.noise_m"
        );
        assert_eq!(
            bad(BaroConfig {
                drift_time_constant_s: 0.0,
                ..d.clone()
            }),
            "baro.drift_time_constant_s"
        );
        assert_eq!(
            bad(BaroConfig {
                offset_sigma_m: f64::NAN,
                ..d
            }),
            "baro.offset_sigma_m"
        );
    }
}
