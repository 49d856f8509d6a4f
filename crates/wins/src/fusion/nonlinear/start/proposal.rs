//! The start's proposals (module doc of [`crate::fusion::nonlinear::estimator`], step 2): the inertial one (the
//! dead reckoning from a known state, the APs triangulated against it), the start solver's
//! (levelled), and the nonlinear window over either, iterated and accepted or not.

use std::collections::HashMap;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::recovery::relocate::{ApFromDrone, Relocated, TimedSight, relocate};
use crate::fusion::nonlinear::solve::NonlinearWindow;
use crate::fusion::nonlinear::solve::aps::triangulate_within_bounds;
use crate::fusion::nonlinear::solve::fit::passes_chi2;
use crate::fusion::nonlinear::start::Start;
use crate::fusion::nonlinear::start::StartContext;
use crate::fusion::nonlinear::state::{BA, BG, Mat15, NavState, POS, THETA, VEL, pose_at};
use crate::fusion::nonlinear::triangulate::Sight;
use crate::fusion::proposal::FrameEstimate;
use crate::imu::STANDARD_GRAVITY_M_S2;
use crate::time::Timestamp;

/// 1σ of the gauge: the first keyframe's position, m …
const GAUGE_POSITION_SIGMA_M: f64 = 1e-3;
/// … and its yaw, rad.
const GAUGE_YAW_SIGMA_RAD: f64 = 1e-3;
/// 1σ of the start's roll and pitch from the linear solution's gravity, rad (loose: the IMU
/// factors level the window).
const LINEAR_TILT_SIGMA_RAD: f64 = 0.05;
/// 1σ of the rest's mean specific force, m/s² (beyond its white noise: vibration, the bias's
/// wander, a not quite still body).
const REST_FORCE_SIGMA_M_S2: f64 = 2e-3;
/// 1σ floor of the gyro bias after a static initialization, rad/s.
const REST_GYRO_BIAS_SIGMA_RAD_S: f64 = 2e-4;
/// 1σ of the roll and pitch carried across a hole, rad.
const HOLE_TILT_SIGMA_RAD: f64 = 0.05;
/// 1σ of the velocity carried across a hole, once corrected, m/s.
const HOLE_VELOCITY_SIGMA_M_S: f64 = 0.5;
/// A start whose APs come closer than this to a keyframe is refused, m (a collapsed AP fits its
/// bearings trivially).
const MIN_AP_RANGE_M: f64 = 0.3;

/// 1σ of a dead-reckoned state's roll/pitch (rad) and velocity (m/s), `elapsed_s` after the
/// state it left from: a rest (at zero velocity; its tilt is left to the rest's specific force,
/// [`RestForce`], which ties it to the accelerometer bias) or a lost window's last good state;
/// then what the IMU adds (a tilt error of a few mrad integrates to ~0.03 m/s per second).
fn dead_reckoned_sigmas(from_rest: bool, elapsed_s: f64) -> (f64, f64) {
    if from_rest {
        (LINEAR_TILT_SIGMA_RAD, 0.01 + 0.03 * elapsed_s)
    } else {
        (0.01 + 1e-3 * elapsed_s, 0.1 + 0.03 * elapsed_s)
    }
}

/// A starting point for the nonlinear window over the start keyframes from `first` on.
pub(in crate::fusion::nonlinear) struct Proposal {
    first: usize,
    states: Vec<NavState>,
    /// The APs, `None` where not placed yet.
    aps: Vec<Option<Vector3<f64>>>,
    /// Priors on APs, in their information (what a window lost to a hole knew of them: range
    /// and height from the carried position), with the horizontal σ the relocation found them
    /// with ([`crate::fusion::nonlinear::recovery::relocate`]).
    ap_priors: Vec<(usize, Matrix3<f64>, f64)>,
    /// σ of the first state's roll and pitch, rad.
    tilt_sigma_rad: f64,
    /// σ of the first state's velocity, m/s (infinite: unknown).
    velocity_sigma_m_s: f64,
    /// The rest the states leave from, when they do.
    rest: Option<RestForce>,
}

/// What a rest measured, seen from the first start keyframe: the mean specific force
/// `f = R_restᵀ g_w + b_a` (its attitude and the accelerometer bias along gravity together; the
/// bias across gravity and the tilt are one unknown), and the body's turn since.
#[derive(Clone, Copy, Debug)]
struct RestForce {
    /// `R_restᵀ R_k0`: the first keyframe's body axes in the rest's body.
    rest_from_body: Matrix3<f64>,
    /// Its duration, s.
    duration_s: f64,
}

impl StartContext<'_> {
    /// The inertial proposal: every start keyframe's dead-reckoned state, and every AP
    /// triangulated against those poses ([`crate::fusion::nonlinear::triangulate`]). After a hole the dead
    /// reckoning is first corrected by the AP the lost window had placed
    /// ([`crate::fusion::nonlinear::recovery::relocate`]).
    pub(in crate::fusion::nonlinear) fn propose_inertial(&self, start: &Start) -> Option<Proposal> {
        let reference = start.reference.as_ref()?;
        let mut states: Vec<NavState> = start
            .keyframes
            .iter()
            .map(|k| k.dead_reckoned)
            .collect::<Option<_>>()?;
        let after_hole = start.hole.is_some();
        let mut relocated = None;
        let mut ap_priors = Vec::new();
        if after_hole {
            let (l, found, ap) = self.relocate_after_hole(start, &states)?;
            for x in &mut states {
                let t = x.t.secs_since(reference.t);
                x.p_b_in_w += found.dp(t);
                x.v_b_in_w += found.dvel(t);
            }
            relocated = Some((l, found, ap));
        }
        let mut aps = self.triangulate_along(start, &states);
        if let Some((l, found, ap)) = relocated {
            let range = states
                .iter()
                .map(|x| (found.c - x.p_b_in_w).norm())
                .fold(f64::INFINITY, f64::min);
            if self.config.ap_sigma_ok(found.ap_sigma_m, range) {
                if aps.len() <= l {
                    aps.resize(l + 1, None);
                }
                aps[l] = Some(found.c);
                ap_priors.push((l, ap.information(&found.c), found.ap_sigma_m));
            }
        }
        if aps.iter().all(Option::is_none) {
            return None;
        }
        let elapsed = states.first()?.t.secs_since(reference.t).max(0.0);
        let x0_rotation = states.first()?.world_from_body;
        let (tilt_sigma_rad, velocity_sigma_m_s) = match after_hole {
            true => (HOLE_TILT_SIGMA_RAD, HOLE_VELOCITY_SIGMA_M_S),
            false => dead_reckoned_sigmas(start.reference_is_rest, elapsed),
        };
        Some(Proposal {
            first: 0,
            states,
            aps,
            ap_priors,
            tilt_sigma_rad,
            velocity_sigma_m_s,
            rest: self
                .static_init
                .filter(|_| start.reference_is_rest)
                .map(|s| RestForce {
                    rest_from_body: (reference.world_from_body.inverse() * x0_rotation)
                        .to_rotation_matrix()
                        .into_inner(),
                    duration_s: s.duration_s,
                }),
        })
    }

    /// Every AP triangulated against the start keyframes at `states`, `None` where its sights
    /// do not place it well enough (it waits as a placeholder).
    fn triangulate_along(&self, start: &Start, states: &[NavState]) -> Vec<Option<Vector3<f64>>> {
        self.sights_along(start, states)
            .iter()
            .map(|s| {
                let sights: Vec<Sight> = s.iter().map(|(_, sight)| *sight).collect();
                triangulate_within_bounds(&sights, self.config).map(|t| t.c_in_w)
            })
            .collect()
    }

    /// Every bearing of the start seen from the start keyframes at `states`, per AP, with the
    /// time of its frame.
    pub(in crate::fusion::nonlinear) fn sights_along(
        &self,
        start: &Start,
        states: &[NavState],
    ) -> Vec<Vec<(Timestamp, Sight)>> {
        let g = STANDARD_GRAVITY_M_S2;
        let body_from_array = self.sensors.body_from_array;
        let mut sights: Vec<Vec<(Timestamp, Sight)>> = Vec::new();
        for (k, x) in start.keyframes.iter().zip(states) {
            for f in &k.frames {
                if f.bearings.is_empty() {
                    continue;
                }
                let pose = pose_at(x, &f.partial, g);
                for b in &f.bearings {
                    if sights.len() <= b.ap {
                        sights.resize(b.ap + 1, Vec::new());
                    }
                    sights[b.ap].push((f.partial.end, Sight::of(&pose, &body_from_array, b)));
                }
            }
        }
        sights
    }

    /// The linear proposal: the linear window's frames, levelled (its mean gravity to −z).
    pub(in crate::fusion::nonlinear) fn propose_linear(&self, start: &Start) -> Option<Proposal> {
        let linear = start.solver.proposal()?;
        let frames: HashMap<i64, FrameEstimate> =
            linear.frames.iter().map(|f| (f.t.0, *f)).collect();
        // Level: the mean upward gravity in b0 to +z (summed in the frames' order: the result
        // must not depend on a hash order).
        let up: Vector3<f64> = linear
            .frames
            .iter()
            .map(|f| f.b0_from_bk * f.g_in_bk)
            .sum::<Vector3<f64>>();
        let n = frames.len().max(1) as f64;
        let g_norm = up.norm() / n;
        if !(0.8 * STANDARD_GRAVITY_M_S2..1.2 * STANDARD_GRAVITY_M_S2).contains(&g_norm) {
            return None;
        }
        let w_from_b0 = UnitQuaternion::rotation_between(&up, &Vector3::z())?;
        let bg = linear.gyro_bias_rad_s;
        let ba = linear.accel_bias_m_s2;
        // The longest run of start keyframes the linear window still has.
        let first = start
            .keyframes
            .iter()
            .rposition(|k| !frames.contains_key(&k.t.0))
            .map_or(0, |i| i + 1);
        let states = start
            .keyframes
            .iter()
            .skip(first)
            .map(|k| {
                let f = frames.get(&k.t.0)?;
                let r = w_from_b0 * f.b0_from_bk;
                Some(NavState {
                    t: f.t,
                    world_from_body: r,
                    p_b_in_w: w_from_b0 * f.p_in_b0,
                    v_b_in_w: r * f.v_in_bk,
                    gyro_bias_rad_s: bg,
                    accel_bias_m_s2: ba,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        let aps = linear
            .aps_in_b0
            .iter()
            .map(|c| c.map(|c| w_from_b0 * c))
            .collect();
        Some(Proposal {
            first,
            states,
            aps,
            ap_priors: Vec::new(),
            tilt_sigma_rad: LINEAR_TILT_SIGMA_RAD,
            velocity_sigma_m_s: f64::INFINITY,
            rest: None,
        })
    }

    /// The nonlinear window over a proposal, iterated; `None` when it is not accepted.
    pub(in crate::fusion::nonlinear) fn refine(
        &self,
        start: &Start,
        proposal: Proposal,
    ) -> Option<NonlinearWindow> {
        let Proposal {
            first,
            states,
            aps,
            ap_priors,
            tilt_sigma_rad,
            velocity_sigma_m_s,
            rest,
        } = proposal;
        let keys: Vec<_> = start.keyframes.iter().skip(first).collect();
        let (k0, x0) = (keys.first()?, *states.first()?);
        let g = STANDARD_GRAVITY_M_S2;
        let baro = self.has_baro.then(|| {
            let d: Vec<f64> = keys
                .iter()
                .zip(&states)
                .flat_map(|(k, x)| {
                    k.frames.iter().filter_map(|f| {
                        f.altitude_m
                            .map(|h| h - pose_at(x, &f.partial, g).p_b_in_w.z)
                    })
                })
                .collect();
            if d.is_empty() {
                0.0
            } else {
                d.iter().sum::<f64>() / d.len() as f64
            }
        });
        let mut w = NonlinearWindow::new(
            NonlinearConfig {
                bearing_correlation_s: 0.0,
                ..self.config.clone()
            },
            g,
            self.sensors.imu_noise.clone(),
            self.sensors.body_from_array,
            x0,
            k0.frames.clone(),
            &self.start_prior(&x0, tilt_sigma_rad, velocity_sigma_m_s, rest.as_ref()),
            aps,
            baro,
            (self.config.sin_bias_sigma > 0.0).then_some((0.0, self.config.sin_bias_sigma)),
        );
        for (l, info, _) in &ap_priors {
            if let Some(c) = w.ap(*l) {
                w.place_ap(*l, c, info);
            }
        }
        for (k, x) in keys.iter().zip(&states).skip(1) {
            w.push_keyframe(*x, k.from_prev.clone()?, k.frames.clone())?;
        }
        w.optimize(self.config.iterations_at_start).ok()?;
        let fit = w.fit();
        let ap_ok = (0..w.aps().len()).filter(|&l| w.is_placed(l)).all(|l| {
            let range = w.ap_nearest_range_m(l).unwrap_or(f64::INFINITY);
            // An AP the relocation placed (after a hole) is judged by the relocation's σ, whose
            // velocity and tilt corrections hold the heading the window's own start lacks for
            // seconds; the window's χ² still has to pass.
            let relocated_sigma = ap_priors.iter().find(|p| p.0 == l).map(|p| p.2);
            relocated_sigma
                .or(w.ap_horizontal_sigma_m(l))
                .is_some_and(|s| self.config.ap_sigma_ok(s, range))
                && range > MIN_AP_RANGE_M
        });
        if !(ap_ok && passes_chi2(&fit, w.border_dim(), self.config.chi2_significance)) {
            return None;
        }
        w.set_bearing_correlation_s(self.config.bearing_correlation_s);
        Some(w)
    }

    /// The prior on the start's first keyframe: the gauge (position, yaw), the roll and pitch
    /// (σ `tilt_sigma_rad`), the velocity (σ `velocity_sigma_m_s`; at most 100 m/s), the biases'
    /// spreads (the gyro's from the rest when there was one), and the rest's specific force when
    /// `x0` leaves from a rest: `r = ΔR R̂ᵀ g_w + b_a − f`, with
    /// `∂r/∂δθ = ΔR [R̂ᵀ g_w]×` and `∂r/∂δb_a = I` (zero at `x0`, which was levelled on it).
    fn start_prior(
        &self,
        x0: &NavState,
        tilt_sigma_rad: f64,
        velocity_sigma_m_s: f64,
        rest: Option<&RestForce>,
    ) -> Mat15 {
        let mut h = Mat15::zeros();
        let r: Matrix3<f64> = x0.world_from_body.to_rotation_matrix().into_inner();
        // δθ is body-side: a world-frame tilt/yaw information Λ_w becomes Rᵀ Λ_w R.
        let lw = Matrix3::from_diagonal(&Vector3::new(
            tilt_sigma_rad.powi(-2),
            tilt_sigma_rad.powi(-2),
            GAUGE_YAW_SIGMA_RAD.powi(-2),
        ));
        h.fixed_view_mut::<3, 3>(THETA, THETA)
            .copy_from(&(r.transpose() * lw * r));
        let noise = &self.sensors.imu_noise;
        let gyro_sigma = match self.static_init {
            Some(s) => (3.0 * noise.gyro_noise_density_rad_s_sqrt_hz
                / s.duration_s.max(0.1).sqrt())
            .max(REST_GYRO_BIAS_SIGMA_RAD_S),
            None => noise.gyro_turn_on_bias_rad_s.max(1e-4),
        };
        for i in 0..3 {
            h[(POS + i, POS + i)] = GAUGE_POSITION_SIGMA_M.powi(-2);
            h[(VEL + i, VEL + i)] = velocity_sigma_m_s.max(1e-3).powi(-2).max(1e-4);
            h[(BG + i, BG + i)] = gyro_sigma.powi(-2);
        }
        let ba_info = Matrix3::identity() * noise.accel_turn_on_bias_m_s2.max(1e-3).powi(-2);
        h.fixed_view_mut::<3, 3>(BA, BA).copy_from(&ba_info);
        if let Some(rest) = rest {
            let white = noise.accel_noise_density_m_s2_sqrt_hz / rest.duration_s.max(0.1).sqrt();
            let info = (white.powi(2) + REST_FORCE_SIGMA_M_S2.powi(2)).recip();
            let g_in_b = r.transpose() * Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2);
            let mut j = nalgebra::SMatrix::<f64, 3, 15>::zeros();
            j.fixed_view_mut::<3, 3>(0, THETA)
                .copy_from(&(rest.rest_from_body * g_in_b.cross_matrix()));
            j.fixed_view_mut::<3, 3>(0, BA)
                .copy_from(&Matrix3::identity());
            h += j.transpose() * j * info;
        }
        h
    }

    /// After a hole: the AP of the lost window with the most bearings since, found with the
    /// velocity and tilt corrections of the dead reckoning at `states` ([`crate::fusion::nonlinear::recovery::relocate`]).
    pub(super) fn relocate_after_hole(
        &self,
        start: &Start,
        states: &[NavState],
    ) -> Option<(usize, Relocated, ApFromDrone)> {
        let fix = start.hole.as_ref()?;
        let reference = start.reference.as_ref()?;
        let sights: Vec<Vec<TimedSight>> = self
            .sights_along(start, states)
            .into_iter()
            .map(|s| {
                s.into_iter()
                    .map(|(t, sight)| TimedSight {
                        sight,
                        t_s: t.secs_since(reference.t),
                    })
                    .collect()
            })
            .collect();
        let lost = fix
            .aps_in_w
            .iter()
            .max_by_key(|ap| sights.get(ap.l).map_or(0, Vec::len))?;
        let (l, c_old) = (lost.l, lost.c_in_w);
        // The lost window's AP in the new window's frame, were the carried heading right.
        let c_guess = self.anchor.inverse_transform_point(&c_old.into()).coords;
        let sigma_old = lost.sigma_m;
        let ap = ApFromDrone {
            drone: reference.p_b_in_w,
            offset: c_guess - reference.p_b_in_w,
            sigma_m: fix.carried_sigma_m.hypot(sigma_old),
        };
        let found = relocate(
            sights.get(l)?,
            &ap,
            &reference.v_b_in_w,
            self.config.cauchy_scale,
        )?;
        Some((l, found, ap))
    }
}
