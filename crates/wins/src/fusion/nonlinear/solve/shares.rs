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
