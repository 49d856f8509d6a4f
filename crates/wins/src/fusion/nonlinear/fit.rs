//! The window's residual statistics and the Cauchy loss its bearings are weighed by.

/// Residual statistics of the window at its estimate (whitened: in units of each σ).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FitStats {
    /// Σ rᵀ Λ r over the IMU factors.
    pub imu_chi2: f64,
    /// Number of IMU residual components (15 per factor).
    pub imu_dof: usize,
    /// Number of AoA residuals.
    pub bearings: usize,
    /// Σ e² over the AoA residuals.
    pub bearing_chi2: f64,
    /// Σ ρ(e²) over the AoA residuals (Cauchy).
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

/// Cauchy loss `ρ(s) = c² ln(1 + s/c²)` on a squared whitened residual `s`, and its IRLS weight
/// `ρ'(s) = 1 / (1 + s/c²)`.
pub fn cauchy(s: f64, c: f64) -> (f64, f64) {
    let c2 = c * c;
    (c2 * (s / c2).ln_1p(), 1.0 / (1.0 + s / c2))
}
