//! A start (module doc of [`crate::fusion::nonlinear::estimator`], step 2), from the rest, from nothing (airborne),
//! or after a loss or a hole: the state it owns, how it begins, its keyframes, and its
//! acceptance into tracking. The proposals it tries are in `proposal`.

pub mod proposal;
pub mod rest;
pub mod still;
pub mod triangulate;

use std::collections::VecDeque;

use nalgebra::{Isometry3, Translation3, Vector3};

use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::estimator::NonlinearEstimator;
use crate::fusion::nonlinear::phase::{Phase, PhaseKind, Reason, Tracking};
use crate::fusion::nonlinear::recovery::HoleFix;
use crate::fusion::nonlinear::solve::{NonlinearWindow, SubFrame};
use crate::fusion::nonlinear::state::{NavState, pose_at};
use crate::fusion::proposal::{StartPrior, StartSolver};
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::so3::heading;
use crate::time::Timestamp;

/// A keyframe of the start window (its state comes from a proposal).
#[derive(Clone, Debug)]
pub(super) struct StartKeyframe {
    pub(super) t: Timestamp,
    pub(super) from_prev: Option<Preintegrated>,
    pub(super) frames: Vec<SubFrame>,
    /// The state the IMU alone gives here, from the start's reference state.
    pub(super) dead_reckoned: Option<NavState>,
}

/// A start's own state.
#[derive(Clone, Debug)]
pub(super) struct Start {
    /// When it began (the motion, or the restart).
    pub(super) since: Timestamp,
    /// The start solver, fed the same inputs, for a proposal when no state is known.
    pub(super) solver: Box<dyn StartSolver>,
    pub(super) keyframes: VecDeque<StartKeyframe>,
    /// The known state the start leaves from (the end of a rest, or a lost window's last good
    /// state), in the window's frame; `None` when there is none or it is too old.
    pub(super) reference: Option<NavState>,
    /// Whether `reference` is the end of the rest (its accelerometer bias then is the rest's).
    pub(super) reference_is_rest: bool,
    /// The IMU's dead reckoning from `reference` to the newest frame.
    pub(super) dead_reckoned: Option<NavState>,
    /// When a window was last tried.
    pub(super) last_try: Option<Timestamp>,
    /// What a window lost to a hole left to place the new one by (`holes`).
    pub(super) hole: Option<HoleFix>,
}

impl Start {
    /// Carries the dead reckoning to `t` over `interval`; past
    /// [`NonlinearConfig::inertial_start_max_s`] from the reference it is dropped (the start
    /// solver's proposal remains).
    pub(super) fn dead_reckon(
        &mut self,
        t: Timestamp,
        interval: &Preintegrated,
        config: &NonlinearConfig,
    ) {
        let Some(x) = self.dead_reckoned else {
            return;
        };
        if self
            .reference
            .is_none_or(|r| t.secs_since(r.t) > config.inertial_start_max_s)
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

    /// Appends a keyframe, dropping those older than `max_window_s`.
    pub(super) fn push_keyframe(&mut self, k: StartKeyframe, max_window_s: f64) {
        let t = k.t;
        self.keyframes.push_back(k);
        while self
            .keyframes
            .front()
            .is_some_and(|k| t.secs_since(k.t) > max_window_s)
        {
            self.keyframes.pop_front();
            if let Some(f) = self.keyframes.front_mut() {
                f.from_prev = None;
            }
        }
    }
}

impl NonlinearEstimator {
    /// A start at `t` from `from` (the state to restart from, in the output frame), or else the
    /// static initialization, carried by the IMU of the rest's last frames `rest_intervals`.
    /// Leaving from `from` places the output frame there and takes its biases.
    pub(super) fn new_start(
        &mut self,
        t: Timestamp,
        from: Option<NavState>,
        rest_intervals: VecDeque<Preintegrated>,
    ) -> Start {
        self.since_keyframe = None;
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
        let reference = match (from, self.static_init) {
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
        let reference_is_rest = from.is_none() && reference.is_some();
        let mut start = Start {
            since: t,
            solver: self.start_solver.make(prior),
            keyframes: VecDeque::new(),
            reference,
            reference_is_rest,
            dead_reckoned: reference,
            last_try: None,
            hole: None,
        };
        if reference_is_rest {
            // From the rest's end through the frames the detector needed to see the motion.
            for i in rest_intervals {
                if start.reference.is_some_and(|r| i.start >= r.t) {
                    start.dead_reckon(i.end, &i, &self.config);
                }
            }
        }
        if let Some(x) = from {
            self.inputs.pre.set_bias(x.biases());
            // The new window's level `b0` frame is placed at this state (module doc).
            self.anchor =
                Isometry3::from_parts(Translation3::from(x.p_b_in_w), heading(&x.world_from_body));
        }
        start
    }

    /// A gap in the IMU stream during a start: the start begins again at `t` from nothing (the
    /// state it left from is too old to carry), keeping what a hole before it left.
    pub(super) fn restart_start(&mut self, t: Timestamp) {
        let kind = self.phase.kind();
        let hole = self.phase.start_mut().and_then(|s| s.hole.take());
        let mut start = self.new_start(t, None, VecDeque::new());
        start.reference = None;
        start.reference_is_rest = false;
        start.dead_reckoned = None;
        start.solver = self.start_solver.make(None);
        start.hole = hole;
        let phase = match kind {
            PhaseKind::Recovering => Phase::Recovering(Box::new(start)),
            _ => Phase::Starting(Box::new(start)),
        };
        self.enter(phase, Some(t), Reason::ImuGapWhileStarting);
    }

    /// Tries the start when it is time (module doc of [`crate::fusion::nonlinear::estimator`], step 2); an
    /// accepted window starts tracking.
    pub(super) fn maybe_start(&mut self, t: Timestamp) {
        let Some(start) = self.phase.start() else {
            return;
        };
        if t.secs_since(start.since) < self.config.start_after_motion_s
            || start
                .last_try
                .is_some_and(|l| t.secs_since(l) < self.config.start_retry_s)
        {
            return;
        }
        let started = self.start_window(start).and_then(|w| {
            let Some(hole) = &start.hole else {
                return Some((w, None));
            };
            let placement = self.placement(hole, &w);
            // After a hole, a window whose APs disagree with the lost window's is a wrong one.
            if !placement.is_none_or(|p| p.agrees) {
                return None;
            }
            // After a hole, the lost window's APs also anchor the new window's ranges
            // (`anchor`).
            Some(match self.anchored(hole, &w) {
                Some(a) => (a.window, Some(a.placement)),
                None => (w, placement),
            })
        });
        let Some(start) = self.phase.start_mut() else {
            return;
        };
        start.last_try = Some(t);
        let Some((window, placement)) = started else {
            self.record.stats.rejected_convergences += 1;
            return;
        };
        let hole = start.hole.take();
        let tracking = Tracking {
            window,
            failing_since: None,
            last_good: None,
            late_sights: Vec::new(),
            solve_due: None,
        };
        self.enter(
            Phase::Tracking(Box::new(tracking)),
            Some(t),
            Reason::Accepted,
        );
        if let Some(hole) = hole {
            self.place_by_aps(hole, placement);
        }
        self.trim_window();
        if let Some(tr) = self.phase.tracking_mut() {
            tr.last_good = tr.window.newest().copied();
        }
        self.record.epoch += 1;
        self.record.converged_at.get_or_insert(t);
    }

    /// The nonlinear window over the start, initialized from a proposal (the inertial one when
    /// the start has a known state to leave from, else the start solver's) and iterated; `None`
    /// when it is not accepted.
    fn start_window(&self, start: &Start) -> Option<NonlinearWindow> {
        if start.hole.is_some() {
            // After a hole the carried state is a guess: each proposal gets its chance.
            return (self
                .propose_inertial(start)
                .and_then(|p| self.refine(start, p)))
            .or_else(|| {
                self.propose_linear(start)
                    .and_then(|p| self.refine(start, p))
            });
        }
        let proposal = self
            .propose_inertial(start)
            .or_else(|| self.propose_linear(start))?;
        self.refine(start, proposal)
    }
}
