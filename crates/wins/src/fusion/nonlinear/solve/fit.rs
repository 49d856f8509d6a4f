//! The window's residual statistics, and the χ² test on them (acceptance of a start, loss).

use crate::chi2::chi2_upper;

/// Residual statistics of the window at its estimate (whitened: in units of each σ).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FitStats {
    /// Σ rᵀ Λ r over the IMU factors.
    pub imu_chi2: f64,
    /// Number of IMU residual components (15 per factor).
    pub imu_dof: usize,
    /// Number of AoA residuals.
    pub bearings: usize,
    /// Their degrees of freedom: each bearing's share of an independent measurement
    /// ([`super::shares`]) summed.
    pub bearing_dof: f64,
    /// Σ share · e² over the AoA residuals.
    pub bearing_chi2: f64,
    /// Σ share · ρ(e²) over the AoA residuals (Cauchy).
    pub bearing_robust: f64,
    /// AoA residuals with |e| > 3.
    pub bearing_outliers: usize,
    /// Barometer residuals and their Σ e².
    pub baro: usize,
    /// See `baro`.
    pub baro_chi2: f64,
    /// Range anchors (what a window lost to a hole knew of an AP's range, on a window started
    /// after it) and their Σ r².
    pub anchors: usize,
    /// See `anchors`.
    pub anchor_chi2: f64,
    /// Zero-velocity residual components (3 per keyframe held still) and their Σ r².
    pub zero_velocity: usize,
    /// See `zero_velocity`.
    pub zero_velocity_chi2: f64,
}

/// Whether residual statistics pass the χ² test at significance `alpha`: the whole cost (IMU,
/// the AoA factors' robust cost, barometer, range anchors, zero-velocity holds) against χ² with
/// as many degrees of freedom as measurements beyond the IMU chain's own (the IMU factors alone
/// are met exactly by any trajectory: each adds as many residuals as states; a bearing counts
/// its share, `bearing_dof`), less the border's `border_dim` unknowns. The zero-velocity holds
/// add no degrees of freedom either: their σ is a tolerance, not a noise, and their near-zero
/// residuals would let a wrong window pass.
pub fn passes_chi2(fit: &FitStats, border_dim: usize, alpha: f64) -> bool {
    let dof = (fit.bearing_dof + (fit.baro + fit.anchors) as f64 - border_dim as f64).max(0.0);
    let cost = fit.imu_chi2
        + fit.bearing_robust
        + fit.baro_chi2
        + fit.anchor_chi2
        + fit.zero_velocity_chi2;
    dof <= 0.0 || cost <= chi2_upper(dof, alpha)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thousand bearings each worth a fiftieth of an independent one are tested as χ² with
    /// 20 degrees of freedom (less the border), not a thousand.
    #[test]
    fn bearings_count_their_share_of_the_degrees_of_freedom() {
        let fit = |cost: f64| FitStats {
            bearings: 1000,
            bearing_dof: 20.0,
            bearing_robust: cost,
            ..FitStats::default()
        };
        let bound = chi2_upper(17.0, 1e-3);
        assert!(passes_chi2(&fit(bound - 0.1), 3, 1e-3));
        assert!(!passes_chi2(&fit(bound + 0.1), 3, 1e-3));
        // No degrees of freedom left: nothing to test.
        assert!(passes_chi2(&fit(1e9), 25, 1e-3));
    }
}
