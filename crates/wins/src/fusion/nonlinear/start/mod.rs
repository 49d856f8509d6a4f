//! A start (module doc of [`crate::fusion::nonlinear::estimator`], step 2), from the rest, from nothing (airborne),
//! or after a loss or a hole: the state it owns, how it begins, its keyframes, and its
//! acceptance into tracking. The proposals it tries are in `proposal`.

pub mod proposal;
pub mod rest;
pub mod still;

use std::collections::VecDeque;

use nalgebra::Isometry3;

use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::config::Sensors;
use crate::fusion::nonlinear::recovery::HoleFix;
use crate::fusion::nonlinear::solve::SubFrame;
use crate::fusion::nonlinear::start::rest::StaticInit;
use crate::fusion::nonlinear::state::{NavState, pose_at};
use crate::fusion::proposal::StartSolver;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
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

    /// The time from the oldest keyframe to the newest, s (0 without two).
    pub(super) fn span_s(&self) -> f64 {
        match (self.keyframes.front(), self.keyframes.back()) {
            (Some(a), Some(b)) => b.t.secs_since(a.t),
            _ => 0.0,
        }
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

/// What a start reads of the estimator: its settings and sensors, the rest it may leave from,
/// and the output frame.
#[derive(Clone, Copy, Debug)]
pub(in crate::fusion::nonlinear) struct StartContext<'a> {
    pub(in crate::fusion::nonlinear) config: &'a NonlinearConfig,
    pub(in crate::fusion::nonlinear) sensors: &'a Sensors,
    pub(in crate::fusion::nonlinear) has_baro: bool,
    pub(in crate::fusion::nonlinear) static_init: Option<StaticInit>,
    /// Output `w` from the window's `w`.
    pub(in crate::fusion::nonlinear) anchor: Isometry3<f64>,
}
