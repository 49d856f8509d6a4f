//! Settings of the sliding window (the `[window]` table of a configuration) and their ranges.

use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use crate::check::Problems;

/// Settings of the window (the `[window]` table of a configuration). Three fields describe the
/// rig rather than the estimator and are not read from a file: `body_from_array`, and the bias
/// priors, set from the IMU's turn-on spreads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindowConfig {
    /// Frames kept before the oldest is marginalized (paper: 30).
    pub max_frames: usize,
    /// Frames kept before the estimate has converged (none is marginalized until then, so the
    /// early rows are re-linearized at the converged solution), at most.
    pub max_startup_frames: usize,
    /// The range λ assumed for every AoA row until the estimate has converged, m.
    pub initial_range_m: f64,
    /// Ranges from the solution are clamped to this interval, m.
    pub range_limits_m: (f64, f64),
    /// 1σ of the zero-elevation assumption (AP in the array's `a_x a_y` plane), rad.
    pub elevation_sigma_rad: f64,
    /// 1σ of the attitude from the attitude stage, rad (enters the α and AoA rows).
    pub attitude_sigma_rad: f64,
    /// Weak priors of the first frame: velocity and gravity 1σ per axis (zero mean).
    pub prior_velocity_sigma_m_s: f64,
    /// See `prior_velocity_sigma_m_s`.
    pub prior_gravity_sigma_m_s2: f64,
    /// Prior 1σ of a new AP's position per axis, around the first frame, m.
    pub prior_ap_sigma_m: f64,
    /// Prior 1σ of the accelerometer bias per axis, m/s² (from the rig's IMU: its turn-on spread).
    #[serde(skip)]
    pub prior_accel_bias_sigma_m_s2: f64,
    /// Prior 1σ of the gyro bias per axis, rad/s (from the rig's IMU: its turn-on spread).
    #[serde(skip)]
    pub prior_gyro_bias_sigma_rad_s: f64,
    /// Estimate the gyro bias jointly once converged (removes the attitude's gyro drift); off:
    /// the rotations are the gyro chain as given.
    pub estimate_gyro_bias: bool,
    /// 1σ of the translation gauge `p_0 = 0`, m.
    pub gauge_sigma_m: f64,
    /// A convergence candidate when every AP's largest marginal position σ (algebraic rows) is
    /// below this, m.
    pub converged_ap_sigma_m: f64,
    /// The candidate is accepted when, re-linearized as angles, every AP's σ is below this, m,
    /// and the next two tests pass.
    pub converged_ap_sigma_after_m: f64,
    /// The bearings' residual RMS (in units of their σ) must be below this.
    pub converged_max_residual_rms: f64,
    /// Every AP must be at least this far from the newest frame, m (a collapsed AP fits its
    /// bearings trivially).
    pub converged_min_range_m: f64,
    /// After convergence, the estimate is declared lost when the bearings' residual RMS (in
    /// units of their σ) stays above this for [`Self::lost_after_frames`] frames in a row, or at
    /// once when a state is not finite or an AP leaves [`Self::range_limits_m`]'s upper bound.
    pub lost_residual_rms: f64,
    /// See `lost_residual_rms`.
    pub lost_after_frames: usize,
    /// After a rejected candidate, the next is tried this much later, s.
    pub convergence_retry_s: f64,
    /// From the third rejected candidate on, the wait doubles up to this, s: each candidate
    /// iterates the whole startup window, so a flight that cannot converge (no excitation, a
    /// gyro bias beyond the startup's reach) must not spend its time on them.
    pub convergence_retry_max_s: f64,
    /// Pose of the antenna array on the body (from the rig).
    #[serde(skip)]
    pub body_from_array: Isometry3<f64>,
    /// Refresh the linearization from the solution (AoA ranges after convergence, the upward
    /// direction of the AoA rows, the IMU noise mapping at the previous estimate). Off: constant ranges and a nominal mapping, so the weights never
    /// depend on the data and the window equals the batch solution exactly.
    pub adaptive_weights: bool,
    /// After convergence, linearize the AoA rows as angles at the solution (scale-free) instead
    /// of the algebraic rows (see `factors::aoa_info`).
    pub angle_rows: bool,
    /// With `angle_rows`, the exact cone row of a linear array (`âᵀ x / |x| = sin θ`, no AP
    /// height assumed) instead of the horizontal model's two rows.
    pub cone_rows: bool,

    /// Gauss–Newton iterations per solve once converged (≥ 1).
    pub iterations: usize,
    /// Gauss–Newton iterations over the whole startup window when it converges.
    pub iterations_at_convergence: usize,
    /// Before convergence, solve only every this many frames (≥ 1), or every
    /// 1/[`Self::startup_solves_per_window`] of the window's length when that is more: the
    /// startup window grows without marginalization, so solving it at every frame costs O(n²)
    /// over the startup, and its poses are not usable before convergence anyway. Convergence is
    /// noticed up to that many frames late.
    pub startup_solve_every: usize,
    /// Before convergence, at most this many solves per window's length (≥ 1; 50: every 2 %).
    /// As the default estimator's start solver, whose solution is read only when a start is
    /// tried, it is set to the tries' own cadence
    /// ([`crate::fusion::nonlinear::NonlinearConfig::start_retry_share`]).
    pub startup_solves_per_window: usize,
    /// After convergence, solve only every this many frames (≥ 1); the frames between keep the
    /// IMU's prediction from the last solve, are still marginalized and checked by the lost test.
    /// 2 (a solve every 40 ms on the default 20 ms frame grid) keeps a three-AP replay above
    /// 100× real time; 1 is about 1–3 % more accurate and 15 % slower (docs/RESULTS.md).
    pub converged_solve_every: usize,
}

impl Default for WindowConfig {
    fn default() -> Self {
        Self {
            max_frames: 30,
            max_startup_frames: 1500,
            initial_range_m: 5.0,
            range_limits_m: (0.5, 100.0),
            elevation_sigma_rad: 5f64.to_radians(),
            attitude_sigma_rad: 0.3f64.to_radians(),
            prior_velocity_sigma_m_s: 10.0,
            prior_gravity_sigma_m_s2: 20.0,
            prior_ap_sigma_m: 100.0,
            prior_accel_bias_sigma_m_s2: 0.02,
            prior_gyro_bias_sigma_rad_s: 0.02,
            estimate_gyro_bias: true,
            gauge_sigma_m: 1e-3,
            converged_ap_sigma_m: 0.25,
            converged_ap_sigma_after_m: 1.5,
            converged_max_residual_rms: 2.0,
            converged_min_range_m: 1.0,
            convergence_retry_s: 1.0,
            convergence_retry_max_s: 8.0,
            lost_residual_rms: 4.0,
            lost_after_frames: 25,
            body_from_array: Isometry3::identity(),
            adaptive_weights: true,
            angle_rows: true,
            cone_rows: false,

            iterations: 1,
            iterations_at_convergence: 10,
            startup_solve_every: 10,
            startup_solves_per_window: 50,
            converged_solve_every: 2,
        }
    }
}

impl WindowConfig {
    /// Every setting in its range, under `prefix` (the rig's fields are not checked here).
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.at_least(prefix, "max_frames", self.max_frames, 2);
        p.require(
            self.max_startup_frames >= self.max_frames,
            prefix,
            "max_startup_frames",
            format!(
                "{} is below max_frames {}",
                self.max_startup_frames, self.max_frames
            ),
        );
        p.require(
            self.max_startup_frames <= MAX_STARTUP_FRAMES,
            prefix,
            "max_startup_frames",
            format!("{} is above {MAX_STARTUP_FRAMES}", self.max_startup_frames),
        );
        p.positive(prefix, "initial_range_m", self.initial_range_m);
        let (lo, hi) = self.range_limits_m;
        p.require(
            lo.is_finite() && hi.is_finite() && lo > 0.0 && lo < hi,
            prefix,
            "range_limits_m",
            format!("[{lo}, {hi}] is not 0 < min < max"),
        );
        for (key, v) in [
            ("elevation_sigma_rad", self.elevation_sigma_rad),
            ("attitude_sigma_rad", self.attitude_sigma_rad),
            ("prior_velocity_sigma_m_s", self.prior_velocity_sigma_m_s),
            ("prior_gravity_sigma_m_s2", self.prior_gravity_sigma_m_s2),
            ("prior_ap_sigma_m", self.prior_ap_sigma_m),
            ("gauge_sigma_m", self.gauge_sigma_m),
            ("converged_ap_sigma_m", self.converged_ap_sigma_m),
            (
                "converged_ap_sigma_after_m",
                self.converged_ap_sigma_after_m,
            ),
            (
                "converged_max_residual_rms",
                self.converged_max_residual_rms,
            ),
            ("converged_min_range_m", self.converged_min_range_m),
            ("lost_residual_rms", self.lost_residual_rms),
            ("convergence_retry_s", self.convergence_retry_s),
        ] {
            p.positive(prefix, key, v);
        }
        p.require(
            self.convergence_retry_max_s.is_finite()
                && self.convergence_retry_max_s >= self.convergence_retry_s,
            prefix,
            "convergence_retry_max_s",
            format!(
                "{} is below convergence_retry_s {}",
                self.convergence_retry_max_s, self.convergence_retry_s
            ),
        );
        p.at_least(prefix, "lost_after_frames", self.lost_after_frames, 1);
        p.at_least(prefix, "iterations", self.iterations, 1);
        p.at_least(
            prefix,
            "iterations_at_convergence",
            self.iterations_at_convergence,
            1,
        );
        p.at_least(prefix, "startup_solve_every", self.startup_solve_every, 1);
        p.at_least(
            prefix,
            "startup_solves_per_window",
            self.startup_solves_per_window,
            1,
        );
        p.at_least(
            prefix,
            "converged_solve_every",
            self.converged_solve_every,
            1,
        );
        p.require(
            !self.cone_rows || self.angle_rows,
            prefix,
            "cone_rows",
            "needs angle_rows = true",
        );
        p
    }
}

/// Most frames a startup window may hold (its normal equations grow with it).
pub const MAX_STARTUP_FRAMES: usize = 100_000;
