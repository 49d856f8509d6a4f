//! The nonlinear estimator as a push API (IMU samples, bearings and barometer samples in; poses
//! out), and its start and recovery:
//!
//! 1. **Rest** ([`super::rest`]): while the IMU is still, the gyro bias, roll, pitch and the
//!    accelerometer bias along gravity.
//! 2. **Proposal**: from the rest's end (or a lost window's last good state) the IMU alone
//!    carries the trajectory (dead reckoning), and the APs are triangulated against it
//!    ([`super::triangulate`]): the inertial proposal, for up to
//!    [`NonlinearConfig::inertial_start_max_s`]. Without such a state (a flight started in the
//!    air) the paper's linear window (a start solver, [`crate::fusion::proposal`]) solves positions,
//!    velocities, gravity and APs from zeros and proposes its solution; its own convergence test
//!    is off.
//! 3. **Acceptance** (`start`): every [`NonlinearConfig::start_retry_s`] the proposal
//!    initializes the nonlinear window over the whole start (one keyframe per
//!    [`NonlinearConfig::keyframe_period_s`]), which is iterated. It is accepted only when its
//!    residuals pass the χ² test at [`NonlinearConfig::chi2_significance`] and every placed AP's
//!    horizontal σ is within [`NonlinearConfig::max_ap_sigma_m`] and its fraction of the range;
//!    then the window is marginalized down to [`NonlinearConfig::max_keyframes`] and the output
//!    starts, converged. APs placed later join from `late_ap`.
//! 4. **Tracking**: one solve per keyframe. The same χ² tests over the window's residuals decide
//!    loss: failing for [`NonlinearConfig::loss_window_s`] in a row restarts at 2 from the last
//!    keyframe that passed, propagated by the IMU to now; the output frame is kept (the new
//!    window is placed at that state), so the trajectory does not jump back.

use std::collections::VecDeque;

use nalgebra::{Isometry3, Translation3, Vector3};

use super::bridge::Before;
use super::config::NonlinearConfig;
use super::rest::{RestDetector, StaticInit};
use super::state::{NavState, pose_at};
use super::still::StillDetector;
use super::window::{NonlinearWindow, SubFrame};
use crate::fusion::bearing::Bearing;
use crate::fusion::error::EstimatorError;
use crate::fusion::frames::{check_frame_order, drop_frames_in_gap};
use crate::fusion::pose::{PoseEstimate, Step};
use crate::fusion::proposal::StartPrior;
use crate::fusion::proposal::{StartSolver, StartSolverFactory};
use crate::fusion::stats::EstimatorStats;
use crate::imu::ImuGap;
use crate::imu::{ImuBiases, ImuSample, Preintegrated, Preintegrator, STANDARD_GRAVITY_M_S2};
use crate::rig::ImuNoise;
use crate::so3::heading;
use crate::time::Timestamp;

/// What the estimator knows of its sensors (from the rig).
#[derive(Clone, Debug, PartialEq)]
pub struct Sensors {
    /// IMU noise densities.
    pub imu_noise: ImuNoise,
    /// How a gap in the IMU stream is integrated.
    pub imu_gap: ImuGap,
    /// The antenna array's mounting.
    pub body_from_array: Isometry3<f64>,
}

/// A frame waiting for the IMU to pass it.
#[derive(Clone, Debug)]
struct PendingFrame {
    t: Timestamp,
    bearings: Vec<Bearing>,
    altitude_m: Option<f64>,
}

/// A keyframe of the start window (its state comes from the linear solution).
#[derive(Clone, Debug)]
pub(super) struct StartKeyframe {
    pub(super) t: Timestamp,
    pub(super) from_prev: Option<Preintegrated>,
    pub(super) frames: Vec<SubFrame>,
    /// The state the IMU alone gives here, from the start's reference state.
    pub(super) dead_reckoned: Option<NavState>,
}

/// The estimator (module doc).
#[derive(Clone, Debug)]
pub struct NonlinearEstimator {
    pub(super) config: NonlinearConfig,
    pub(super) sensors: Sensors,
    /// Makes the start solver of a start with no known state.
    start_solver: StartSolverFactory,
    pub(super) has_baro: bool,
    pub(super) pre: Preintegrator,
    pending: VecDeque<PendingFrame>,
    rest: RestDetector,
    /// Stillness for the zero-velocity updates ([`super::still`]).
    pub(super) still: StillDetector,
    pub(super) static_init: Option<StaticInit>,
    pub(super) moving_since: Option<Timestamp>,
    pub(super) linear: Option<Box<dyn StartSolver>>,
    pub(super) start: VecDeque<StartKeyframe>,
    /// The known state the start leaves from (the end of a rest, or a lost window's last good
    /// state), in the window's frame; `None` when there is none or it is too old.
    pub(super) reference: Option<NavState>,
    /// Whether `reference` is the end of the rest (its accelerometer bias then is the rest's).
    pub(super) reference_is_rest: bool,
    /// The IMU's dead reckoning from `reference` to the newest frame.
    pub(super) dead_reckoned: Option<NavState>,
    /// The IMU between the last frames before the motion was detected (the motion starts before
    /// the detector can see it).
    rest_intervals: VecDeque<Preintegrated>,
    /// Bearings of APs the window does not hold yet, against its estimate ([`super::late_ap`]).
    pub(super) late_sights: Vec<super::triangulate::LateSights>,
    /// IMU since the newest keyframe.
    pub(super) since_keyframe: Option<Preintegrated>,
    pub(super) window: Option<NonlinearWindow>,
    /// Output `w` from the window's `w`.
    pub(super) anchor: Isometry3<f64>,
    pub(super) last_try: Option<Timestamp>,
    pub(super) failing_since: Option<Timestamp>,
    /// The newest keyframe that passed the loss test.
    pub(super) last_good: Option<NavState>,
    pub(super) stats: EstimatorStats,
    pub(super) converged_at: Option<Timestamp>,
    /// Changes of the frame poses are given in (a start or a restart).
    pub(super) epoch: u64,
    /// How long the IMU gaps since the last frame lasted, s ([`super::holes`]).
    imu_gap_s: f64,
    /// What a window lost to a hole leaves to place the next one by ([`super::holes`]).
    pub(super) ap_fix: Option<HoleFix>,
    /// The newest keyframe's time when its solve has not run yet ([`Self::solve_pending`]).
    pub(super) solve_due: Option<Timestamp>,
}

/// What a window lost to a hole (an IMU gap, a CSI outage) leaves for the next one.
#[derive(Clone, Debug)]
pub(super) struct HoleFix {
    /// Every AP the lost window had placed, in the output frame.
    pub(super) aps_in_w: Vec<LostAp>,
    /// The lost window's barometer offset in the output frame (`h = z + o`), m, when it had a
    /// barometer: the barometer runs on through an IMU gap, so the next window's height is
    /// placed by it.
    pub(super) baro_offset_m: Option<f64>,
    /// The first frame after the hole (where the new start leaves from).
    pub(super) t: Timestamp,
    /// 1σ of the carried position there, horizontal, m.
    pub(super) carried_sigma_m: f64,
    /// The lost window's newest keyframe, before the hole.
    pub(super) before: Before,
}

/// An AP a window lost to a hole had placed, in the output frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct LostAp {
    /// Its index.
    pub(super) l: usize,
    /// Its position, m.
    pub(super) c_in_w: Vector3<f64>,
    /// Its horizontal σ, m.
    pub(super) sigma_m: f64,
    /// The variance of its height, m² (weakly seen: an AP near the drone's height is seen at
    /// an elevation near zero).
    pub(super) var_z_m2: f64,
}

impl NonlinearEstimator {
    /// A fresh estimator; `has_baro`: barometer samples will come; `start_solver`: what
    /// proposes a start when no state is known (the paper's linear window,
    /// [`crate::fusion::choice`]).
    pub fn new(
        config: NonlinearConfig,
        sensors: Sensors,
        has_baro: bool,
        start_solver: StartSolverFactory,
    ) -> Self {
        Self {
            pre: Preintegrator::new(sensors.imu_noise.clone(), ImuBiases::zero())
                .with_gap(sensors.imu_gap),
            rest: RestDetector::new(config.clone(), STANDARD_GRAVITY_M_S2),
            still: StillDetector::new(&config, &sensors.imu_noise, STANDARD_GRAVITY_M_S2),
            config,
            sensors,
            start_solver,
            has_baro,
            pending: VecDeque::new(),
            static_init: None,
            moving_since: None,
            linear: None,
            start: VecDeque::new(),
            reference: None,
            reference_is_rest: false,
            dead_reckoned: None,
            rest_intervals: VecDeque::new(),
            late_sights: Vec::new(),
            since_keyframe: None,
            window: None,
            anchor: Isometry3::identity(),
            last_try: None,
            failing_since: None,
            last_good: None,
            stats: EstimatorStats::default(),
            converged_at: None,
            epoch: 0,
            imu_gap_s: 0.0,
            ap_fix: None,
            solve_due: None,
        }
    }

    /// A start solver from zeros.
    pub(super) fn new_start_solver(&self) -> Box<dyn StartSolver> {
        self.start_solver.make(None)
    }

    /// Counters.
    pub fn stats(&self) -> EstimatorStats {
        self.stats
    }

    /// When the output first started (a restart does not reset it).
    pub fn converged_at(&self) -> Option<Timestamp> {
        self.converged_at
    }

    /// Whether the nonlinear window is running now.
    pub fn is_tracking(&self) -> bool {
        self.window.is_some()
    }

    /// The static initialization, when the flight started at rest.
    pub fn static_init(&self) -> Option<&StaticInit> {
        self.static_init.as_ref()
    }

    /// The nonlinear window (while tracking).
    pub fn window(&self) -> Option<&NonlinearWindow> {
        self.window.as_ref()
    }

    /// Starts and restarts so far: poses of different epochs are in different `b0` frames.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// The gyro bias now, rad/s.
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        match (&self.window, &self.linear) {
            (Some(w), _) => w.newest().map_or(Vector3::zeros(), |x| x.gyro_bias_rad_s),
            (None, Some(l)) => l.gyro_bias_rad_s(),
            _ => self
                .static_init
                .map_or(Vector3::zeros(), |s| s.gyro_bias_rad_s),
        }
    }

    /// AP `l` in the frame poses are given in (`b0` of [`PoseEstimate`]), while tracking.
    pub fn ap_in_b0(&self, l: usize) -> Option<Vector3<f64>> {
        self.window.as_ref()?.ap(l)
    }

    /// AP `l` in the output frame `w`, and its largest σ, while tracking.
    pub fn ap_in_w(&self, l: usize) -> Option<(Vector3<f64>, f64)> {
        let w = self.window.as_ref()?;
        let c = w.ap(l)?;
        let sigma = w.ap_sigma_m(l).unwrap_or(f64::INFINITY);
        Some((self.anchor.transform_point(&c.into()).coords, sigma))
    }

    /// Queues a frame of bearings at `t`.
    pub fn push_bearings(
        &mut self,
        t: Timestamp,
        bearings: Vec<Bearing>,
    ) -> Result<(), EstimatorError> {
        self.solve_pending();
        self.check_order(t)?;
        if let Some(l) = &mut self.linear {
            l.push_bearings(t, bearings.clone())?;
        }
        self.pending.push_back(PendingFrame {
            t,
            bearings,
            altitude_m: None,
        });
        Ok(())
    }

    /// Queues a barometer altitude at `t`, m.
    pub fn push_baro(&mut self, t: Timestamp, altitude_m: f64) -> Result<(), EstimatorError> {
        self.solve_pending();
        self.check_order(t)?;
        if !altitude_m.is_finite() {
            self.stats.frames_refused += 1;
            return Ok(());
        }
        match self.pending.back_mut() {
            Some(p) if p.t == t => p.altitude_m = Some(altitude_m),
            _ => self.pending.push_back(PendingFrame {
                t,
                bearings: Vec::new(),
                altitude_m: Some(altitude_m),
            }),
        }
        Ok(())
    }

    fn check_order(&mut self, t: Timestamp) -> Result<(), EstimatorError> {
        let newest = self.pending.back().map(|p| p.t);
        check_frame_order(t, newest, &self.pre, &mut self.stats)
    }

    /// Integrates one IMU sample, processing every queued frame it passes.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError> {
        self.solve_pending();
        if let Err(e) = self.pre.check(s) {
            self.stats.imu_refused += 1;
            return Err(e.into());
        }
        if let Some(gap_s) =
            drop_frames_in_gap(&mut self.pending, |p| p.t, &self.pre, s, &mut self.stats)
        {
            self.imu_gap_s += gap_s;
        }
        let mut step = Step::default();
        if self.config.zero_velocity {
            self.still.push(s);
        }
        if !self.rest.moved() {
            if let Some(init) = self.rest.push(s) {
                self.static_init = Some(init);
                self.pre.set_bias(ImuBiases {
                    gyro_rad_s: init.gyro_bias_rad_s,
                    accel_m_s2: init.accel_bias_m_s2,
                });
            }
            if self.rest.moved() {
                self.begin_start(s.t, None);
            }
        }
        if let Some(l) = &mut self.linear {
            match l.push_imu(s) {
                Ok(ls) => step.frames.extend(ls.frames.into_iter().map(|mut p| {
                    p.converged = false;
                    p
                })),
                Err(e) => step.refused.extend(match e {
                    EstimatorError::Frame(w) => Some(w),
                    _ => None,
                }),
            }
        }
        while self.pending.front().is_some_and(|p| p.t <= s.t) {
            let Some(frame) = self.pending.pop_front() else {
                break;
            };
            if self.pre.last_sample().is_none() {
                self.stats.frames_late += 1;
                continue;
            }
            let interval = self.pre.cut(frame.t, s)?;
            if let Some(pose) = self.on_frame(frame, interval) {
                step.frames.push(pose);
            }
        }
        self.pre.push(s)?;
        self.stats.imu_samples += 1;
        step.imu_pose = self.propagated();
        Ok(step)
    }

    /// Starts (or restarts) the linear window at `t`, from `from` (the state to restart from,
    /// in the output frame) or the static initialization.
    pub(super) fn begin_start(&mut self, t: Timestamp, from: Option<NavState>) {
        self.moving_since = Some(t);
        self.start.clear();
        self.late_sights.clear();
        self.since_keyframe = None;
        self.window = None;
        self.last_try = None;
        self.failing_since = None;
        let g = STANDARD_GRAVITY_M_S2;
        let prior = match (from, self.static_init) {
            (Some(x), _) => Some(StartPrior {
                gravity_in_b0: x.world_from_body.inverse() * Vector3::new(0.0, 0.0, g),
                gravity_sigma_m_s2: 0.2,
                velocity_in_b0: x.world_from_body.inverse() * x.v_b_in_w,
                velocity_sigma_m_s: 0.5,
                gyro_bias_rad_s: x.gyro_bias_rad_s,
            }),
            (None, Some(init)) => Some(StartPrior {
                gravity_in_b0: init.specific_force_m_s2.normalize() * g,
                gravity_sigma_m_s2: 0.2,
                velocity_in_b0: Vector3::zeros(),
                velocity_sigma_m_s: 0.3,
                gyro_bias_rad_s: init.gyro_bias_rad_s,
            }),
            (None, None) => None,
        };
        self.reference = match (from, self.static_init) {
            (Some(x), _) => {
                // In the new window's frame: level, placed at x, heading removed (module doc).
                let h = heading(&x.world_from_body).inverse();
                Some(NavState {
                    t,
                    world_from_body: h * x.world_from_body,
                    p_b_in_w: Vector3::zeros(),
                    v_b_in_w: h * x.v_b_in_w,
                    ..x
                })
            }
            (None, Some(init)) => Some(NavState {
                t: init.rest_end,
                world_from_body: init.world_from_body,
                p_b_in_w: Vector3::zeros(),
                v_b_in_w: Vector3::zeros(),
                gyro_bias_rad_s: init.gyro_bias_rad_s,
                accel_bias_m_s2: init.accel_bias_m_s2,
            }),
            (None, None) => None,
        };
        self.reference_is_rest = from.is_none() && self.reference.is_some();
        self.dead_reckoned = self.reference;
        if self.reference_is_rest {
            // From the rest's end through the frames the detector needed to see the motion.
            let intervals = std::mem::take(&mut self.rest_intervals);
            for i in intervals {
                if self.reference.is_some_and(|r| i.start >= r.t) {
                    self.dead_reckon(i.end, &i);
                }
            }
        }
        if let Some(x) = from {
            self.pre.set_bias(x.biases());
            // The new window's level `b0` frame is placed at this state (module doc).
            self.anchor =
                Isometry3::from_parts(Translation3::from(x.p_b_in_w), heading(&x.world_from_body));
        }
        self.linear = Some(self.start_solver.make(prior));
    }

    /// One frame: into the start window or the nonlinear window; the pose when tracking.
    fn on_frame(&mut self, frame: PendingFrame, interval: Preintegrated) -> Option<PoseEstimate> {
        self.solve_pending();
        self.stats.bearings += frame.bearings.len() as u64;
        self.stats.frames += 1;
        let imu_gap_s = std::mem::take(&mut self.imu_gap_s);
        let imu_gap = imu_gap_s > 0.0;
        // Frames at rest carry no geometry; their IMU is kept for the motion's onset.
        if self.moving_since.is_none() {
            let keep_s = 2.0 * super::rest::ONSET_MARGIN_S + 0.2;
            while self
                .rest_intervals
                .front()
                .is_some_and(|i| frame.t.secs_since(i.end) > keep_s)
            {
                self.rest_intervals.pop_front();
            }
            self.rest_intervals.push_back(interval);
            return None;
        }
        let t = frame.t;
        if self.after_hole(t, imu_gap) {
            self.restart_after_hole(t, &interval, imu_gap_s);
            return None;
        }
        if imu_gap && self.window.is_none() {
            self.begin_start(t, None);
            self.forget_reference();
            return None;
        }
        if self.window.is_none() {
            self.dead_reckon(t, &interval);
        }
        // Keyframes only at frames of bearings: the start takes their states from the linear
        // window, which has a frame at each of those.
        let may_be_keyframe = !frame.bearings.is_empty();
        let (is_keyframe, from_prev) = match self.since_keyframe.take() {
            None if may_be_keyframe => (true, None),
            None => return None,
            Some(mut acc) => {
                if acc.append(&interval).is_err() {
                    acc = interval;
                }
                if may_be_keyframe && acc.dt_s() >= self.config.keyframe_period_s - 1e-9 {
                    (true, Some(acc))
                } else {
                    self.since_keyframe = Some(acc);
                    (false, None)
                }
            }
        };
        if is_keyframe {
            self.since_keyframe = Some(Preintegrated::empty(t, self.pre.bias()));
        }
        let partial = self
            .since_keyframe
            .clone()
            .unwrap_or_else(|| Preintegrated::empty(t, self.pre.bias()));
        let sub = SubFrame {
            partial,
            bearings: frame.bearings,
            altitude_m: frame.altitude_m,
        };
        if self.window.is_some() {
            return self.track(t, is_keyframe, from_prev, sub);
        }
        if is_keyframe {
            self.start.push_back(StartKeyframe {
                t,
                from_prev,
                frames: vec![sub],
                dead_reckoned: self.dead_reckoned,
            });
            while self
                .start
                .front()
                .is_some_and(|k| t.secs_since(k.t) > self.config.max_start_window_s)
            {
                self.start.pop_front();
                if let Some(f) = self.start.front_mut() {
                    f.from_prev = None;
                }
            }
            self.maybe_start(t);
        } else if let Some(k) = self.start.back_mut() {
            k.frames.push(sub);
        }
        self.pose_now(t)
    }

    /// Carries the dead reckoning to `t` over `interval`; past
    /// [`NonlinearConfig::inertial_start_max_s`] from the reference it is dropped (the linear
    /// window's proposal remains).
    fn dead_reckon(&mut self, t: Timestamp, interval: &Preintegrated) {
        let Some(x) = self.dead_reckoned else {
            return;
        };
        if self
            .reference
            .is_none_or(|r| t.secs_since(r.t) > self.config.inertial_start_max_s)
        {
            self.reference = None;
            self.dead_reckoned = None;
            return;
        }
        let p = pose_at(&x, interval, STANDARD_GRAVITY_M_S2);
        self.dead_reckoned = Some(NavState {
            t,
            world_from_body: p.world_from_body,
            p_b_in_w: p.p_b_in_w,
            v_b_in_w: p.v_b_in_w,
            ..x
        });
    }
}
