//! The start from the linear solution, its χ² acceptance, and the loss test (module doc of
//! [`super::estimator`]).

use std::collections::HashMap;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::chi2::chi2_upper;
use super::estimator::NonlinearEstimator;
use super::state::{BA, BG, Mat15, NavState, POS, THETA, VEL, pose_at};
use super::window::{FitStats, NonlinearWindow};
use crate::fusion::window::FrameEstimate;
use crate::imu::STANDARD_GRAVITY_M_S2;
use crate::time::Timestamp;

/// 1σ of the gauge: the first keyframe's position, m …
const GAUGE_POSITION_SIGMA_M: f64 = 1e-3;
/// … and its yaw, rad.
const GAUGE_YAW_SIGMA_RAD: f64 = 1e-3;
/// 1σ of the start's roll and pitch from the linear solution's gravity, rad (loose: the IMU
/// factors level the window).
const START_TILT_SIGMA_RAD: f64 = 0.05;
/// 1σ of the gyro bias after a static initialization, rad/s.
const STATIC_GYRO_BIAS_SIGMA_RAD_S: f64 = 2e-3;
/// A start whose APs come closer than this to a keyframe is refused, m (a collapsed AP fits its
/// bearings trivially).
const MIN_AP_RANGE_M: f64 = 0.3;

/// Whether residual statistics pass the χ² test at significance `alpha`: the whole cost (IMU,
/// the AoA factors' robust cost, barometer) against χ² with as many degrees of freedom as
/// measurements beyond the IMU chain's own (the IMU factors alone are met exactly by any
/// trajectory: each adds as many residuals as states), less the border's `border_dim` unknowns.
pub fn passes_chi2(fit: &FitStats, border_dim: usize, alpha: f64) -> bool {
    let dof = (fit.bearings + fit.baro).saturating_sub(border_dim);
    let cost = fit.imu_chi2 + fit.bearing_robust + fit.baro_chi2;
    dof == 0 || cost <= chi2_upper(dof as f64, alpha)
}

impl NonlinearEstimator {
    /// Tries the start when it is time (module doc, step 3).
    pub(super) fn maybe_start(&mut self, t: Timestamp) {
        let Some(since) = self.moving_since else {
            return;
        };
        if t.secs_since(since) < self.config.start_after_motion_s
            || self
                .last_try
                .is_some_and(|l| t.secs_since(l) < self.config.start_retry_s)
        {
            return;
        }
        self.last_try = Some(t);
        match self.start_window() {
            Some(w) => {
                let mut w = w;
                while w.len() > self.config.max_keyframes {
                    w.marginalize_oldest();
                }
                self.last_good = w.newest().copied();
                self.window = Some(w);
                self.linear = None;
                self.start.clear();
                self.epoch += 1;
                self.converged_at.get_or_insert(t);
            }
            None => self.stats.rejected_convergences += 1,
        }
    }

    /// The nonlinear window over the start, initialized from the linear solution and iterated;
    /// `None` when it is not accepted.
    fn start_window(&self) -> Option<NonlinearWindow> {
        self.start_window_scaled(1.0)
            .and_then(|(w, _, ok)| ok.then_some(w))
    }

    /// [`Self::start_window`] from the linear solution scaled by `scale` about its first frame:
    /// the window, its cost, and whether it is accepted.
    fn start_window_scaled(&self, scale: f64) -> Option<(NonlinearWindow, f64, bool)> {
        let linear = self.linear.as_ref()?.window();
        if linear.num_aps() == 0 || linear.max_ap_sigma_m() >= self.candidate_ap_sigma_m {
            return None;
        }
        let frames: HashMap<i64, FrameEstimate> = linear.frames().map(|f| (f.t.0, f)).collect();
        // Level: the mean upward gravity in b0 to +z.
        let up: Vector3<f64> = frames
            .values()
            .map(|f| f.b0_from_bk * f.g_in_bk)
            .sum::<Vector3<f64>>();
        let n = frames.len().max(1) as f64;
        let g_norm = up.norm() / n;
        if !(0.8 * STANDARD_GRAVITY_M_S2..1.2 * STANDARD_GRAVITY_M_S2).contains(&g_norm) {
            return None;
        }
        let w_from_b0 = UnitQuaternion::rotation_between(&up, &Vector3::z())?;
        let bg = linear.gyro_bias_rad_s();
        let ba = linear.accel_bias_m_s2();
        let state_of = |f: &FrameEstimate| {
            let r = w_from_b0 * f.b0_from_bk;
            NavState {
                t: f.t,
                world_from_body: r,
                p_b_in_w: w_from_b0 * f.p_in_b0 * scale,
                v_b_in_w: r * f.v_in_bk * scale,
                gyro_bias_rad_s: bg,
                accel_bias_m_s2: ba,
            }
        };
        // The longest run of start keyframes the linear window still has.
        let first = self
            .start
            .iter()
            .rposition(|k| !frames.contains_key(&k.t.0))
            .map_or(0, |i| i + 1);
        let mut keys = self.start.iter().skip(first);
        let k0 = keys.next()?;
        let x0 = state_of(frames.get(&k0.t.0)?);
        let aps: Vec<Vector3<f64>> = (0..linear.num_aps())
            .filter_map(|l| linear.ap_in_b0(l).map(|c| w_from_b0 * c * scale))
            .collect();
        let g = STANDARD_GRAVITY_M_S2;
        let baro = self.has_baro.then(|| {
            let d: Vec<f64> = self
                .start
                .iter()
                .skip(first)
                .filter_map(|k| {
                    let x = state_of(frames.get(&k.t.0)?);
                    Some(
                        k.frames
                            .iter()
                            .filter_map(|f| {
                                f.altitude_m
                                    .map(|h| h - pose_at(&x, &f.partial, g).p_b_in_w.z)
                            })
                            .collect::<Vec<_>>(),
                    )
                })
                .flatten()
                .collect();
            if d.is_empty() {
                0.0
            } else {
                d.iter().sum::<f64>() / d.len() as f64
            }
        });
        let mut w = NonlinearWindow::new(
            self.config.clone(),
            g,
            self.linear_config.imu_noise.clone(),
            self.linear_config.window.body_from_array,
            x0,
            k0.frames.clone(),
            &self.start_prior(&x0),
            aps,
            baro,
        );
        for k in keys {
            let x = state_of(frames.get(&k.t.0)?);
            w.push_keyframe(x, k.from_prev.clone()?, k.frames.clone())?;
        }
        let report = w.optimize(self.config.iterations_at_start).ok()?;
        let fit = w.fit();
        let ap_ok = (0..w.aps().len()).all(|l| {
            let range = w
                .keyframes()
                .map(|x| (w.aps()[l] - x.p_b_in_w).norm())
                .fold(f64::INFINITY, f64::min);
            w.ap_sigma_m(l).is_some_and(|s| {
                s < self.config.max_ap_sigma_m && s < self.config.max_ap_sigma_fraction * range
            }) && range > MIN_AP_RANGE_M
        });
        let ok = ap_ok && passes_chi2(&fit, w.border_dim(), self.config.chi2_significance);
        Some((w, report.cost_after, ok))
    }

    /// The prior on the start's first keyframe: the gauge (position, yaw), a loose roll and
    /// pitch, and the biases' spreads (the gyro's from the rest when there was one).
    fn start_prior(&self, x0: &NavState) -> Mat15 {
        let mut h = Mat15::zeros();
        let r: Matrix3<f64> = x0.world_from_body.to_rotation_matrix().into_inner();
        // δθ is body-side: a world-frame tilt/yaw information Λ_w becomes Rᵀ Λ_w R.
        let lw = Matrix3::from_diagonal(&Vector3::new(
            START_TILT_SIGMA_RAD.powi(-2),
            START_TILT_SIGMA_RAD.powi(-2),
            GAUGE_YAW_SIGMA_RAD.powi(-2),
        ));
        h.fixed_view_mut::<3, 3>(THETA, THETA)
            .copy_from(&(r.transpose() * lw * r));
        let noise = &self.linear_config.imu_noise;
        let gyro_sigma = if self.static_init.is_some() {
            STATIC_GYRO_BIAS_SIGMA_RAD_S
        } else {
            noise.gyro_turn_on_bias_rad_s.max(1e-4)
        };
        for i in 0..3 {
            h[(POS + i, POS + i)] = GAUGE_POSITION_SIGMA_M.powi(-2);
            h[(VEL + i, VEL + i)] = 1e-4;
            h[(BG + i, BG + i)] = gyro_sigma.powi(-2);
            h[(BA + i, BA + i)] = noise.accel_turn_on_bias_m_s2.max(1e-3).powi(-2);
        }
        h
    }

    /// The loss test after a keyframe's solve (module doc, step 4).
    pub(super) fn check_health(&mut self, t: Timestamp) {
        let Some(w) = &self.window else {
            return;
        };
        if passes_chi2(&w.fit(), w.border_dim(), self.config.chi2_significance) {
            self.failing_since = None;
            self.last_good = w.newest().copied();
            return;
        }
        let since = *self.failing_since.get_or_insert(t);
        if t.secs_since(since) >= self.config.loss_window_s {
            self.lose(t);
        }
    }

    /// The estimate is lost: start over from the last good keyframe, propagated to now.
    pub(super) fn lose(&mut self, t: Timestamp) {
        self.stats.restarts += 1;
        let from = self.window.as_ref().and_then(|w| {
            let good = self.last_good?;
            let mut x = good;
            let mut after = false;
            for kf in &w.keyframes {
                if after && let Some((pre, _)) = &kf.from_prev {
                    let p = pose_at(&x, pre, STANDARD_GRAVITY_M_S2);
                    x = NavState {
                        t: kf.x.t,
                        world_from_body: p.world_from_body,
                        p_b_in_w: p.p_b_in_w,
                        v_b_in_w: p.v_b_in_w,
                        ..x
                    };
                }
                after |= kf.x.t == good.t;
            }
            // Into the output frame.
            let a = self.anchor;
            Some(NavState {
                world_from_body: a.rotation * x.world_from_body,
                p_b_in_w: a.transform_point(&x.p_b_in_w.into()).coords,
                v_b_in_w: a.rotation * x.v_b_in_w,
                ..x
            })
        });
        self.epoch += 1;
        self.begin_start(t, from);
    }
}
