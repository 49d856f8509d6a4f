//! The data of a run's three figures (`wins run` draws them): the trajectory from above against
//! the truth with the APs, the position error over time, and the AoA per packet against the
//! truth. Only numbers here; drawing is the caller's (the CLI uses `wins-plot`).

pub use super::figure_data::{AoaSeries, Points, RunFigures};
use super::run_output::RunOutput;
use crate::dataset::truth::Truth;
use crate::eval::{EvalError, EvalOptions, Metrics, position_error_series};

impl RunOutput {
    /// The figures' data against `truth`, with `metrics` from [`RunOutput::score`] (its
    /// alignment).
    pub fn figures(
        &self,
        truth: &Truth,
        metrics: &Metrics,
        options: &EvalOptions,
    ) -> Result<RunFigures, EvalError> {
        let align = &metrics.alignment;
        let t0 = truth.poses.first().map_or(0.0, |p| p.t.as_secs_f64());
        let poses = self.converged_poses();
        let xy = |p: &nalgebra::Vector3<f64>| (p.x, p.y);
        let position_error = position_error_series(&poses, &truth.poses, options)?
            .iter()
            .map(|(t, e)| (t.as_secs_f64() - t0, *e))
            .collect();
        let pairs = self.aoa_vs_truth(truth);
        let aoa = self.aoa_series(&pairs, t0, |l| {
            truth.packets.get(l).map(|rows| {
                rows.iter()
                    .map(|r| (r.t_ns as f64 * 1e-9 - t0, r.aoa_deg))
                    .collect()
            })
        });
        Ok(RunFigures {
            truth_xy: truth.poses.iter().map(|p| xy(&p.p_b_in_w)).collect(),
            estimate_xy: poses
                .iter()
                .map(|p| xy(&align.apply_point(&p.p_b_in_w)))
                .collect(),
            truth_aps_xy: truth.aps.iter().map(|a| (a.x_m, a.y_m)).collect(),
            estimated_aps_xy: self
                .aps
                .iter()
                .map(|a| xy(&align.apply_point(&a.p_in_w)))
                .collect(),
            position_error,
            converged_s: self.converged_at.map(|t| t.as_secs_f64() - t0),
            aoa,
        })
    }

    /// Per AP its AoA series: the fed packets' `(AP, t, measured°, …)` in `pairs` less `t0`,
    /// and its truth from `truth_of(AP)` (times already less `t0`; none: empty).
    pub(super) fn aoa_series(
        &self,
        pairs: &[(usize, f64, f64, f64)],
        t0: f64,
        truth_of: impl Fn(usize) -> Option<Vec<(f64, f64)>>,
    ) -> Vec<AoaSeries> {
        self.stats
            .per_ap
            .iter()
            .enumerate()
            .map(|(l, s)| AoaSeries {
                name: s.name.clone(),
                measured: pairs
                    .iter()
                    .filter(|p| p.0 == l)
                    .map(|p| (p.1 - t0, p.2))
                    .collect(),
                truth: truth_of(l).unwrap_or_default(),
            })
            .collect()
    }
}
