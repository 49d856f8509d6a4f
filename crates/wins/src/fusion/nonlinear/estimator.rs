//! The nonlinear estimator as a push API (IMU samples, bearings and barometer samples in; poses
//! out). What it does with a frame depends on the flight's phase ([`crate::fusion::nonlinear::phase`]), and the
//! frame handler is one `match` on it (`on_frame`):
//!
//! 1. **At rest** ([`crate::fusion::nonlinear::start::rest`]): while the IMU is still, the gyro bias, roll, pitch and the
//!    accelerometer bias along gravity.
//! 2. **Starting** ([`crate::fusion::nonlinear::start`]): from the rest's end the IMU alone carries the trajectory
//!    (dead reckoning) and the APs are triangulated against it: the inertial proposal, for up to
//!    [`NonlinearConfig::inertial_start_max_s`]. Without such a state (a flight started in the
//!    air) a start solver (the paper's linear window, [`crate::fusion::proposal`]) solves
//!    positions, velocities, gravity and APs from zeros and proposes its solution. Every
//!    [`NonlinearConfig::start_retry_s`] (or [`NonlinearConfig::start_retry_share`] of the start
//!    window's span, when longer) a proposal initializes the nonlinear window over the
//!    whole start (one keyframe per [`NonlinearConfig::keyframe_period_s`]), which is iterated
//!    and accepted only when its residuals pass the χ² test at
//!    [`NonlinearConfig::chi2_significance`] and every placed AP's horizontal σ is within
//!    [`NonlinearConfig::max_ap_sigma_m`] and its fraction of the range.
//! 3. **Tracking** ([`crate::fusion::nonlinear::track`]): one solve per keyframe; APs placed later join
//!    (`late_ap`). The same χ² tests over the window's residuals decide loss: failing for
//!    [`NonlinearConfig::loss_window_s`] in a row ends the window.
//! 4. **Recovering**: a start again from the last keyframe that passed, propagated by the IMU to
//!    now, or after a hole from the newest keyframe carried across it (`holes`); the output frame
//!    is kept (the new window is placed at that state), so the trajectory does not jump back.

use std::collections::VecDeque;

use nalgebra::{Isometry3, Matrix3, Vector3};

use crate::fusion::bearing::Bearing;
use crate::fusion::error::EstimatorError;
use crate::fusion::frames::{check_frame_order, drop_frames_in_gap};
use crate::fusion::nonlinear::config::{NonlinearConfig, Sensors};
use crate::fusion::nonlinear::phase::{AtRest, Phase, PhaseChange, PhaseKind, Reason};
use crate::fusion::nonlinear::solve::{NonlinearWindow, SubFrame};
use crate::fusion::nonlinear::start::StartKeyframe;
use crate::fusion::nonlinear::start::rest::{ONSET_MARGIN_S, RestDetector, StaticInit};
use crate::fusion::nonlinear::start::still::StillDetector;
use crate::fusion::pose::{ApInWorld, PoseEstimate, Step};
use crate::fusion::proposal::StartSolverFactory;
use crate::fusion::stats::EstimatorStats;
use crate::imu::{
    ImuBiases, ImuSample, NoiseMeter, Preintegrated, Preintegrator, STANDARD_GRAVITY_M_S2,
};
use crate::time::Timestamp;

/// A frame waiting for the IMU to pass it.
#[derive(Clone, Debug)]
struct PendingFrame {
    t: Timestamp,
    bearings: Vec<Bearing>,
    altitude_m: Option<f64>,
}

/// The inputs not yet taken: the IMU since the last frame, and the frames it has not passed.
#[derive(Clone, Debug)]
pub(super) struct Inputs {
    pub(super) pre: Preintegrator,
    /// The IMU's noise as its samples show it.
    meter: NoiseMeter,
    pending: VecDeque<PendingFrame>,
    /// How long the IMU gaps since the last frame lasted, s (`holes`).
    imu_gap_s: f64,
}

/// What the estimator reports of its history.
#[derive(Clone, Debug, Default)]
pub(super) struct Record {
    pub(super) stats: EstimatorStats,
    /// When the output first started (a restart does not reset it).
    pub(super) converged_at: Option<Timestamp>,
    /// Changes of the frame poses are given in (a start or a restart).
    pub(super) epoch: u64,
    /// Every change of phase.
    pub(super) timeline: Vec<PhaseChange>,
}

/// The estimator (module doc).
#[derive(Clone, Debug)]
pub struct NonlinearEstimator {
    pub(super) config: NonlinearConfig,
    pub(super) sensors: Sensors,
    /// Makes the start solver of a start with no known state.
    pub(super) start_solver: StartSolverFactory,
    pub(super) has_baro: bool,
    pub(super) inputs: Inputs,
    /// Stillness for the zero-velocity updates ([`crate::fusion::nonlinear::start::still`]).
    pub(super) still: StillDetector,
    /// What the rest measured, when the flight started at rest.
    pub(super) static_init: Option<StaticInit>,
    /// IMU since the newest keyframe.
    pub(super) since_keyframe: Option<Preintegrated>,
    /// Output `w` from the window's `w`.
    pub(super) anchor: Isometry3<f64>,
    pub(super) record: Record,
    /// The phase, with the state only it owns ([`crate::fusion::nonlinear::phase`]).
    pub(super) phase: Phase,
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
        let at_rest = AtRest {
            detector: RestDetector::new(
                config.clone(),
                sensors.imu_noise.clone(),
                STANDARD_GRAVITY_M_S2,
            ),
            intervals: VecDeque::new(),
        };
        Self {
            inputs: Inputs {
                pre: Preintegrator::new(sensors.imu_noise.clone(), ImuBiases::zero())
                    .with_gap(sensors.imu_gap),
                meter: NoiseMeter::new(config.imu_noise_time_constant_s),
                pending: VecDeque::new(),
                imu_gap_s: 0.0,
            },
            still: StillDetector::new(&config, &sensors.imu_noise, STANDARD_GRAVITY_M_S2),
            config,
            sensors,
            start_solver,
            has_baro,
            static_init: None,
            since_keyframe: None,
            anchor: Isometry3::identity(),
            record: Record {
                timeline: vec![PhaseChange {
                    phase: PhaseKind::AtRest,
                    t_s: None,
                    reason: Reason::Created,
                }],
                ..Record::default()
            },
            phase: Phase::AtRest(Box::new(at_rest)),
        }
    }

    /// Counters.
    pub fn stats(&self) -> EstimatorStats {
        self.record.stats
    }

    /// When the output first started (a restart does not reset it).
    pub fn converged_at(&self) -> Option<Timestamp> {
        self.record.converged_at
    }

    /// The phase now.
    pub fn phase(&self) -> PhaseKind {
        self.phase.kind()
    }

    /// Every change of phase so far, with its time and reason.
    pub fn timeline(&self) -> &[PhaseChange] {
        &self.record.timeline
    }

    /// Whether the nonlinear window is running now.
    pub fn is_tracking(&self) -> bool {
        self.phase.kind() == PhaseKind::Tracking
    }

    /// The static initialization, when the flight started at rest.
    pub fn static_init(&self) -> Option<&StaticInit> {
        self.static_init.as_ref()
    }

    /// The nonlinear window (while tracking).
    pub fn window(&self) -> Option<&NonlinearWindow> {
        self.phase.window()
    }

    /// Starts and restarts so far: poses of different epochs are in different `b0` frames.
    pub fn epoch(&self) -> u64 {
        self.record.epoch
    }

    /// The gyro bias now, rad/s.
    pub fn gyro_bias_rad_s(&self) -> Vector3<f64> {
        match &self.phase {
            Phase::Tracking(t) => t
                .window
                .newest()
                .map_or(Vector3::zeros(), |x| x.gyro_bias_rad_s),
            Phase::Starting(s) | Phase::Recovering(s) => s.solver.gyro_bias_rad_s(),
            Phase::AtRest(_) => self
                .static_init
                .map_or(Vector3::zeros(), |s| s.gyro_bias_rad_s),
        }
    }

    /// AP `l` in the frame poses are given in (`b0` of [`PoseEstimate`]), while tracking.
    pub fn ap_in_b0(&self, l: usize) -> Option<Vector3<f64>> {
        self.window()?.ap(l)
    }

    /// AP `l` in the output frame `w`, with its covariance there, while tracking.
    pub fn ap_in_w(&self, l: usize) -> Option<ApInWorld> {
        let w = self.window()?;
        let c = w.ap(l)?;
        let r = self.anchor.rotation.to_rotation_matrix();
        let covariance = w
            .ap_covariance(l)
            .unwrap_or_else(|| Matrix3::from_diagonal_element(f64::INFINITY));
        Some(ApInWorld {
            p_in_w: self.anchor.transform_point(&c.into()).coords,
            covariance_in_w: r.matrix() * covariance * r.matrix().transpose(),
        })
    }

    /// Queues a frame of bearings at `t`.
    pub fn push_bearings(
        &mut self,
        t: Timestamp,
        bearings: Vec<Bearing>,
    ) -> Result<(), EstimatorError> {
        self.solve_pending();
        self.check_order(t)?;
        if let Some(start) = self.phase.start_mut() {
            start.solver.push_bearings(t, bearings.clone())?;
        }
        self.inputs.pending.push_back(PendingFrame {
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
            self.record.stats.frames_refused += 1;
            return Ok(());
        }
        match self.inputs.pending.back_mut() {
            Some(p) if p.t == t => p.altitude_m = Some(altitude_m),
            _ => self.inputs.pending.push_back(PendingFrame {
                t,
                bearings: Vec::new(),
                altitude_m: Some(altitude_m),
            }),
        }
        Ok(())
    }

    fn check_order(&mut self, t: Timestamp) -> Result<(), EstimatorError> {
        let newest = self.inputs.pending.back().map(|p| p.t);
        check_frame_order(t, newest, &self.inputs.pre, &mut self.record.stats)
    }

    /// Integrates one IMU sample, processing every queued frame it passes.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, EstimatorError> {
        self.solve_pending();
        let (inputs, stats) = (&mut self.inputs, &mut self.record.stats);
        if let Err(e) = inputs.pre.check(s) {
            stats.imu_refused += 1;
            return Err(e.into());
        }
        if let Some(gap_s) = drop_frames_in_gap(&mut inputs.pending, |p| p.t, &inputs.pre, s, stats)
        {
            inputs.imu_gap_s += gap_s;
        }
        if self.config.imu_noise_from_data && inputs.meter.push(s) {
            let noise = inputs.meter.effective(&self.sensors.imu_noise);
            stats.imu_accel_density_max_m_s2_sqrt_hz = stats
                .imu_accel_density_max_m_s2_sqrt_hz
                .max(noise.accel_noise_density_m_s2_sqrt_hz);
            stats.imu_gyro_density_max_rad_s_sqrt_hz = stats
                .imu_gyro_density_max_rad_s_sqrt_hz
                .max(noise.gyro_noise_density_rad_s_sqrt_hz);
            inputs.pre.set_noise(noise);
        }
        let mut step = Step::default();
        if self.config.zero_velocity {
            self.still.push(s);
        }
        if let Phase::AtRest(rest) = &mut self.phase {
            if let Some(init) = rest.detector.push(s) {
                self.still
                    .set_biases(init.gyro_bias_rad_s, init.accel_bias_m_s2);
                self.static_init = Some(init);
                self.inputs.pre.set_bias(ImuBiases {
                    gyro_rad_s: init.gyro_bias_rad_s,
                    accel_m_s2: init.accel_bias_m_s2,
                });
            }
            if rest.detector.moved() {
                let intervals = std::mem::take(&mut rest.intervals);
                let start = self.new_start(s.t, None, intervals);
                self.enter(Phase::Starting(Box::new(start)), Some(s.t), Reason::Motion);
            }
        }
        if let Some(start) = self.phase.start_mut() {
            match start.solver.push_imu(s) {
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
        while self.inputs.pending.front().is_some_and(|p| p.t <= s.t) {
            let Some(frame) = self.inputs.pending.pop_front() else {
                break;
            };
            if self.inputs.pre.last_sample().is_none() {
                self.record.stats.frames_late += 1;
                continue;
            }
            let interval = self.inputs.pre.cut(frame.t, s)?;
            if let Some(pose) = self.on_frame(frame, interval) {
                step.frames.push(pose);
            }
        }
        self.inputs.pre.push(s)?;
        self.record.stats.imu_samples += 1;
        step.imu_pose = self.propagated();
        Ok(step)
    }

    /// One frame, by phase: kept for the motion's onset at rest, a hole's end or a keyframe
    /// while tracking, a start keyframe while starting or recovering; the pose when tracking.
    fn on_frame(&mut self, frame: PendingFrame, interval: Preintegrated) -> Option<PoseEstimate> {
        self.solve_pending();
        self.record.stats.bearings += frame.bearings.len() as u64;
        self.record.stats.frames += 1;
        let imu_gap_s = std::mem::take(&mut self.inputs.imu_gap_s);
        let imu_gap = imu_gap_s > 0.0;
        let t = frame.t;
        match &mut self.phase {
            // Frames at rest carry no geometry; their IMU is kept for the motion's onset.
            Phase::AtRest(rest) => {
                let keep_s = 2.0 * ONSET_MARGIN_S + 0.2;
                while rest
                    .intervals
                    .front()
                    .is_some_and(|i| t.secs_since(i.end) > keep_s)
                {
                    rest.intervals.pop_front();
                }
                rest.intervals.push_back(interval);
                return None;
            }
            Phase::Tracking(_) => {
                if self.after_hole(t, imu_gap) {
                    self.restart_after_hole(t, &interval, imu_gap_s);
                    return None;
                }
            }
            Phase::Starting(_) | Phase::Recovering(_) => {
                if imu_gap {
                    self.restart_start(t);
                    return None;
                }
                if let Some(start) = self.phase.start_mut() {
                    start.dead_reckon(t, &interval, &self.config);
                }
            }
        }
        let (is_keyframe, from_prev) = self.next_keyframe(t, &frame, interval)?;
        let partial = self
            .since_keyframe
            .clone()
            .unwrap_or_else(|| Preintegrated::empty(t, self.inputs.pre.bias()));
        let sub = SubFrame {
            partial,
            bearings: frame.bearings,
            altitude_m: frame.altitude_m,
        };
        if self.is_tracking() {
            return self.track(t, is_keyframe, from_prev, sub);
        }
        let max_start_window_s = self.config.max_start_window_s;
        let start = self.phase.start_mut()?;
        if is_keyframe {
            start.push_keyframe(
                StartKeyframe {
                    t,
                    from_prev,
                    frames: vec![sub],
                    dead_reckoned: start.dead_reckoned,
                },
                max_start_window_s,
            );
            self.maybe_start(t);
        } else if let Some(k) = start.keyframes.back_mut() {
            k.frames.push(sub);
        }
        self.pose_now(t)
    }

    /// Whether the frame at `t` is a keyframe, with the IMU from the previous keyframe; `None`
    /// before the first keyframe. Keyframes only at frames of bearings: the start takes their
    /// states from the start solver, which has a frame at each of those.
    fn next_keyframe(
        &mut self,
        t: Timestamp,
        frame: &PendingFrame,
        interval: Preintegrated,
    ) -> Option<(bool, Option<Preintegrated>)> {
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
            self.since_keyframe = Some(Preintegrated::empty(t, self.inputs.pre.bias()));
        }
        Some((is_keyframe, from_prev))
    }
}
