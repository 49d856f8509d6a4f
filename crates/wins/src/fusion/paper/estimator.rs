//! The paper's estimator as one object with a push API (paper Fig. 1, Algorithm 1's estimator side): feed IMU
//! samples and per-frame bearings in time order, get the pose at every frame and, between
//! frames, propagated at IMU rate. A replay of a dataset and a live stream are two drivers of it.
//!
//! Per frame: the IMU interval since the previous frame is cut ([`crate::imu::Preintegrator`]),
//! the frame's attitude is chained from the previous one with ΔR corrected to the window's gyro
//! bias, and the [`super::window::SlidingWindow`] is solved; once it has converged the window
//! estimates the gyro bias jointly, which is what removes the gyro drift from the attitude (the
//! paper's relaxed rotation averaging, fed back in the loop, made it worse: see docs/RESULTS.md). Poses come out in the world frame `w`: origin and heading of `b0`, z along
//! the solved upward gravity. When a converged estimate is lost, the window starts over with a
//! new `b0`; `w` stays the same: the new window is placed at the position and heading of the
//! lost one's last pose whose bearings still fitted, so the output trajectory does not jump back
//! to the origin (that pose's error carries over).

use std::collections::VecDeque;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::window::{SlidingWindow, WindowConfig};
use crate::fusion::arrow::Vec9;
use crate::fusion::bearing::Bearing;
use crate::fusion::error::{EstimatorError, FrameError};
use crate::fusion::frames::{check_frame_order, drop_frames_in_gap};
use crate::fusion::pose::{PoseEstimate, Step};
use crate::fusion::proposal::{FrameEstimate, StartPrior};
use crate::fusion::stats::EstimatorStats;
use crate::imu::{ImuBiases, ImuGap, ImuSample, Preintegrator};
use crate::rig::ImuNoise;
use crate::so3::heading;
use crate::time::Timestamp;

/// Settings of the estimator.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearConfig {
    /// The sliding window.
    pub window: WindowConfig,
    /// IMU noise densities.
    pub imu_noise: ImuNoise,
    /// How a gap in the IMU stream is integrated.
    pub imu_gap: ImuGap,
}

impl LinearConfig {
    /// Default window settings with the given IMU noise and the array on the body's origin.
    pub fn new(imu_noise: ImuNoise) -> Self {
        Self::for_rig(WindowConfig::default(), imu_noise, Isometry3::identity())
    }

    /// `window` completed with what the rig says: the array's mounting, and the biases' priors
    /// from the IMU's turn-on spreads (floored: an ideal IMU has none).
    pub fn for_rig(
        window: WindowConfig,
        imu_noise: ImuNoise,
        body_from_array: Isometry3<f64>,
    ) -> Self {
        let window = WindowConfig {
            prior_gyro_bias_sigma_rad_s: imu_noise.gyro_turn_on_bias_rad_s.max(1e-4),
            prior_accel_bias_sigma_m_s2: imu_noise.accel_turn_on_bias_m_s2.max(1e-3),
            body_from_array,
            ..window
        };
        Self {
            window,
            imu_noise,
            imu_gap: ImuGap::default(),
        }
    }
}

/// The estimator (module doc).
#[derive(Clone, Debug)]
pub struct LinearEstimator {
    config: LinearConfig,
    pre: Preintegrator,
    window: SlidingWindow,
    pending: VecDeque<(Timestamp, Vec<Bearing>)>,
    stats: EstimatorStats,
    /// `w` from the current window's gravity-aligned `b0` frame: identity until a restart.
    anchor: Isometry3<f64>,
    first_converged_at: Option<Timestamp>,
    /// The last converged pose whose bearings fitted (the anchor of a restart).
    last_good: Option<PoseEstimate>,
}

impl LinearEstimator {
    /// A fresh estimator (initialization-free: no state is needed).
    pub fn new(config: LinearConfig) -> Self {
        Self {
            pre: Preintegrator::new(config.imu_noise.clone(), ImuBiases::zero())
                .with_gap(config.imu_gap),
            window: SlidingWindow::new(config.window.clone()),
            pending: VecDeque::new(),
            stats: EstimatorStats::default(),
            anchor: Isometry3::identity(),
            first_converged_at: None,
            last_good: None,
            config,
        }
    }

    /// A fresh estimator whose first frame starts from what is known (a static initialization
    /// or a lost estimate's last state): the IMU is integrated with that gyro bias.
    pub fn with_start(config: LinearConfig, start: StartPrior) -> Self {
        let mut w = Self::new(config);
        w.pre = Preintegrator::new(
            w.config.imu_noise.clone(),
            ImuBiases {
                gyro_rad_s: start.gyro_bias_rad_s,
                accel_m_s2: Vector3::zeros(),
            },
        )
        .with_gap(w.config.imu_gap);
        w.window = SlidingWindow::with_start(w.config.window.clone(), start);
        w
    }

    /// The settings.
    pub fn config(&self) -> &LinearConfig {
        &self.config
    }

    /// Counters.
    pub fn stats(&self) -> EstimatorStats {
        EstimatorStats {
            rejected_convergences: self.stats.rejected_convergences
                + self.window.rejected_candidates(),
            ..self.stats
        }
    }

    /// When the estimate first converged (a restart does not reset it), if it has.
    pub fn converged_at(&self) -> Option<Timestamp> {
        self.first_converged_at
    }

    /// Starts the converged estimate from a state given from outside (see
    /// [`SlidingWindow::converge_from`]); the poses follow from the next frame on.
    pub fn converge_from(
        &mut self,
        state_of: &dyn Fn(Timestamp) -> Vec9,
        aps_in_b0: &[Vector3<f64>],
        iterations: usize,
    ) -> Result<(), FrameError> {
        self.window.converge_from(state_of, aps_in_b0, iterations)
    }

    /// The window (for AP positions, covariances, convergence).
    pub fn window(&self) -> &SlidingWindow {
        &self.window
    }

    /// Queues a frame at `t` with its bearings; it is solved when the IMU stream passes `t`.
    pub fn push_bearings(
        &mut self,
        t: Timestamp,
        bearings: Vec<Bearing>,
    ) -> Result<(), EstimatorError> {
        let newest = self.pending.back().map(|(p, _)| *p);
        check_frame_order(t, newest, &self.pre, &mut self.stats)?;
        self.pending.push_back((t, bearings));
        Ok(())
    }

    /// Integrates one IMU sample, solving every queued frame it passes.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError> {
        // Checked before any queued frame is cut with it.
        if let Err(e) = self.pre.check(s) {
            self.stats.imu_refused += 1;
            return Err(e.into());
        }
        drop_frames_in_gap(
            &mut self.pending,
            |(t, _)| *t,
            &self.pre,
            s,
            &mut self.stats,
        );
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
            match self.add_frame(t, interval, bearings) {
                Ok(Some(pose)) => step.frames.push(pose),
                Ok(None) => {}
                Err(e) => step.refused.push(e),
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
    ) -> Result<Option<PoseEstimate>, FrameError> {
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
        if let Err(e) = result {
            self.stats.frames_refused += 1;
            return Err(e);
        }
        self.stats.bearings += n_bearings;
        if self.window.solve().is_err() {
            self.stats.solve_failures += 1;
        }
        self.stats.frames += 1;
        if self.first_converged_at.is_none() {
            self.first_converged_at = self.window.converged_at();
        }
        let pose = self.window.latest().map(|f| self.to_world(&f));
        if self.window.converged_at().is_some() && self.window.misfit_frames() == 0 {
            self.last_good = pose;
        }
        if self.window.is_lost() {
            // Start over from zeros (initialization-free), as after a cold start, placed where
            // the lost window last was (module doc).
            self.stats.rejected_convergences += self.window.rejected_candidates();
            self.stats.restarts += 1;
            self.window = SlidingWindow::new(self.config.window.clone());
            if let Some(p) = self.last_good.take() {
                self.anchor = Isometry3::from_parts(
                    Translation3::from(p.p_b_in_w),
                    heading(&p.world_from_body),
                );
            }
        }
        Ok(pose)
    }

    /// The gyro bias estimate with a zero accelerometer bias (the window corrects ΔR with it; the
    /// accelerometer bias is a window unknown).
    fn gyro_only_bias(&self) -> ImuBiases {
        ImuBiases {
            gyro_rad_s: self.window.gyro_bias_rad_s(),
            accel_m_s2: Vector3::zeros(),
        }
    }

    /// `T_w_b0` of the current window: z along the solved upward gravity, origin and heading of
    /// `b0` (after a restart, moved to where the lost window last was; module doc).
    pub fn world_from_b0(&self) -> Isometry3<f64> {
        let up = self
            .window
            .latest()
            .and_then(|f| (f.b0_from_bk * f.g_in_bk).try_normalize(1e-9));
        let level = up
            .and_then(|u| UnitQuaternion::rotation_between(&u, &Vector3::z()))
            .unwrap_or_else(UnitQuaternion::identity);
        self.anchor * Isometry3::from_parts(Translation3::identity(), level)
    }

    fn to_world(&self, f: &FrameEstimate) -> PoseEstimate {
        let w_b0 = self.world_from_b0();
        PoseEstimate {
            t: f.t,
            p_b_in_w: w_b0.transform_point(&f.p_in_b0.into()).coords,
            v_b_in_w: w_b0.rotation * (f.b0_from_bk * f.v_in_bk),
            world_from_body: w_b0.rotation * f.b0_from_bk,
            p_b_in_b0: f.p_in_b0,
            b0_from_body: f.b0_from_bk,
            converged: self.window.converged_at().is_some(),
            covariance: None,
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
