//! The linear sliding-window estimator (paper Sec. V, `eqn:cost`).
//!
//! Unknowns, all in the first PAoA frame `b0`: per frame `x_k = [p_k (in b0), v_k (in b_k),
//! g_k (in b_k)]`, then a border of the accelerometer bias `b_a` and every AP's position `c_l`.
//! Rotations `R_{b_k}^{b_0}` come from the attitude stage, so every factor is linear
//! ([`factors`]); the normal equations are an arrow matrix solved by a block Cholesky
//! ([`arrow`]). When the window is full the oldest frame is marginalized by the Schur complement
//! of only the factors that touch it (its prior, its IMU factor, its AoA factors) into a prior on
//! the next frame and the border: with fixed rotations and weights this is exact, so the window
//! reproduces the batch solution over all frames (tested).
//!
//! Initialization-free: the first frame gets `p_0 = 0` (the translation gauge) and only weak
//! zero-mean priors on everything else (velocity, gravity, bias, APs); the AP ranges λ that weight
//! the AoA rows start at a constant and follow the solution once it has converged. Converged means
//! every AP's marginal position σ (largest axis) is below a threshold.

pub mod arrow;
pub mod factors;
mod marginalize;

use std::collections::VecDeque;
use std::ops::AddAssign;

use nalgebra::{DMatrix, DVector, Isometry3, UnitQuaternion, Vector3};

use self::arrow::{ArrowSystem, FRAME_DIM, Vec9};
use self::factors::{AoaInfo, ImuFactorInput, ImuInfo, aoa_info, imu_info};
use crate::fusion::bearing::Bearing;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::time::Timestamp;

/// Settings of the window.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowConfig {
    /// Frames kept before the oldest is marginalized (paper: 30).
    pub max_frames: usize,
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
    /// Prior 1σ of the accelerometer bias per axis, m/s².
    pub prior_accel_bias_sigma_m_s2: f64,
    /// 1σ of the translation gauge `p_0 = 0`, m.
    pub gauge_sigma_m: f64,
    /// Converged when every AP's largest marginal position σ is below this, m.
    pub converged_ap_sigma_m: f64,
    /// Pose of the antenna array on the body.
    pub body_from_array: Isometry3<f64>,
    /// Refresh the linearization from the solution (AoA ranges after convergence, the upward
    /// direction of the AoA rows, the IMU noise mapping at the previous estimate). Off: constant ranges and a nominal mapping, so the weights never
    /// depend on the data and the window equals the batch solution exactly.
    pub adaptive_weights: bool,
}

impl Default for WindowConfig {
    fn default() -> Self {
        Self {
            max_frames: 30,
            initial_range_m: 5.0,
            range_limits_m: (0.5, 100.0),
            elevation_sigma_rad: 5f64.to_radians(),
            attitude_sigma_rad: 0.3f64.to_radians(),
            prior_velocity_sigma_m_s: 10.0,
            prior_gravity_sigma_m_s2: 20.0,
            prior_ap_sigma_m: 100.0,
            prior_accel_bias_sigma_m_s2: 0.02,
            gauge_sigma_m: 1e-3,
            converged_ap_sigma_m: 0.25,
            body_from_array: Isometry3::identity(),
            adaptive_weights: true,
        }
    }
}

/// Why the window refused an input or could not solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WindowError {
    /// A frame after the first came without the IMU interval from the previous frame.
    #[error("frame at {t_ns} ns has no IMU interval from the previous frame")]
    MissingImu {
        /// Frame time, ns.
        t_ns: i64,
    },
    /// The IMU interval does not join the previous frame to this one.
    #[error(
        "IMU interval {start_ns}…{end_ns} ns does not join the frames at {prev_ns} and {t_ns} ns"
    )]
    ImuMismatch {
        /// Interval start, ns.
        start_ns: i64,
        /// Interval end, ns.
        end_ns: i64,
        /// Previous frame, ns.
        prev_ns: i64,
        /// This frame, ns.
        t_ns: i64,
    },
    /// The normal equations were not positive definite (degenerate input).
    #[error("the normal equations are not positive definite")]
    NotPositiveDefinite,
}

/// One frame's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameEstimate {
    /// Frame time.
    pub t: Timestamp,
    /// `p_k` in `b0`, m.
    pub p_in_b0: Vector3<f64>,
    /// `v_k` in `b_k`, m/s.
    pub v_in_bk: Vector3<f64>,
    /// Upward gravity `g_k` in `b_k`, m/s².
    pub g_in_bk: Vector3<f64>,
    /// `R_{b_k}^{b_0}`.
    pub b0_from_bk: UnitQuaternion<f64>,
}

#[derive(Clone, Debug)]
struct Frame {
    t: Timestamp,
    b0_from_bk: UnitQuaternion<f64>,
    /// IMU interval from the previous frame (None for the very first frame).
    from_prev: Option<Preintegrated>,
    bearings: Vec<Bearing>,
    x: Vec9,
    /// Upward direction in `b_k` before the solution has a gravity (mean specific force).
    up_hint: Vector3<f64>,
}

impl Frame {
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
    frames: VecDeque<Frame>,
    num_aps: usize,
    /// Prior over `[first frame, border]` in information form (border may be shorter than now).
    prior_h: DMatrix<f64>,
    prior_b: DVector<f64>,
    border: DVector<f64>,
    border_covariance: DMatrix<f64>,
    gyro_bias_rad_s: Vector3<f64>,
    solved_once: bool,
    converged_at: Option<Timestamp>,
    marginalized: usize,
}

impl SlidingWindow {
    /// An empty window.
    pub fn new(config: WindowConfig) -> Self {
        Self {
            config,
            frames: VecDeque::new(),
            num_aps: 0,
            prior_h: DMatrix::zeros(0, 0),
            prior_b: DVector::zeros(0),
            border: DVector::zeros(3),
            border_covariance: DMatrix::zeros(3, 3),
            gyro_bias_rad_s: Vector3::zeros(),
            solved_once: false,
            converged_at: None,
            marginalized: 0,
        }
    }

    /// The settings.
    pub fn config(&self) -> &WindowConfig {
        &self.config
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
    ) -> Result<(), WindowError> {
        match (self.frames.back(), &from_prev) {
            (Some(_), None) => return Err(WindowError::MissingImu { t_ns: t.0 }),
            (Some(prev), Some(pre)) if pre.start != prev.t || pre.end != t => {
                return Err(WindowError::ImuMismatch {
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
            self.prior_h = DMatrix::zeros(FRAME_DIM + 3, FRAME_DIM + 3);
            self.prior_b = DVector::zeros(FRAME_DIM + 3);
            let c = &self.config;
            for i in 0..3 {
                self.prior_h[(i, i)] = c.gauge_sigma_m.powi(-2);
                self.prior_h[(3 + i, 3 + i)] = c.prior_velocity_sigma_m_s.powi(-2);
                self.prior_h[(6 + i, 6 + i)] = c.prior_gravity_sigma_m_s2.powi(-2);
                self.prior_h[(9 + i, 9 + i)] = c.prior_accel_bias_sigma_m_s2.powi(-2);
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
            up_hint,
        });
        Ok(())
    }

    fn add_ap(&mut self) {
        self.num_aps += 1;
        let old = self.prior_h.nrows();
        let new = old + 3;
        self.prior_h = self.prior_h.clone().resize(new, new, 0.0);
        self.prior_b = self.prior_b.clone().resize_vertically(new, 0.0);
        for i in old..new {
            self.prior_h[(i, i)] = self.config.prior_ap_sigma_m.powi(-2);
        }
        self.border = self
            .border
            .clone()
            .resize_vertically(3 + 3 * self.num_aps, 0.0);
    }

    /// Sets the attitude of window frame `i` (0 = oldest in the window).
    pub fn set_rotation(&mut self, i: usize, b0_from_bk: UnitQuaternion<f64>) {
        if let Some(f) = self.frames.get_mut(i) {
            f.b0_from_bk = b0_from_bk;
        }
    }

    /// Sets the gyro bias the IMU intervals are corrected to.
    pub fn set_gyro_bias(&mut self, gyro_bias_rad_s: Vector3<f64>) {
        self.gyro_bias_rad_s = gyro_bias_rad_s;
    }

    /// Solves the window, then marginalizes frames beyond [`WindowConfig::max_frames`].
    pub fn solve(&mut self) -> Result<(), WindowError> {
        let sys = self.build();
        let sol = sys.solve().ok_or(WindowError::NotPositiveDefinite)?;
        for (f, x) in self.frames.iter_mut().zip(sol.frames) {
            f.x = x;
        }
        self.border = sol.border;
        self.border_covariance = sol.border_covariance;
        self.solved_once = true;
        if self.converged_at.is_none()
            && self.num_aps > 0
            && self.max_ap_sigma_m() < self.config.converged_ap_sigma_m
        {
            self.converged_at = self.frames.back().map(|f| f.t);
        }
        while self.frames.len() > self.config.max_frames.max(2) {
            self.marginalize_oldest();
        }
        Ok(())
    }

    /// Largest marginal position σ over the APs (largest eigenvalue of each 3×3 block), m;
    /// infinite without APs.
    pub fn max_ap_sigma_m(&self) -> f64 {
        (0..self.num_aps)
            .map(|l| {
                let o = 3 + 3 * l;
                let block = self.border_covariance.fixed_view::<3, 3>(o, o).into_owned();
                block.symmetric_eigenvalues().max().max(0.0).sqrt()
            })
            .fold(
                if self.num_aps == 0 {
                    f64::INFINITY
                } else {
                    0.0
                },
                f64::max,
            )
    }

    /// When the estimate first converged (module doc), if it has.
    pub fn converged_at(&self) -> Option<Timestamp> {
        self.converged_at
    }

    /// Frames in the window, oldest first.
    pub fn frames(&self) -> impl Iterator<Item = FrameEstimate> + '_ {
        self.frames.iter().map(|f| FrameEstimate {
            t: f.t,
            p_in_b0: f.x.fixed_rows::<3>(0).into_owned(),
            v_in_bk: f.x.fixed_rows::<3>(3).into_owned(),
            g_in_bk: f.x.fixed_rows::<3>(6).into_owned(),
            b0_from_bk: f.b0_from_bk,
        })
    }

    /// Per window frame: the IMU interval from the previous frame (None for the oldest frame of
    /// the very first window), the bearings, and the upward direction the AoA rows use.
    pub fn frame_inputs(
        &self,
    ) -> impl Iterator<Item = (Option<&Preintegrated>, &[Bearing], Vector3<f64>)> + '_ {
        let adaptive = self.config.adaptive_weights;
        self.frames
            .iter()
            .map(move |f| (f.from_prev.as_ref(), f.bearings.as_slice(), f.up(adaptive)))
    }

    /// The gyro bias the IMU intervals are corrected to, rad/s.
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        self.gyro_bias_rad_s
    }

    /// The newest frame.
    pub fn latest(&self) -> Option<FrameEstimate> {
        self.frames().last()
    }

    /// Number of frames in the window.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the window has no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frames marginalized so far.
    pub fn marginalized(&self) -> usize {
        self.marginalized
    }

    /// Number of APs with a state.
    pub fn num_aps(&self) -> usize {
        self.num_aps
    }

    /// AP `l`'s position in `b0`, m.
    pub fn ap_in_b0(&self, l: usize) -> Option<Vector3<f64>> {
        (l < self.num_aps).then(|| self.border.fixed_rows::<3>(3 + 3 * l).into_owned())
    }

    /// AP `l`'s marginal position covariance, m².
    pub fn ap_covariance(&self, l: usize) -> Option<nalgebra::Matrix3<f64>> {
        let o = 3 + 3 * l;
        (l < self.num_aps).then(|| self.border_covariance.fixed_view::<3, 3>(o, o).into_owned())
    }

    /// The accelerometer bias estimate, m/s².
    pub fn accel_bias_m_s2(&self) -> Vector3<f64> {
        self.border.fixed_rows::<3>(0).into_owned()
    }

    /// The range λ weighting frame `f`'s rows to AP `l` (module doc).
    fn range_m(&self, f: &Frame, l: usize) -> f64 {
        let c = &self.config;
        if self.converged_at.is_none() || !c.adaptive_weights {
            return c.initial_range_m;
        }
        let ap = self.border.fixed_rows::<3>(3 + 3 * l);
        let p = f.x.fixed_rows::<3>(0);
        let r = (ap - p).norm();
        if r.is_finite() {
            r.clamp(c.range_limits_m.0, c.range_limits_m.1)
        } else {
            c.initial_range_m
        }
    }

    fn imu_factor(&self, k: usize) -> Option<ImuInfo> {
        let (a, b) = (&self.frames[k], &self.frames[k + 1]);
        let pre = b.from_prev.as_ref()?;
        let adaptive = self.solved_once && self.config.adaptive_weights;
        let (v_next, g_next) = if adaptive {
            (
                b.x.fixed_rows::<3>(3).into_owned(),
                b.x.fixed_rows::<3>(6).into_owned(),
            )
        } else {
            (Vector3::zeros(), nominal_gravity(pre))
        };
        let g_next = if g_next.norm() < 1.0 {
            nominal_gravity(pre)
        } else {
            g_next
        };
        let step_m = if adaptive {
            (b.x.fixed_rows::<3>(0) - a.x.fixed_rows::<3>(0)).norm()
        } else {
            0.0
        };
        imu_info(&ImuFactorInput {
            pre,
            b0_from_bk: &a.b0_from_bk,
            gyro_bias_rad_s: self.gyro_bias_rad_s,
            v_next,
            g_next,
            step_m,
            attitude_sigma_rad: self.config.attitude_sigma_rad,
        })
    }

    fn aoa_factors(&self, k: usize) -> impl Iterator<Item = (usize, AoaInfo)> + '_ {
        let f = &self.frames[k];
        let c = &self.config;
        let up = f.up(c.adaptive_weights);
        f.bearings
            .iter()
            .filter(|b| b.is_valid())
            .filter_map(move |b| {
                let info = aoa_info(
                    b,
                    &f.b0_from_bk,
                    &up,
                    &c.body_from_array,
                    self.range_m(f, b.ap),
                    c.attitude_sigma_rad,
                    c.elevation_sigma_rad,
                )?;
                Some((b.ap, info))
            })
    }

    /// The window's normal equations as they stand (for inspection and benchmarks).
    pub fn normal_equations(&self) -> ArrowSystem {
        self.build()
    }

    fn build(&self) -> ArrowSystem {
        let n = self.frames.len();
        let m = 3 + 3 * self.num_aps;
        let mut sys = ArrowSystem::zeros(n, m);
        if n == 0 {
            return sys;
        }
        // Prior on the first frame and the border.
        let pb = self.prior_h.nrows() - FRAME_DIM;
        sys.diag[0] += self.prior_h.fixed_view::<FRAME_DIM, FRAME_DIM>(0, 0);
        sys.border[0]
            .view_mut((0, 0), (pb, FRAME_DIM))
            .add_assign(&self.prior_h.view((FRAME_DIM, 0), (pb, FRAME_DIM)));
        sys.corner
            .view_mut((0, 0), (pb, pb))
            .add_assign(&self.prior_h.view((FRAME_DIM, FRAME_DIM), (pb, pb)));
        sys.rhs_frames[0] += self.prior_b.fixed_rows::<FRAME_DIM>(0);
        sys.rhs_border
            .rows_mut(0, pb)
            .add_assign(&self.prior_b.rows(FRAME_DIM, pb));
        for k in 0..n {
            if k + 1 < n
                && let Some(info) = self.imu_factor(k)
            {
                sys.diag[k] += info.h_kk;
                sys.diag[k + 1] += info.h_ll;
                sys.lower[k] += info.h_lk;
                sys.border[k]
                    .view_mut((0, 0), (3, FRAME_DIM))
                    .add_assign(&info.h_kb.transpose());
                sys.border[k + 1]
                    .view_mut((0, 0), (3, FRAME_DIM))
                    .add_assign(&info.h_lb.transpose());
                sys.corner.view_mut((0, 0), (3, 3)).add_assign(&info.h_bb);
                sys.rhs_frames[k] += info.b_k;
                sys.rhs_frames[k + 1] += info.b_l;
                sys.rhs_border.rows_mut(0, 3).add_assign(&info.b_b);
            }
            for (l, info) in self.aoa_factors(k) {
                let o = 3 + 3 * l;
                sys.diag[k].fixed_view_mut::<3, 3>(0, 0).add_assign(&info.n);
                sys.corner.fixed_view_mut::<3, 3>(o, o).add_assign(&info.n);
                sys.border[k]
                    .fixed_view_mut::<3, 3>(o, 0)
                    .add_assign(&(-info.n));
                sys.rhs_frames[k]
                    .fixed_rows_mut::<3>(0)
                    .add_assign(&(-info.b_c));
                sys.rhs_border.fixed_rows_mut::<3>(o).add_assign(&info.b_c);
            }
        }
        sys
    }
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
