//! APs first seen (or first placeable) after the start: their bearings are kept against the
//! window's own estimate of each keyframe as it leaves the window, and the AP is triangulated
//! from them ([`crate::fusion::nonlinear::triangulate`]) and joins the window once its horizontal σ passes the same
//! bounds as a start's APs.

use crate::fusion::nonlinear::solve::aps::triangulate_within_bounds;
use nalgebra::Isometry3;

use crate::fusion::nonlinear::estimator::NonlinearEstimator;
use crate::fusion::nonlinear::phase::Tracking;
use crate::fusion::nonlinear::state::pose_at;
use crate::fusion::nonlinear::triangulate::{LateSights, Sight};
use crate::imu::STANDARD_GRAVITY_M_S2;

/// At most this many sights are kept per AP (the oldest leave first).
pub(super) const MAX_SIGHTS: usize = 3000;
/// A placement is tried when the sights kept so far are a multiple of this.
const TRY_EVERY: usize = 25;

impl NonlinearEstimator {
    /// Marginalizes the window down to [`super::NonlinearConfig::max_keyframes`], keeping the
    /// bearings of APs it does not hold from each keyframe that leaves.
    pub(super) fn trim_window(&mut self) {
        let body_from_array = self.sensors.body_from_array;
        let Some(tracking) = self.phase.tracking_mut() else {
            return;
        };
        while tracking.window.len() > self.config.max_keyframes {
            tracking.keep_late_sights(&body_from_array);
            tracking.window.marginalize_oldest();
        }
    }

    /// Places every AP the window lacks whose sights allow it.
    pub(super) fn place_late_aps(&mut self) {
        let config = &self.config;
        let Some(tracking) = self.phase.tracking_mut() else {
            return;
        };
        let w = &mut tracking.window;
        for (l, late) in tracking.late_sights.iter_mut().enumerate() {
            if w.is_placed(l) || late.seen == 0 || late.seen % TRY_EVERY != 0 {
                continue;
            }
            let sights = late.sights.make_contiguous();
            let Some(t) = triangulate_within_bounds(sights, config) else {
                continue;
            };
            if let Some(info) = t.covariance.try_inverse() {
                w.place_ap(l, t.c_in_w, &((info + info.transpose()) * 0.5));
                late.sights.clear();
            }
        }
    }
}

impl Tracking {
    /// Keeps the bearings of APs the window does not hold yet from its oldest keyframe (about to
    /// leave it), at that keyframe's estimate.
    fn keep_late_sights(&mut self, body_from_array: &Isometry3<f64>) {
        let w = &self.window;
        let Some(kf) = w.keyframes.front() else {
            return;
        };
        for f in &kf.frames {
            let mut unplaced = f.bearings.iter().filter(|b| !w.is_placed(b.ap)).peekable();
            if unplaced.peek().is_none() {
                continue;
            }
            let pose = pose_at(&kf.x, &f.partial, STANDARD_GRAVITY_M_S2);
            for b in unplaced {
                if self.late_sights.len() <= b.ap {
                    self.late_sights.resize_with(b.ap + 1, LateSights::default);
                }
                let late = &mut self.late_sights[b.ap];
                if late.sights.len() >= MAX_SIGHTS {
                    late.sights.pop_front();
                }
                late.sights.push_back(Sight::of(&pose, body_from_array, b));
                late.seen += 1;
            }
        }
    }
}
