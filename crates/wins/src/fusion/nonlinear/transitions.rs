//! Every change of the estimator's phase ([`super::phase`]), in one place: the start at the
//! first motion or again after an IMU gap, the acceptance of a start window into tracking, the
//! loss of a window, and the end of a window at a hole; each enters its phase through
//! `NonlinearEstimator::enter`, which records it with its reason.

use std::collections::VecDeque;

use nalgebra::{Isometry3, Translation3, Vector3};

use super::estimator::NonlinearEstimator;
use super::phase::{Phase, PhaseChange, PhaseKind, Reason, Tracking};
use super::recovery::Recovery;
use super::solve::NonlinearWindow;
use super::start::{Start, StartContext};
use super::state::{NavState, pose_at};
use crate::fusion::proposal::StartPrior;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::so3::heading;
use crate::time::Timestamp;

impl NonlinearEstimator {
    /// Every transition: enters `phase` at `t` for `reason`, and records it.
    pub(super) fn enter(&mut self, phase: Phase, t: Option<Timestamp>, reason: Reason) {
        self.record.timeline.push(PhaseChange {
            phase: phase.kind(),
            t_s: t.map(|t| t.as_secs_f64()),
            reason,
        });
        self.phase = phase;
    }

    /// Whether a frame at `t` comes after a hole in the tracking window's information: an IMU
    /// gap since the last frame, or no keyframe for longer than the dead-reckoning limit.
    pub(super) fn after_hole(&self, t: Timestamp, imu_gap: bool) -> bool {
        let Some(newest) = self.phase.window().and_then(|w| w.newest()) else {
            return false;
        };
        imu_gap || t.secs_since(newest.t) > self.config.max_dead_reckoning_s
    }

    /// Ends the tracking window at the frame `t` after a hole, `interval` the IMU since the
    /// last frame (with gaps of `imu_gap_s` s in it): restarts from the newest keyframe
    /// carried to `t` by the IMU, keeping its placed APs for the new window (`relocated`).
    pub(super) fn restart_after_hole(
        &mut self,
        t: Timestamp,
        interval: &Preintegrated,
        imu_gap_s: f64,
    ) {
        let Some(w) = self.phase.window() else {
            return;
        };
        let Some(newest) = w.newest().copied() else {
            return;
        };
        let mut carried = self
            .since_keyframe
            .clone()
            .unwrap_or_else(|| Preintegrated::empty(newest.t, interval.bias));
        if carried.append(interval).is_err() {
            carried = interval.clone();
        }
        let p = pose_at(&newest, &carried, STANDARD_GRAVITY_M_S2);
        let a = self.anchor;
        let from = NavState {
            t,
            world_from_body: a.rotation * p.world_from_body,
            p_b_in_w: a.transform_point(&p.p_b_in_w.into()).coords,
            v_b_in_w: a.rotation * p.v_b_in_w,
            ..newest
        };
        let fix = self.recovery().hole_fix(w, t, carried.dt_s(), imu_gap_s);
        self.record.stats.restarts += 1;
        self.record.epoch += 1;
        let mut start = self.new_start(t, Some(from), VecDeque::new());
        // The carried velocity and attitude are guesses: the start solver starts from zeros.
        start.solver = self.start_solver.make(None);
        start.hole = fix;
        let reason = if imu_gap_s > 0.0 {
            Reason::ImuGap
        } else {
            Reason::CsiOutage
        };
        self.enter(Phase::Recovering(Box::new(start)), Some(t), reason);
    }

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
        self.since_keyframe = None;
        let start = Start {
            since: t,
            solver: self.start_solver.make(None),
            keyframes: VecDeque::new(),
            reference: None,
            reference_is_rest: false,
            dead_reckoned: None,
            last_try: None,
            hole,
        };
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
        let retry_s = self
            .config
            .start_retry_s
            .max(self.config.start_retry_share * start.span_s());
        if t.secs_since(start.since) < self.config.start_after_motion_s
            || start.last_try.is_some_and(|l| t.secs_since(l) < retry_s)
        {
            return;
        }
        let started = self.start_window(start).and_then(|w| {
            let Some(hole) = &start.hole else {
                return Some((w, None));
            };
            let placement = self.recovery().placement(hole, &w);
            // After a hole, a window whose APs disagree with the lost window's is a wrong one.
            if !placement.is_none_or(|p| p.agrees) {
                return None;
            }
            // After a hole, the lost window's APs also anchor the new window's ranges
            // (`anchor`).
            Some(match self.recovery().anchored(hole, &w) {
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
            let mut recovery = Recovery {
                config: &self.config,
                anchor: self.anchor,
            };
            if let Some(tracking) = self.phase.tracking_mut() {
                recovery.place_by_aps(&mut tracking.window, hole, placement);
            }
            self.anchor = recovery.anchor;
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
        let ctx = self.start_context();
        if start.hole.is_some() {
            // After a hole the carried state is a guess: each proposal gets its chance.
            return (ctx
                .propose_inertial(start)
                .and_then(|p| ctx.refine(start, p)))
            .or_else(|| ctx.propose_linear(start).and_then(|p| ctx.refine(start, p)));
        }
        let proposal = ctx
            .propose_inertial(start)
            .or_else(|| ctx.propose_linear(start))?;
        ctx.refine(start, proposal)
    }

    /// What a start reads of the estimator.
    fn start_context(&self) -> StartContext<'_> {
        StartContext {
            config: &self.config,
            sensors: &self.sensors,
            has_baro: self.has_baro,
            static_init: self.static_init,
            anchor: self.anchor,
        }
    }

    /// What recovery reads of the estimator.
    fn recovery(&self) -> Recovery<'_> {
        Recovery {
            config: &self.config,
            anchor: self.anchor,
        }
    }

    /// The estimate is lost (for `reason`): start over from the last good keyframe, propagated
    /// to now.
    pub(super) fn lose(&mut self, t: Timestamp, reason: Reason) {
        self.record.stats.restarts += 1;
        let from = self.phase.tracking().and_then(|tr| {
            let w = &tr.window;
            let good = tr.last_good?;
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
        self.record.epoch += 1;
        let start = self.new_start(t, from, VecDeque::new());
        self.enter(Phase::Recovering(Box::new(start)), Some(t), reason);
    }
}
