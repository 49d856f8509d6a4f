//! What one pass over a trajectory learns of it before it is evaluated ([`TrajectoryScan`]),
//! holding a few poses at most: the checks and the numbers of [`super::evaluate`] that need the
//! trajectory alone.

use std::collections::VecDeque;

use super::EvalError;
use super::drift::JUMP_THRESHOLD_M;
use super::metrics::SPEED_MIN_INTERVAL_S;
use crate::dataset::truth::Pose;
use crate::time::Timestamp;

/// What one pass over a trajectory learns of it before the evaluation: its length, its first
/// time, its first non-finite and first out-of-order pose, its jumps and its largest speed
/// ([`super::metrics`]'s definitions). Holds the poses of the last 20 ms at most.
#[derive(Clone, Debug, Default)]
pub(crate) struct TrajectoryScan {
    poses: usize,
    first_t: Option<Timestamp>,
    last: Option<Pose>,
    non_finite: Option<usize>,
    unsorted: Option<usize>,
    jumps: usize,
    max_speed_m_s: f64,
    /// Poses waiting for one at least `SPEED_MIN_INTERVAL_S` after them.
    waiting: VecDeque<Pose>,
    most_waiting: usize,
}

impl TrajectoryScan {
    /// The scan of `poses`.
    pub(crate) fn of(poses: &[Pose]) -> Self {
        let mut scan = Self::default();
        for p in poses {
            scan.push(p);
        }
        scan
    }

    /// The next pose of the trajectory.
    pub(crate) fn push(&mut self, p: &Pose) {
        let finite = p.p_b_in_w.iter().all(|x| x.is_finite())
            && p.world_from_body.coords.iter().all(|x| x.is_finite());
        if !finite && self.non_finite.is_none() {
            self.non_finite = Some(self.poses);
        }
        if let Some(last) = &self.last {
            if p.t < last.t && self.unsorted.is_none() {
                self.unsorted = Some(self.poses);
            }
            if (p.p_b_in_w - last.p_b_in_w).norm() > JUMP_THRESHOLD_M {
                self.jumps += 1;
            }
        }
        let min_ns = (SPEED_MIN_INTERVAL_S * 1e9).round() as i64;
        while let Some(a) = self.waiting.front()
            && p.t.0 - a.t.0 >= min_ns
        {
            let v = (p.p_b_in_w - a.p_b_in_w).norm() / p.t.secs_since(a.t);
            self.max_speed_m_s = self.max_speed_m_s.max(v);
            self.waiting.pop_front();
        }
        self.waiting.push_back(*p);
        self.most_waiting = self.most_waiting.max(self.waiting.len());
        self.first_t.get_or_insert(p.t);
        self.last = Some(*p);
        self.poses += 1;
    }

    /// Poses seen.
    pub(crate) fn poses(&self) -> usize {
        self.poses
    }

    /// The time of the first pose.
    pub(crate) fn first_t(&self) -> Option<Timestamp> {
        self.first_t
    }

    /// Poses more than [`JUMP_THRESHOLD_M`] from the one before.
    pub(crate) fn jumps(&self) -> usize {
        self.jumps
    }

    /// The largest speed between poses at least `SPEED_MIN_INTERVAL_S` apart, m/s
    /// ([`super::metrics`]'s `max_speed`).
    pub(crate) fn max_speed_m_s(&self) -> f64 {
        self.max_speed_m_s
    }

    /// The most poses held at once (those of the last `SPEED_MIN_INTERVAL_S`).
    pub(crate) fn most_poses_held(&self) -> usize {
        self.most_waiting
    }

    pub(crate) fn check_finite(&self, trajectory: &'static str) -> Result<(), EvalError> {
        match self.non_finite {
            Some(index) => Err(EvalError::NonFinite { trajectory, index }),
            None => Ok(()),
        }
    }

    pub(crate) fn check_sorted(&self, trajectory: &'static str) -> Result<(), EvalError> {
        if self.poses == 0 {
            return Err(EvalError::EmptyTrajectory { trajectory });
        }
        match self.unsorted {
            Some(index) => Err(EvalError::Unsorted { trajectory, index }),
            None => Ok(()),
        }
    }
}
