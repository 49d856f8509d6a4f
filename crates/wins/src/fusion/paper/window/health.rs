//! Is the window's estimate believable? The convergence test's second stage (a candidate is
//! re-linearized and kept only if plausible), a convergence declared from outside
//! ([`SlidingWindow::converge_from`]) and the lost test after convergence.

use nalgebra::Vector3;

use super::SlidingWindow;
use super::assemble::ap_offset;
use super::factors::{AoaFactorInput, AoaPoint, aoa_residuals};
use crate::fusion::arrow::Vec9;
use crate::fusion::error::FrameError;
use crate::time::Timestamp;

impl SlidingWindow {
    /// Declares the window converged at a state given from outside (surveyed AP positions and a
    /// motion-capture fix, or the truth of a simulation) instead of its own startup: every
    /// frame's `[p in b0, v in b_k, upward g in b_k]` from `state_of(t)`, the first
    /// `aps_in_b0.len()` APs (at most [`Self::num_aps`]) as given, biases kept; then the rows are
    /// re-linearized as after a convergence of its own and `iterations` Gauss–Newton steps taken.
    /// The window's priors are weak (zero-centred), so the result is the estimate the data
    /// support near that state: started at the truth, it measures what the data can give.
    pub fn converge_from(
        &mut self,
        state_of: &dyn Fn(Timestamp) -> Vec9,
        aps_in_b0: &[Vector3<f64>],
        iterations: usize,
    ) -> Result<(), FrameError> {
        for f in self.frames.iter_mut() {
            f.x = state_of(f.t);
        }
        for (l, a) in aps_in_b0.iter().enumerate().take(self.num_aps) {
            self.border.fixed_rows_mut::<3>(ap_offset(l)).copy_from(a);
        }
        self.solved_once = true;
        self.health.converged_at = self.frames.back().map(|f| f.t);
        self.iterate(iterations.max(1))
    }

    /// A candidate convergence: re-linearizes every frame kept since the start at the solution
    /// (angle rows, gyro bias) and keeps it only if the result is plausible
    /// ([`Self::plausible`]); else restores the startup solution and retries after
    /// [`super::WindowConfig::convergence_retry_s`] (doubling, see
    /// [`super::WindowConfig::convergence_retry_max_s`]).
    pub(super) fn try_converge(&mut self) -> Result<(), FrameError> {
        let saved = (
            self.frames.iter().map(|f| f.x).collect::<Vec<_>>(),
            self.border.clone(),
            self.border_covariance.clone(),
            self.gyro_bias_rad_s,
        );
        let t = self.frames.back().map(|f| f.t);
        self.health.converged_at = t;
        let result = self.iterate(self.config.iterations_at_convergence.max(1));
        if result.is_ok() && self.plausible() {
            return Ok(());
        }
        let (xs, border, cov, gyro) = saved;
        for (f, x) in self.frames.iter_mut().zip(xs) {
            f.x = x;
        }
        self.border = border;
        self.border_covariance = cov;
        self.gyro_bias_rad_s = gyro;
        self.health.converged_at = None;
        self.health.rejected_candidates += 1;
        let c = &self.config;
        let doublings = self.health.rejected_candidates.saturating_sub(2).min(16) as i32;
        let wait_s = (c.convergence_retry_s * 2f64.powi(doublings))
            .min(c.convergence_retry_max_s.max(c.convergence_retry_s));
        self.health.retry_after = t.map(|t| Timestamp(t.0 + (wait_s * 1e9).round() as i64));
        result
    }

    /// Whether a re-linearized solution is believable: every AP between
    /// [`super::WindowConfig::converged_min_range_m`] and the upper
    /// [`super::WindowConfig::range_limits_m`] from the newest frame, its angle-row σ below
    /// [`super::WindowConfig::converged_ap_sigma_after_m`], and the bearings fitting within
    /// [`super::WindowConfig::converged_max_residual_rms`] of their σ.
    fn plausible(&self) -> bool {
        let c = &self.config;
        let (lo, hi) = (c.converged_min_range_m, c.range_limits_m.1);
        self.ap_ranges_m().iter().all(|r| (lo..=hi).contains(r))
            && self.max_ap_sigma_m() <= c.converged_ap_sigma_after_m
            && self
                .aoa_residual_rms()
                .is_some_and(|rms| rms <= c.converged_max_residual_rms)
    }

    /// Each AP's distance from the newest frame, m.
    fn ap_ranges_m(&self) -> Vec<f64> {
        let Some(p) = self
            .frames
            .back()
            .map(|f| f.x.fixed_rows::<3>(0).into_owned())
        else {
            return Vec::new();
        };
        (0..self.num_aps)
            .filter_map(|l| self.ap_in_b0(l))
            .map(|c| (c - p).norm())
            .collect()
    }

    /// Whether the converged estimate has been lost (see [`super::WindowConfig::lost_residual_rms`]);
    /// checked after every solve, the caller starts a new window.
    pub fn is_lost(&self) -> bool {
        self.health.converged_at.is_some()
            && self.health.misfit_in_row >= self.config.lost_after_frames.max(1)
    }

    /// Converged frames in a row, up to now, whose bearings did not fit (0 when the last one
    /// did; see [`super::WindowConfig::lost_residual_rms`]).
    pub fn misfit_frames(&self) -> usize {
        self.health.misfit_in_row
    }

    /// Updates the lost test after a converged solve.
    pub(super) fn check_fit(&mut self) {
        let c = &self.config;
        let finite = self.border.iter().all(|v| v.is_finite())
            && self
                .frames
                .iter()
                .all(|f| f.x.iter().all(|v| v.is_finite()));
        let in_range = self.ap_ranges_m().iter().all(|r| *r <= c.range_limits_m.1);
        if !finite || !in_range {
            self.health.misfit_in_row = usize::MAX;
        } else if self
            .aoa_residual_rms()
            .is_some_and(|rms| rms > c.lost_residual_rms)
        {
            self.health.misfit_in_row = self.health.misfit_in_row.saturating_add(1);
        } else {
            self.health.misfit_in_row = 0;
        }
    }

    /// Candidate convergences rejected as implausible so far.
    pub fn rejected_candidates(&self) -> u64 {
        self.health.rejected_candidates
    }

    /// Root mean square of the AoA rows' residuals over the window, each in units of its σ, as
    /// angles at the current solution (1 when the bearings fit as well as their σ says); `None`
    /// without AoA rows.
    pub fn aoa_residual_rms(&self) -> Option<f64> {
        let c = &self.config;
        let gyro_b = self.gyro_bias_rad_s;
        let (mut sum, mut n) = (0.0, 0usize);
        for f in &self.frames {
            let up = f.up(c.adaptive_weights);
            let p = f.x.fixed_rows::<3>(0).into_owned();
            let r = f.rotation(&gyro_b);
            for b in f.bearings.iter().filter(|b| b.is_valid()) {
                let Some(ap) = self.ap_in_b0(b.ap) else {
                    continue;
                };
                let x = ap - p - r * c.body_from_array.translation.vector;
                if x.norm() < c.range_limits_m.0 {
                    continue;
                }
                let Some((rows, len)) = aoa_residuals(&AoaFactorInput {
                    bearing: b,
                    b0_from_bj: &r,
                    up_in_bj: &up,
                    body_from_array: &c.body_from_array,
                    point: AoaPoint::At(x),
                    gyro: None,
                    sigmas: self.aoa_sigmas(),
                }) else {
                    continue;
                };
                for (e, var) in &rows[..len] {
                    sum += e * e / var;
                    n += 1;
                }
            }
        }
        (n > 0).then(|| (sum / n as f64).sqrt())
    }
}
