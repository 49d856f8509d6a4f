//! The data of a run's three figures (`wins run` draws them): the trajectory from above against
//! the truth with the APs, the position error over time, and the AoA per packet against the
//! truth. Only numbers here, computed by the scoring ([`RunOutput::score_against`](super::run_output::RunOutput::score_against)); drawing is the
//! caller's (the CLI uses `wins-plot`).

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
