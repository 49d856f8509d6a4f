//! WINS as one object with a push API (paper Fig. 1, Algorithm 1's estimator side): feed IMU
//! samples and per-frame bearings in time order, get the pose at every frame and, between
//! frames, propagated at IMU rate. A replay of a dataset and a live stream are two drivers of it.
//!
//! Per frame: the IMU interval since the previous frame is cut ([`crate::imu::Preintegrator`]),
//! the frame's attitude is chained from the previous one with the bias-corrected ΔR, the
//! [`super::window::SlidingWindow`] is solved, and — once the window has converged — the
//! [`super::attitude`] stage re-averages the window's rotations with gravity and bearing rows and
//! updates the gyro bias. Poses come out in the world frame `w`: origin and heading of `b0`,
//! z along the solved upward gravity.

use std::collections::VecDeque;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::attitude::{AttitudeFrame, GyroBiasEstimator, average};
use super::bearing::Bearing;
use super::window::factors::horizontal_direction;
use super::window::{FrameEstimate, SlidingWindow, WindowConfig, WindowError};
use crate::imu::{ImuBiases, ImuNoise, ImuSample, PreintegrationError, Preintegrator};
use crate::time::Timestamp;

/// Settings of the estimator.
#[derive(Clone, Debug, PartialEq)]
pub struct WinsConfig {
    /// The sliding window.
    pub window: WindowConfig,
    /// IMU noise densities.
    pub imu_noise: ImuNoise,
    /// Re-average the attitude with gravity and bearings and estimate the gyro bias (Sec. IV-A).
    /// Off: the attitude is the gyro chain alone.
    pub attitude_averaging: bool,
    /// Prior 1σ of the gyro bias per axis, rad/s.
    pub gyro_bias_prior_sigma_rad_s: f64,
}

impl WinsConfig {
    /// Defaults with the given IMU noise.
    pub fn new(imu_noise: ImuNoise) -> Self {
        Self {
            window: WindowConfig::default(),
            imu_noise,
            // Off by default: on paper-circle with 2° bearings the feedback currently makes the
            // attitude worse (8° vs 1.8° after 40 s), see the README's fusion status.
            attitude_averaging: false,
            gyro_bias_prior_sigma_rad_s: 0.01,
        }
    }
}

/// One pose estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseEstimate {
    /// Time.
    pub t: Timestamp,
    /// Body position in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Body velocity in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Attitude.
    pub world_from_body: UnitQuaternion<f64>,
    /// Body position in `b0` (the estimator's own frame), m.
    pub p_b_in_b0: Vector3<f64>,
    /// `R_{b}^{b_0}`.
    pub b0_from_body: UnitQuaternion<f64>,
    /// Whether the window had converged.
    pub converged: bool,
}

/// What the estimator has seen and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WinsStats {
    /// IMU samples integrated.
    pub imu_samples: u64,
    /// IMU samples refused (non-finite, out of order).
    pub imu_refused: u64,
    /// Frames solved.
    pub frames: u64,
    /// Bearings fed to the window.
    pub bearings: u64,
    /// Frames dropped because they were older than the IMU stream or came before any IMU.
    pub frames_late: u64,
    /// Window solves that failed (the frame stays, the previous estimate is kept).
    pub solve_failures: u64,
}

/// Why an input was refused (the estimator's state is unchanged; the refusal is counted).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WinsError {
    /// The IMU sample was refused.
    #[error(transparent)]
    Imu(#[from] PreintegrationError),
    /// The window refused the frame.
    #[error(transparent)]
    Window(#[from] WindowError),
    /// A frame older than the last IMU sample (cannot be cut any more).
    #[error("frame at {t_ns} ns is older than the last IMU sample at {last_ns} ns")]
    LateFrame {
        /// Frame time, ns.
        t_ns: i64,
        /// Last IMU sample, ns.
        last_ns: i64,
    },
}

/// Output of one IMU push.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Step {
    /// Poses of the frames solved by this push (usually zero or one).
    pub frames: Vec<PoseEstimate>,
    /// The pose propagated to this IMU sample (once a frame exists).
    pub imu_pose: Option<PoseEstimate>,
}

/// The estimator (module doc).
#[derive(Clone, Debug)]
pub struct Wins {
    config: WinsConfig,
    pre: Preintegrator,
    window: SlidingWindow,
    pending: VecDeque<(Timestamp, Vec<Bearing>)>,
    gyro_bias: GyroBiasEstimator,
    up_sum_in_b0: Vector3<f64>,
    stats: WinsStats,
}

impl Wins {
    /// A fresh estimator (initialization-free: no state is needed).
    pub fn new(config: WinsConfig) -> Self {
        Self {
            pre: Preintegrator::new(config.imu_noise.clone(), ImuBiases::zero()),
            window: SlidingWindow::new(config.window.clone()),
            pending: VecDeque::new(),
            gyro_bias: GyroBiasEstimator::new(config.gyro_bias_prior_sigma_rad_s),
            up_sum_in_b0: Vector3::zeros(),
            stats: WinsStats::default(),
            config,
        }
    }

    /// Counters.
    pub fn stats(&self) -> WinsStats {
        self.stats
    }

    /// The window (for AP positions, covariances, convergence).
    pub fn window(&self) -> &SlidingWindow {
        &self.window
    }

    /// Queues a frame at `t` with its bearings; it is solved when the IMU stream passes `t`.
    pub fn push_bearings(&mut self, t: Timestamp, bearings: Vec<Bearing>) -> Result<(), WinsError> {
        let last = self.pre.last_sample().map(|s| s.t);
        let newest = self.pending.back().map(|(p, _)| *p).or(last);
        if let Some(l) = newest.filter(|l| t < *l) {
            self.stats.frames_late += 1;
            return Err(WinsError::LateFrame {
                t_ns: t.0,
                last_ns: l.0,
            });
        }
        self.pending.push_back((t, bearings));
        Ok(())
    }

    /// Integrates one IMU sample, solving every queued frame it passes.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, WinsError> {
        // Checked before any queued frame is cut with it.
        if let Err(e) = self.pre.check(s) {
            self.stats.imu_refused += 1;
            return Err(e.into());
        }
        let mut step = Step::default();
        while let Some((t, _)) = self.pending.front() {
            if *t > s.t {
                break;
            }
            let Some((t, bearings)) = self.pending.pop_front() else {
                break;
            };
            if self.pre.last_sample().is_none() {
                self.stats.frames_late += 1;
                continue;
            }
            let interval = self.pre.cut(t, s)?;
            if let Some(pose) = self.add_frame(t, interval, bearings) {
                step.frames.push(pose);
            }
        }
        self.pre.push(s)?;
        self.stats.imu_samples += 1;
        step.imu_pose = self.propagated();
        Ok(step)
    }

    fn add_frame(
        &mut self,
        t: Timestamp,
        interval: crate::imu::Preintegrated,
        bearings: Vec<Bearing>,
    ) -> Option<PoseEstimate> {
        let n_bearings = bearings.len() as u64;
        let result = match self.window.latest() {
            None => self
                .window
                .add_frame(t, UnitQuaternion::identity(), None, bearings),
            Some(prev) => {
                let (_, _, d_r) = interval.corrected(&self.gyro_only_bias());
                self.window
                    .add_frame(t, prev.b0_from_bk * d_r, Some(interval), bearings)
            }
        };
        if result.is_err() {
            self.stats.frames_late += 1;
            return None;
        }
        self.stats.bearings += n_bearings;
        if self.window.solve().is_err() {
            self.stats.solve_failures += 1;
        }
        if self.config.attitude_averaging && self.window.converged_at().is_some() {
            self.refine_attitude();
        }
        self.stats.frames += 1;
        self.window.latest().map(|f| self.to_world(&f))
    }

    /// The gyro bias estimate with a zero accelerometer bias (the window corrects ΔR with it; the
    /// accelerometer bias is a window unknown).
    fn gyro_only_bias(&self) -> ImuBiases {
        ImuBiases {
            gyro_rad_s: self.window.gyro_bias_rad_s(),
            accel_m_s2: Vector3::zeros(),
        }
    }

    /// Rotation averaging over the window (module doc of [`super::attitude`]).
    fn refine_attitude(&mut self) {
        let frames: Vec<FrameEstimate> = self.window.frames().collect();
        let inputs: Vec<_> = self
            .window
            .frame_inputs()
            .map(|(pre, b, up)| (pre.cloned(), b.to_vec(), up))
            .collect();
        let n = frames.len();
        if n < 2 {
            return;
        }
        // γ: the unit upward gravity in b0, averaged over every converged frame so far.
        if let Some(f) = frames.last() {
            self.up_sum_in_b0 += f.b0_from_bk * f.g_in_bk.normalize();
        }
        let Some(gamma) = self.up_sum_in_b0.try_normalize(1e-9) else {
            return;
        };
        let body_from_array = self.config.window.body_from_array;
        let bias = self.gyro_only_bias();
        let mut att = Vec::with_capacity(n);
        for k in 0..n {
            let to_next = inputs
                .get(k + 1)
                .and_then(|(pre, _, _)| pre.as_ref())
                .map(|pre| {
                    let (_, _, d_r) = pre.corrected(&bias);
                    let p = pre.covariance.fixed_view::<3, 3>(6, 6).trace() / 3.0;
                    // Gyro noise plus a bias uncertainty of 0.002 rad/s over the interval.
                    (d_r, (p + (0.002 * pre.dt_s()).powi(2)).sqrt())
                });
            let f = &frames[k];
            let (_, bearings, up) = &inputs[k];
            let mut directions = vec![(up.normalize(), gamma, 0.01)];
            for b in bearings.iter().filter(|b| b.is_valid()) {
                let (Some(c), Some((u, ..))) = (
                    self.window.ap_in_b0(b.ap),
                    horizontal_direction(b, up, &body_from_array),
                ) else {
                    continue;
                };
                let array_in_b0 = f.p_in_b0 + f.b0_from_bk * body_from_array.translation.vector;
                if let Some(dir) = (c - array_in_b0).try_normalize(1e-6) {
                    directions.push((u, dir, b.sigma_rad.max(0.01)));
                }
            }
            att.push(AttitudeFrame {
                b0_from_bk: f.b0_from_bk,
                to_next,
                directions,
            });
        }
        let Some(rots) = average(&att, 1e-3) else {
            return;
        };
        for (k, r) in rots.iter().enumerate() {
            self.window.set_rotation(k, *r);
        }
        // The newest interval feeds the gyro-bias estimate.
        if let Some((Some(pre), _, _)) = inputs.last() {
            let j: Matrix3<f64> = pre.jacobian_bias.fixed_view::<3, 3>(6, 3).into_owned();
            let sigma = (pre.covariance.fixed_view::<3, 3>(6, 6).trace() / 3.0).sqrt() + 1e-4;
            self.gyro_bias
                .add(&pre.bk_from_bk1, &j, &rots[n - 2], &rots[n - 1], sigma);
            self.window.set_gyro_bias(self.gyro_bias.estimate());
        }
    }

    /// `R_w_b0`: z along the solved upward gravity, heading of `b0`.
    pub fn world_from_b0(&self) -> UnitQuaternion<f64> {
        let up = self.up_sum_in_b0.try_normalize(1e-9).or_else(|| {
            self.window
                .latest()
                .and_then(|f| (f.b0_from_bk * f.g_in_bk).try_normalize(1e-9))
        });
        up.and_then(|u| UnitQuaternion::rotation_between(&u, &Vector3::z()))
            .unwrap_or_else(UnitQuaternion::identity)
    }

    fn to_world(&self, f: &FrameEstimate) -> PoseEstimate {
        let w_b0 = self.world_from_b0();
        PoseEstimate {
            t: f.t,
            p_b_in_w: w_b0 * f.p_in_b0,
            v_b_in_w: w_b0 * (f.b0_from_bk * f.v_in_bk),
            world_from_body: w_b0 * f.b0_from_bk,
            p_b_in_b0: f.p_in_b0,
            b0_from_body: f.b0_from_bk,
            converged: self.window.converged_at().is_some(),
        }
    }

    /// The newest frame propagated to the last IMU sample with `eqn:linear_update`.
    fn propagated(&self) -> Option<PoseEstimate> {
        let f = self.window.latest()?;
        let run = self.pre.running();
        if run.start != f.t {
            return None;
        }
        let dt = run.dt_s();
        let bias = ImuBiases {
            gyro_rad_s: self.window.gyro_bias_rad_s(),
            accel_m_s2: self.window.accel_bias_m_s2(),
        };
        let (alpha, beta, d_r) = run.corrected(&bias);
        let r = f.b0_from_bk;
        let p = f.p_in_b0 + r * (f.v_in_bk * dt - f.g_in_bk * (0.5 * dt * dt) + alpha);
        let v_in_bk = f.v_in_bk - f.g_in_bk * dt + beta;
        let moved = FrameEstimate {
            t: run.end,
            p_in_b0: p,
            v_in_bk: d_r.inverse() * v_in_bk,
            g_in_bk: d_r.inverse() * f.g_in_bk,
            b0_from_bk: r * d_r,
        };
        Some(self.to_world(&moved))
    }
}
