//! The numbers of a run's three figures, as a run keeps them ([`super::figures`] computes them).

/// Points of a series, `(x, y)`.
pub type Points = Vec<(f64, f64)>;

/// One AP's AoA series.
#[derive(Clone, Debug, PartialEq)]
pub struct AoaSeries {
    /// The AP's name.
    pub name: String,
    /// Packets fed to the estimator: (time since the truth starts, s; AoA, degrees).
    pub measured: Points,
    /// The truth's direct-path AoA of every packet slot, same axes.
    pub truth: Points,
}

/// The figures' data (module doc). Positions are in the truth's world frame (the estimate
/// aligned by the metrics' alignment); times are seconds since the truth's first pose.
#[derive(Clone, Debug, PartialEq)]
pub struct RunFigures {
    /// Truth trajectory from above, (x, y) m.
    pub truth_xy: Points,
    /// Estimated trajectory after convergence, aligned, (x, y) m.
    pub estimate_xy: Points,
    /// True AP positions, (x, y) m.
    pub truth_aps_xy: Points,
    /// Estimated AP positions, aligned, (x, y) m.
    pub estimated_aps_xy: Points,
    /// Position error after alignment over time, (s, m).
    pub position_error: Points,
    /// When the estimate converged, s.
    pub converged_s: Option<f64>,
    /// Per AP (the run's order).
    pub aoa: Vec<AoaSeries>,
}
