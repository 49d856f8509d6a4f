//! Tracking (module doc of [`crate::fusion::nonlinear::estimator`], step 3): a frame while the nonlinear window
//! runs, the solve of a keyframe after its pose has gone out, and the loss test.

use crate::fusion::nonlinear::estimator::NonlinearEstimator;
use crate::fusion::nonlinear::phase::Reason;
use crate::fusion::nonlinear::solve::SubFrame;
use crate::fusion::nonlinear::solve::fit::passes_chi2;
use crate::fusion::nonlinear::state::{NavState, pose_at};
use crate::fusion::pose::PoseEstimate;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::time::Timestamp;

impl NonlinearEstimator {
    /// A frame while tracking: a keyframe is solved and checked.
    pub(super) fn track(
        &mut self,
        t: Timestamp,
        is_keyframe: bool,
        from_prev: Option<Preintegrated>,
        sub: SubFrame,
    ) -> Option<PoseEstimate> {
        let window = &mut self.phase.tracking_mut()?.window;
        if !is_keyframe {
            window.push_frame(sub);
            return self.pose_now(t);
        }
        let newest = *window.newest()?;
        let g = STANDARD_GRAVITY_M_S2;
        let Some(from_prev) = from_prev else {
            return self.pose_now(t);
        };
        let p = pose_at(&newest, &from_prev, g);
        let x = NavState {
            t,
            world_from_body: p.world_from_body,
            p_b_in_w: p.p_b_in_w,
            v_b_in_w: p.v_b_in_w,
            ..newest
        };
        if window.push_keyframe(x, from_prev, vec![sub]).is_none() {
            self.record.stats.frames_refused += 1;
            return self.pose_now(t);
        }
        // On the ground: held at zero velocity ([`crate::fusion::nonlinear::factors::zero_velocity`]).
        let c = &self.config;
        if c.zero_velocity
            && self.still.still_for_s(t) >= c.zero_velocity_min_still_s
            && x.v_b_in_w.norm() <= c.zero_velocity_max_speed_m_s
        {
            window.hold_newest_still();
            self.record.stats.still_keyframes += 1;
        }
        // The pose goes out predicted by the IMU, as between keyframes; the solve follows
        // ([`Self::solve_pending`]).
        if let Some(tr) = self.phase.tracking_mut() {
            tr.solve_due = Some(t);
        }
        self.pose_now(t)
    }

    /// Solves the newest keyframe when its solve is due, then trims the window, places late
    /// APs and runs the loss test. A keyframe's pose is given before its solve (predicted by the
    /// IMU from the window's last solution, as every frame between keyframes is), so that a
    /// caller sending poses can send it first and solve after (`wins live`); otherwise the next
    /// input runs it, before anything else: the estimate is the same either way.
    pub fn solve_pending(&mut self) {
        let Some(tracking) = self.phase.tracking_mut() else {
            return;
        };
        let Some(t) = tracking.solve_due.take() else {
            return;
        };
        let solved = tracking.window.optimize(self.config.iterations);
        self.trim_window();
        self.place_late_aps();
        match solved {
            Ok(_) => self.check_health(t),
            Err(_) => {
                self.record.stats.solve_failures += 1;
                self.lose(t, Reason::SolveFailed);
            }
        }
    }

    /// The loss test after a keyframe's solve (module doc of [`crate::fusion::nonlinear::estimator`], step 3).
    pub(super) fn check_health(&mut self, t: Timestamp) {
        let alpha = self.config.chi2_significance;
        let Some(tr) = self.phase.tracking_mut() else {
            return;
        };
        let w = &tr.window;
        if passes_chi2(&w.fit(), w.border_dim(), alpha) {
            tr.failing_since = None;
            tr.last_good = w.newest().copied();
            return;
        }
        let since = *tr.failing_since.get_or_insert(t);
        if t.secs_since(since) >= self.config.loss_window_s {
            self.lose(t, Reason::ResidualsFailed);
        }
    }
}
