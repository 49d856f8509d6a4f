//! How much of an independent measurement each bearing is worth.
//!
//! A bearing's error is not white: a reflection biases the spectrum's peak by an amount that
//! moves slowly with the drone, so the packets of one second repeat much the same error
//! (measured on the simulator's rooms: 1–2 independent bearings per second from 50–80 packets,
//! docs/ESTIMATOR.md "The bearings' errors persist from packet to packet"). The window models
//! each AP's error as a first-order Gauss–Markov process of correlation time `τ`
//! (`[nonlinear] bearing_correlation_s`): samples `Δt` apart are correlated by `e^{−Δt/τ}`.
//!
//! For `n` such samples at a rate `λ` (an AR(1) sequence with `ρ = e^{−1/(λτ)}`), the mean has
//! the variance of `n / R` independent ones, the long-run variance ratio
//!
//! ```text
//! R = (1 + ρ) / (1 − ρ) = coth(1 / (2λτ))     (≈ 2λτ when λτ ≫ 1, 1 when τ → 0)
//! ```
//!
//! Each bearing therefore enters the window with its per-packet σ for the robust loss (an
//! outlier is one packet's) but `1/R` of its information, and the χ² tests count `1/R` of a
//! degree of freedom for it: the window then holds what a second of bearings carries, not what
//! its packet count says, however fast the AP sends.

/// The long-run variance ratio `R = coth(1/(2λτ))` of an AP whose bearings arrive at
/// `rate_hz` with errors correlated over `correlation_s` (module doc); 1 for no correlation or
/// no rate.
pub fn variance_ratio(rate_hz: f64, correlation_s: f64) -> f64 {
    let x = rate_hz * correlation_s;
    if !x.is_finite() || x <= 0.0 {
        return 1.0;
    }
    let y = 1.0 / (2.0 * x);
    // coth y = (1 + e^{−2y}) / (1 − e^{−2y}), ≥ 1.
    let e = (-2.0 * y).exp();
    ((1.0 + e) / (1.0 - e)).max(1.0)
}

/// The long-run variance ratio of a series measured from the series itself: `1 + 2 Σ ρ_k` over
/// its sample autocorrelations, summed in lag pairs while a pair's sum stays positive (Geyer's
/// initial positive sequence, the estimate behind an MCMC chain's effective sample size), so that
/// a white error and a persistent one in sum are both counted. At least 1 and at most the series'
/// length (its `n` samples are worth at least one); 1 below 8 samples.
pub fn measured_variance_ratio(series: &[f64]) -> f64 {
    let n = series.len();
    if n < 8 {
        return 1.0;
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = series.iter().map(|x| x - mean).collect();
    let c0 = centred.iter().map(|x| x * x).sum::<f64>();
    if !c0.is_finite() || c0 <= 0.0 {
        return 1.0;
    }
    let rho = |k: usize| -> f64 {
        centred
            .iter()
            .zip(&centred[k..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / c0
    };
    let mut sum = 0.0;
    let mut k = 1;
    while k + 1 < n / 2 {
        let pair = rho(k) + rho(k + 1);
        if pair <= 0.0 {
            break;
        }
        sum += pair;
        k += 2;
    }
    (1.0 + 2.0 * sum).clamp(1.0, n as f64)
}

/// Each AP's share of an independent measurement per bearing, `1 / R` (module doc), from its
/// `counts` of bearings over a window `span_s` long.
pub fn shares(counts: &[usize], span_s: f64, correlation_s: f64) -> Vec<f64> {
    counts
        .iter()
        .map(|&n| {
            let rate_hz = if span_s > 0.0 { n as f64 / span_s } else { 0.0 };
            1.0 / variance_ratio(rate_hz, correlation_s)
        })
        .collect()
}

impl super::NonlinearWindow {
    /// From the next solve on, the bearings' errors persist over `correlation_s` (module doc).
    pub fn set_bearing_correlation_s(&mut self, correlation_s: f64) {
        self.model.config.bearing_correlation_s = correlation_s;
    }

    /// Each AP's share per bearing (module doc) over the bearings the window holds now: their
    /// rate is their count over the window's span (at least one keyframe period).
    pub(super) fn bearing_shares(&self) -> Vec<f64> {
        let correlation_s = self.model.config.bearing_correlation_s;
        if correlation_s <= 0.0 {
            return vec![1.0; self.aps.len()];
        }
        let frames = || self.keyframes.iter().flat_map(|k| &k.frames);
        let mut counts = vec![0usize; self.aps.len()];
        for b in frames().flat_map(|f| &f.bearings) {
            if let Some(c) = counts.get_mut(b.ap) {
                *c += 1;
            }
        }
        let span_s = match (
            self.keyframes.front(),
            frames().map(|f| f.partial.end).max(),
        ) {
            (Some(first), Some(last)) => last.secs_since(first.x.t),
            _ => 0.0,
        }
        .max(self.model.config.keyframe_period_s);
        shares(&counts, span_s, correlation_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn the_ratio_is_one_without_correlation_and_two_rate_tau_with_much() {
        assert_eq!(variance_ratio(50.0, 0.0), 1.0);
        assert_eq!(variance_ratio(0.0, 0.3), 1.0);
        assert!((variance_ratio(100.0, 1.0) - 200.0).abs() < 0.01);
        assert!((variance_ratio(1.0, 0.01) - 1.0).abs() < 1e-9);
        assert_eq!(shares(&[10, 0], 0.0, 0.3), vec![1.0, 1.0]);
        let s = shares(&[100], 2.0, 0.3);
        assert!((s[0] - 1.0 / variance_ratio(50.0, 0.3)).abs() < 1e-12);
    }

    /// Measured from the series alone: about 1 for white errors, about `R` for an AR(1)
    /// sequence of correlation time τ, and more for a white error plus a persistent one than
    /// for the white one alone.
    #[test]
    fn the_ratio_measured_from_a_series_finds_its_persistence() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let unit = Normal::new(0.0, 1.0).unwrap();
        let white: Vec<f64> = (0..3000).map(|_| unit.sample(&mut rng)).collect();
        let r_white = measured_variance_ratio(&white);
        assert!((0.7..1.4).contains(&r_white), "white: {r_white}");
        let (rate_hz, tau_s): (f64, f64) = (50.0, 0.3);
        let rho = (-1.0 / (rate_hz * tau_s)).exp();
        let innovation = (1.0 - rho * rho).sqrt();
        let mut e = 0.0;
        let persistent: Vec<f64> = (0..3000)
            .map(|_| {
                e = rho * e + innovation * unit.sample(&mut rng);
                e
            })
            .collect();
        let r = measured_variance_ratio(&persistent);
        let expected = variance_ratio(rate_hz, tau_s);
        assert!(
            (r / expected - 1.0).abs() < 0.5,
            "AR(1): {r} against {expected}"
        );
        let mixed: Vec<f64> = white.iter().zip(&persistent).map(|(w, p)| w + p).collect();
        let r_mixed = measured_variance_ratio(&mixed);
        assert!(
            r_mixed > 5.0 && r_mixed < r,
            "white + persistent: {r_mixed}"
        );
        assert_eq!(measured_variance_ratio(&[1.0; 5]), 1.0);
        assert_eq!(measured_variance_ratio(&[2.0; 100]), 1.0);
        assert!(measured_variance_ratio(&[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]) <= 8.0);
    }

    /// The mean of an AR(1) sequence scatters as `R σ² / n` (Monte Carlo, seeded): counting the
    /// samples as independent would claim `R` times less.
    #[test]
    fn the_mean_of_correlated_errors_scatters_as_the_ratio_says() {
        let (rate_hz, tau_s, n): (f64, f64, usize) = (60.0, 0.3, 600);
        let rho = (-1.0 / (rate_hz * tau_s)).exp();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let unit = Normal::new(0.0, 1.0).unwrap();
        let innovation = (1.0 - rho * rho).sqrt();
        let trials = 2000;
        let mut sum_sq = 0.0;
        for _ in 0..trials {
            let mut e = unit.sample(&mut rng);
            let mut sum = 0.0;
            for _ in 0..n {
                sum += e;
                e = rho * e + innovation * unit.sample(&mut rng);
            }
            sum_sq += (sum / n as f64).powi(2);
        }
        let measured_ratio = sum_sq / trials as f64 * n as f64;
        let ratio = variance_ratio(rate_hz, tau_s);
        // 2000 trials: the variance is known to ±3 %; the finite sequence lowers it by ~2τλ/n.
        assert!(
            (measured_ratio / ratio - 1.0).abs() < 0.12,
            "{measured_ratio} vs {ratio}"
        );
    }
}
