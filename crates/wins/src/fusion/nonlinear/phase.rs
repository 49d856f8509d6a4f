//! The phases a flight goes through, as a value: every transition happens in
//! `NonlinearEstimator::enter`, with its reason, and is recorded in the timeline
//! (`stats.json`'s `estimator.phases`).
//!
//! ```text
//!   AtRest ──motion──► Starting ──accepted──► Tracking ──lost / hole──► Recovering
//!                         ▲  │ IMU gap            ▲                        │  │ IMU gap
//!                         └──┘                    └────────accepted────────┘◄─┘
//! ```
//!
//! - `Phase::AtRest`: before the first motion; the rest detector measures the gyro bias,
//!   roll, pitch and the accelerometer bias along gravity ([`crate::fusion::nonlinear::start::rest`]).
//! - `Phase::Starting`: a start from the rest (or, airborne, from nothing): the start window
//!   gathers keyframes until a proposal passes the χ² acceptance ([`crate::fusion::nonlinear::start`]).
//! - `Phase::Tracking`: the nonlinear window runs, one solve per keyframe, and the loss test
//!   watches its residuals ([`crate::fusion::nonlinear::track`]).
//! - `Phase::Recovering`: a start after a loss or a hole, from the last good state carried to
//!   now; after a hole it places the new window by what the lost one knew
//!   (`holes`).

use serde::Serialize;

use crate::fusion::nonlinear::solve::NonlinearWindow;
use crate::fusion::nonlinear::start::Start;
use crate::fusion::nonlinear::start::rest::RestDetector;
use crate::fusion::nonlinear::triangulate::LateSights;
use crate::imu::Preintegrated;
use crate::time::Timestamp;

/// The phase and the state only it owns.
#[derive(Clone, Debug)]
pub(super) enum Phase {
    /// Before the first motion.
    AtRest(Box<AtRest>),
    /// A start from the rest, or airborne from nothing.
    Starting(Box<Start>),
    /// The nonlinear window runs.
    Tracking(Box<Tracking>),
    /// A start after a loss or a hole.
    Recovering(Box<Start>),
}

/// At rest: the rest detector, and the IMU of the last frames (the motion starts before the
/// detector can see it).
#[derive(Clone, Debug)]
pub(super) struct AtRest {
    pub(super) detector: RestDetector,
    pub(super) intervals: std::collections::VecDeque<Preintegrated>,
}

/// Tracking: the window and what the loss test and the late APs keep.
#[derive(Clone, Debug)]
pub(super) struct Tracking {
    pub(super) window: NonlinearWindow,
    /// Since when the residuals fail the χ² test.
    pub(super) failing_since: Option<Timestamp>,
    /// The newest keyframe that passed the loss test.
    pub(super) last_good: Option<crate::fusion::nonlinear::state::NavState>,
    /// Bearings of APs the window does not hold yet, against its estimate
    /// (`late_ap`).
    pub(super) late_sights: Vec<LateSights>,
    /// The newest keyframe's time when its solve has not run yet
    /// (`NonlinearEstimator::solve_pending`).
    pub(super) solve_due: Option<Timestamp>,
}

/// Which phase (for the timeline).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseKind {
    /// Before the first motion.
    AtRest,
    /// A start from the rest, or airborne from nothing.
    Starting,
    /// The nonlinear window runs.
    Tracking,
    /// A start after a loss or a hole.
    Recovering,
}

/// Why a phase began.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// The estimator was made.
    Created,
    /// The IMU moved (the end of the rest, or an airborne first sample).
    Motion,
    /// A start window passed the χ² acceptance and the AP bounds.
    Accepted,
    /// The window's residuals failed the χ² test for `loss_window_s` in a row.
    ResidualsFailed,
    /// The window's solve failed (not positive definite, or not finite).
    SolveFailed,
    /// A gap in the IMU stream while tracking.
    ImuGap,
    /// No keyframe for longer than `max_dead_reckoning_s` while tracking (a CSI outage).
    CsiOutage,
    /// A gap in the IMU stream during a start: the start begins again.
    ImuGapWhileStarting,
}

/// One change of phase.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PhaseChange {
    /// The phase entered.
    pub phase: PhaseKind,
    /// When, s on the IMU clock (`None`: before any input).
    pub t_s: Option<f64>,
    /// Why.
    pub reason: Reason,
}

impl Phase {
    /// Its kind.
    pub(super) fn kind(&self) -> PhaseKind {
        match self {
            Self::AtRest(_) => PhaseKind::AtRest,
            Self::Starting(_) => PhaseKind::Starting,
            Self::Tracking(_) => PhaseKind::Tracking,
            Self::Recovering(_) => PhaseKind::Recovering,
        }
    }

    /// The start, while starting or recovering.
    pub(super) fn start(&self) -> Option<&Start> {
        match self {
            Self::Starting(s) | Self::Recovering(s) => Some(s),
            _ => None,
        }
    }

    /// The start, while starting or recovering.
    pub(super) fn start_mut(&mut self) -> Option<&mut Start> {
        match self {
            Self::Starting(s) | Self::Recovering(s) => Some(s),
            _ => None,
        }
    }

    /// The tracking state, while tracking.
    pub(super) fn tracking(&self) -> Option<&Tracking> {
        match self {
            Self::Tracking(t) => Some(t),
            _ => None,
        }
    }

    /// The tracking state, while tracking.
    pub(super) fn tracking_mut(&mut self) -> Option<&mut Tracking> {
        match self {
            Self::Tracking(t) => Some(t),
            _ => None,
        }
    }

    /// The window, while tracking.
    pub(super) fn window(&self) -> Option<&NonlinearWindow> {
        self.tracking().map(|t| &t.window)
    }
}
