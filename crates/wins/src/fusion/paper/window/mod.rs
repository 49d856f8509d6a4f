//! The linear sliding-window estimator (paper Sec. V, `eqn:cost`).
//!
//! Unknowns, all in the first PAoA frame `b0`: per frame `x_k = [p_k (in b0), v_k (in b_k),
//! g_k (in b_k)]`, then a border of the accelerometer and gyro biases `b_a`, `b_g` and every AP's
//! position `c_l`. Rotations `R_{b_k}^{b_0}` are chained from the gyro by the caller; with them
//! fixed every factor is linear ([`factors`]); the normal equations are an arrow matrix solved by
//! a block Cholesky ([`crate::fusion::arrow`]), assembled in `assemble`. When the window is full the oldest
//! frame is marginalized by the Schur complement of only the factors that touch it (its prior,
//! its IMU factor, its AoA factors) into a prior on the next frame and the border: with fixed
//! rotations and weights this is exact, so the window reproduces the batch solution (tested).
//!
//! Initialization-free: the first frame gets `p_0 = 0` (the translation gauge) and only weak
//! zero-mean priors on everything else (velocity, gravity, biases, APs). Until converged the AoA
//! rows are the paper's algebraic ones with a constant range λ, and no frame is marginalized (up to
//! [`WindowConfig::max_startup_frames`]). A convergence candidate is when every AP's marginal
//! position σ (largest axis) is below a threshold; then every row is re-linearized at the solution
//! as an angle (scale-free, see [`factors::aoa_info`]) and iterated, and the result is kept only if
//! plausible (`health`: AP ranges, angle-row σ, residuals; else the startup solution is restored
//! and the candidate retried later). Once converged the gyro bias joins as an unknown (rotations
//! `R̂_k Exp(Ψ_k δb_g)`, first order), and the window shrinks to
//! [`WindowConfig::max_frames`] with [`WindowConfig::iterations`] Gauss–Newton steps per frame. A
//! converged window whose bearings stop fitting reports itself lost ([`SlidingWindow::is_lost`]);
//! the estimator then starts a new one. An IMU factor is re-linearized only when its
//! linearization point has moved by more than a small fraction of its noise (`assemble`): the 3-AP
//! replay's estimator time fell from 0.64 to 0.55 s with it, and its ATE mean moved by 0.7 mm.

mod assemble;
mod config;
pub mod factors;
mod health;
mod marginalize;
mod readout;

use std::cell::RefCell;
use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector, Matrix3, UnitQuaternion, Vector3};

use self::assemble::{ImuLinearization, ap_offset};
pub use self::config::{MAX_STARTUP_FRAMES, WindowConfig};
use self::factors::{BIAS_DIM, ImuInfo};
use crate::fusion::arrow::{ArrowSystem, FRAME_DIM, Vec9};
use crate::fusion::bearing::Bearing;
use crate::fusion::error::FrameError;
pub use crate::fusion::proposal::{FrameEstimate, StartPrior};
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::so3::exp;
use crate::time::Timestamp;

#[derive(Clone, Debug)]
struct Frame {
    t: Timestamp,
    b0_from_bk: UnitQuaternion<f64>,
    /// IMU interval from the previous frame (None for the very first frame).
    from_prev: Option<Preintegrated>,
    bearings: Vec<Bearing>,
    x: Vec9,
    /// `Ψ_k = ∂R_k/∂b_g` and the gyro bias `b̂_k` the rotation was chained with:
    /// `R_k(b_g) ≈ R̂_k Exp(Ψ_k (b_g − b̂_k))`. `R̂_k` stays as given (its linearization point is
    /// fixed, as first-estimate Jacobians keep the marginal prior consistent); the estimate is
    /// [`Frame::rotation`].
    psi: Matrix3<f64>,
    gyro_lin: Vector3<f64>,

    /// Upward direction in `b_k` before the solution has a gravity (mean specific force).
    up_hint: Vector3<f64>,
    /// The IMU factor from the previous frame as last linearized, and where.
    imu_cache: RefCell<Option<(ImuLinearization, ImuInfo)>>,
}

impl Frame {
    /// `R_{b_k}^{b_0}` at the gyro bias `b_g`.
    fn rotation(&self, b_g: &Vector3<f64>) -> UnitQuaternion<f64> {
        self.b0_from_bk * exp(&(self.psi * (b_g - self.gyro_lin)))
    }

    /// The upward direction in `b_k` the AoA rows use: the solved gravity once it is plausible
    /// (and the linearization follows the solution), else the specific-force hint.
    fn up(&self, adaptive: bool) -> Vector3<f64> {
        let g = self.x.fixed_rows::<3>(6).into_owned();
        if adaptive && g.norm() > 5.0 {
            g
        } else {
            self.up_hint
        }
    }
}

/// The sliding window (module doc).
#[derive(Clone, Debug)]
pub struct SlidingWindow {
    config: WindowConfig,
    start: Option<StartPrior>,
    frames: VecDeque<Frame>,
    num_aps: usize,
    /// Prior over `[first frame, border]` in information form (border may be shorter than now).
    prior: InformationPrior,
    border: DVector<f64>,
    border_covariance: DMatrix<f64>,
    gyro_bias_rad_s: Vector3<f64>,
    solved_once: bool,
    /// Convergence and its checks.
    health: Health,
    /// Frames added since the last solve (before convergence not every frame is solved).
    unsolved_frames: usize,
    marginalized: usize,
}

/// A prior in information form: `H`, `b`.
#[derive(Clone, Debug)]
struct InformationPrior {
    h: DMatrix<f64>,
    b: DVector<f64>,
}

/// The window's convergence and its checks.
#[derive(Clone, Debug, Default)]
struct Health {
    /// When the window converged.
    converged_at: Option<Timestamp>,
    /// No candidate convergence before this (after a rejected one).
    retry_after: Option<Timestamp>,
    /// Candidate convergences rejected.
    rejected_candidates: u64,
    /// Converged frames in a row whose bearings did not fit (see `lost_residual_rms`).
    misfit_in_row: usize,
}

impl SlidingWindow {
    /// An empty window.
    pub fn new(config: WindowConfig) -> Self {
        Self {
            config,
            start: None,
            frames: VecDeque::new(),
            num_aps: 0,
            prior: InformationPrior {
                h: DMatrix::zeros(0, 0),
                b: DVector::zeros(0),
            },
            border: DVector::zeros(BIAS_DIM),
            border_covariance: DMatrix::zeros(BIAS_DIM, BIAS_DIM),
            gyro_bias_rad_s: Vector3::zeros(),
            solved_once: false,
            health: Health::default(),
            unsolved_frames: 0,
            marginalized: 0,
        }
    }

    /// The settings.
    pub fn config(&self) -> &WindowConfig {
        &self.config
    }

    /// An empty window whose first frame starts from `start` instead of zero-mean priors.
    pub fn with_start(config: WindowConfig, start: StartPrior) -> Self {
        let mut w = Self::new(config);
        w.gyro_bias_rad_s = start.gyro_bias_rad_s;
        w.start = Some(start);
        w
    }

    /// Appends a frame at `t` with attitude `b0_from_bk`, the IMU interval from the previous
    /// frame (`None` only for the first frame) and the bearings measured there. APs get a state
    /// the first time their index appears. Call [`Self::solve`] afterwards.
    pub fn add_frame(
        &mut self,
        t: Timestamp,
        b0_from_bk: UnitQuaternion<f64>,
        from_prev: Option<Preintegrated>,
        bearings: Vec<Bearing>,
    ) -> Result<(), FrameError> {
        match (self.frames.back(), &from_prev) {
            (Some(_), None) => return Err(FrameError::MissingImu { t_ns: t.0 }),
            (Some(prev), Some(pre)) if pre.start != prev.t || pre.end != t => {
                return Err(FrameError::ImuMismatch {
                    start_ns: pre.start.0,
                    end_ns: pre.end.0,
                    prev_ns: prev.t.0,
                    t_ns: t.0,
                });
            }
            _ => {}
        }
        let first = self.frames.is_empty() && self.marginalized == 0;
        if first {
            let dim = FRAME_DIM + BIAS_DIM;
            self.prior.h = DMatrix::zeros(dim, dim);
            self.prior.b = DVector::zeros(dim);
            let c = &self.config;
            for i in 0..3 {
                self.prior.h[(i, i)] = c.gauge_sigma_m.powi(-2);
                self.prior.h[(3 + i, 3 + i)] = c.prior_velocity_sigma_m_s.powi(-2);
                self.prior.h[(6 + i, 6 + i)] = c.prior_gravity_sigma_m_s2.powi(-2);
                self.prior.h[(9 + i, 9 + i)] = c.prior_accel_bias_sigma_m_s2.powi(-2);
                self.prior.h[(12 + i, 12 + i)] = c.prior_gyro_bias_sigma_rad_s.powi(-2);
            }
            if let Some(s) = self.start {
                for i in 0..3 {
                    let hv = s.velocity_sigma_m_s.powi(-2);
                    let hg = s.gravity_sigma_m_s2.powi(-2);
                    self.prior.h[(3 + i, 3 + i)] = hv;
                    self.prior.h[(6 + i, 6 + i)] = hg;
                    self.prior.b[3 + i] = hv * s.velocity_in_b0[i];
                    self.prior.b[6 + i] = hg * s.gravity_in_b0[i];
                    self.prior.b[12 + i] = self.prior.h[(12 + i, 12 + i)] * s.gyro_bias_rad_s[i];
                }
                self.border
                    .fixed_rows_mut::<3>(3)
                    .copy_from(&s.gyro_bias_rad_s);
            }
        }
        let needed = bearings.iter().map(|b| b.ap + 1).max().unwrap_or(0);
        while self.num_aps < needed {
            self.add_ap();
        }
        // Predict the new frame's state from the previous one (a starting point for the noise
        // mapping only; the solve does not depend on it).
        let x = match (self.frames.back(), &from_prev) {
            (Some(prev), Some(pre)) => predict(prev, pre),
            _ => Vec9::zeros(),
        };
        // Ψ_k+1 = ΔR̂ᵀ Ψ_k + J_θg.
        let psi = match (self.frames.back(), &from_prev) {
            (Some(prev), Some(pre)) => {
                let d_r = pre.bk_from_bk1.to_rotation_matrix().into_inner();
                d_r.transpose() * prev.psi + pre.jacobian_bias.fixed_view::<3, 3>(6, 3)
            }
            _ => Matrix3::zeros(),
        };
        let up_hint = from_prev
            .as_ref()
            .map(nominal_gravity)
            .unwrap_or_else(Vector3::z);
        self.frames.push_back(Frame {
            t,
            b0_from_bk,
            from_prev,
            bearings,
            x,
            psi,
            gyro_lin: self.gyro_bias_rad_s,
            up_hint,
            imu_cache: RefCell::new(None),
        });
        Ok(())
    }

    fn add_ap(&mut self) {
        self.num_aps += 1;
        let old = self.prior.h.nrows();
        let new = old + 3;
        self.prior.h = self.prior.h.clone().resize(new, new, 0.0);
        self.prior.b = self.prior.b.clone().resize_vertically(new, 0.0);
        for i in old..new {
            self.prior.h[(i, i)] = self.config.prior_ap_sigma_m.powi(-2);
        }
        self.border = self
            .border
            .clone()
            .resize_vertically(ap_offset(self.num_aps), 0.0);
    }

    /// Solves the window (at the cadence of [`WindowConfig::startup_solve_every`] before
    /// convergence and [`WindowConfig::converged_solve_every`] after), then marginalizes frames
    /// beyond [`WindowConfig::max_frames`].
    pub fn solve(&mut self) -> Result<(), FrameError> {
        let was_converged = self.health.converged_at.is_some();
        let every = startup_solve_interval(
            self.frames.len(),
            self.config.startup_solve_every,
            self.config.startup_solves_per_window,
        );
        self.unsolved_frames += 1;
        if !was_converged && self.solved_once && self.unsolved_frames < every {
            return Ok(());
        }
        if was_converged && self.unsolved_frames < self.config.converged_solve_every {
            self.check_fit();
            self.trim();
            return Ok(());
        }
        self.unsolved_frames = 0;
        let iterations = if was_converged {
            self.config.iterations.max(1)
        } else {
            1
        };
        let mut result = self.iterate(iterations);
        if was_converged {
            self.check_fit();
        }
        let t = self.frames.back().map(|f| f.t);
        if result.is_ok()
            && !was_converged
            && self.num_aps > 0
            && self.max_ap_sigma_m() < self.config.converged_ap_sigma_m
            && t.zip(self.health.retry_after).is_none_or(|(t, r)| t >= r)
        {
            result = self.try_converge();
        }
        // The window stays bounded even when a solve failed (the previous estimate is kept).
        self.trim();
        result
    }

    /// Marginalizes the oldest frames beyond the window's length (the startup's while not
    /// converged).
    fn trim(&mut self) {
        let keep = if self.health.converged_at.is_some() {
            self.config.max_frames
        } else {
            self.config.max_startup_frames.max(self.config.max_frames)
        };
        while self.frames.len() > keep.max(2) {
            self.marginalize_oldest();
        }
    }

    fn iterate(&mut self, iterations: usize) -> Result<(), FrameError> {
        for _ in 0..iterations {
            let sys = self.build();
            let sol = sys.into_solution().ok_or(FrameError::NotPositiveDefinite)?;
            for (f, x) in self.frames.iter_mut().zip(sol.frames) {
                f.x = x;
            }
            self.border = sol.border;
            self.border_covariance = sol.border_covariance;
            self.solved_once = true;
            if self.gyro_active() {
                self.gyro_bias_rad_s = self.border.fixed_rows::<3>(3).into_owned();
            }
        }
        Ok(())
    }

    fn build(&self) -> ArrowSystem {
        self.assemble(self.frames.len(), false)
    }
}

/// Frames between solves before convergence, for a window of `frames` frames: every `every`
/// frames, and at most `per_window` times per window's length (a long startup would otherwise
/// cost O(n²)); at least 1.
fn startup_solve_interval(frames: usize, every: usize, per_window: usize) -> usize {
    every.max(frames / per_window.max(1)).max(1)
}

/// Upward gravity in `b_k+1` guessed from the interval's mean specific force (before any
/// solution exists; only the noise mapping uses it).
fn nominal_gravity(pre: &Preintegrated) -> Vector3<f64> {
    let dt = pre.dt_s().max(1e-6);
    let f = pre.bk_from_bk1.inverse() * (pre.beta / dt);
    if f.norm() > 1.0 {
        f.normalize() * STANDARD_GRAVITY_M_S2
    } else {
        Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2)
    }
}

/// The new frame's state propagated from the previous one with `eqn:linear_update`.
fn predict(prev: &Frame, pre: &Preintegrated) -> Vec9 {
    let dt = pre.dt_s();
    let p = prev.x.fixed_rows::<3>(0).into_owned();
    let v = prev.x.fixed_rows::<3>(3).into_owned();
    let g = prev.x.fixed_rows::<3>(6).into_owned();
    let r = prev.b0_from_bk;
    let dr_inv = pre.bk_from_bk1.inverse();
    let p1 = p + r * (v * dt - g * (0.5 * dt * dt) + pre.alpha);
    let v1 = dr_inv * (v - g * dt + pre.beta);
    let g1 = dr_inv * g;
    let mut x = Vec9::zeros();
    x.fixed_rows_mut::<3>(0).copy_from(&p1);
    x.fixed_rows_mut::<3>(3).copy_from(&v1);
    x.fixed_rows_mut::<3>(6).copy_from(&g1);
    x
}

#[cfg(test)]
mod tests;
