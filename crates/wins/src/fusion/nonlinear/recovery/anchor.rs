//! The lost window's ranges in a window started after a hole ([`crate::fusion::nonlinear::recovery`]).
//!
//! A window started after a hole sees its AP's direction within seconds, but its range only from
//! the parallax of its own path, and the range sets the scale of everything it estimates: the
//! speed, and so where the drone drifts once it stops moving across the line of sight (a hover,
//! a landing). The lost window knew that range: the bridge ([`crate::fusion::nonlinear::recovery::bridge`]) ties the new
//! window's first keyframe to the lost window's last state, and the horizontal distance from the
//! bridge's lever to the AP is the same in both frames, whatever turn and shift lie between them
//! ([`crate::fusion::nonlinear::factors::range_anchor`]). So a new window that would be accepted (its own APs placed within
//! the σ bounds, its ranges agreeing with the lost window's) gets one range anchor per lost AP
//! (σ: the lost AP's and the bridge's) and is solved again; when each anchor is met within
//! [`MAX_ANCHOR_RESIDUAL`] σ and the residuals still pass the χ² test, that window is accepted
//! and placed (`Recovery::placement`); otherwise the window as it was.
//!
//! Accepting on the anchor alone, before the window's own APs pass the σ bounds, was tried: on
//! 32 flights it brought the poses back 2–8 s sooner and more flights within twice the undamaged
//! error after a 5 s IMU gap (29 instead of 26), fewer after a 2 s gap (28 instead of 32): a
//! young window's shape is off by more than its covariance says (docs/VALIDATION.md).

use crate::fusion::nonlinear::factors::range_anchor::RangeAnchor;
use crate::fusion::nonlinear::recovery::bridge::{bridge_sigma_m, end_motion};
use crate::fusion::nonlinear::recovery::{FIRST_KEYFRAME_WITHIN_S, HoleFix, Placement};
use crate::fusion::nonlinear::solve::NonlinearWindow;
use crate::fusion::nonlinear::solve::fit::passes_chi2;

/// The largest whitened residual of an anchor in an accepted window.
const MAX_ANCHOR_RESIDUAL: f64 = 3.0;
/// Floor of an anchor's σ, m.
const MIN_ANCHOR_SIGMA_M: f64 = 0.05;

/// A window started after a hole, anchored to the lost window's ranges.
pub(in crate::fusion::nonlinear) struct Anchored {
    /// The window, anchored and solved again.
    pub(in crate::fusion::nonlinear) window: NonlinearWindow,
    /// Where it goes.
    pub(in crate::fusion::nonlinear) placement: Placement,
}

impl super::Recovery<'_> {
    /// The accepted window `w` started after a hole, anchored to the lost window's APs' ranges
    /// (module doc), solved again and placed: `None` when there was no hole, `w`'s first
    /// keyframe is not the first frame after it (no bridge leaves from it), an AP of `w` is not
    /// placed within the σ bounds by `w` itself (the relocation's σ may have accepted it), no
    /// lost AP is in `w`, or the anchored window misses an anchor, fails the χ² test or
    /// disagrees with the lost window's ranges.
    pub(in crate::fusion::nonlinear) fn anchored(
        &self,
        fix: &HoleFix,
        w: &NonlinearWindow,
    ) -> Option<Anchored> {
        let first = *w.keyframes().next()?;
        if first.t.secs_since(fix.t).abs() > FIRST_KEYFRAME_WITHIN_S {
            return None;
        }
        let placed_by_itself = (0..w.aps().len()).filter(|&l| w.is_placed(l)).all(|l| {
            let range = w.ap_nearest_range_m(l).unwrap_or(f64::INFINITY);
            w.ap_horizontal_sigma_m(l)
                .is_some_and(|s| self.config.ap_sigma_ok(s, range))
        });
        if !placed_by_itself {
            return None;
        }
        let span_s = first.t.secs_since(fix.before.t).max(0.0);
        let sigma_bridge = bridge_sigma_m(span_s);
        let here = end_motion(w.keyframes());
        let mut anchored = w.clone();
        let mut any = false;
        let before = &fix.before.motion;
        for old in &fix.aps_in_w {
            // `D` of [`crate::fusion::nonlinear::factors::range_anchor`], in the output frame: the AP from the lost window's
            // half of the bridge ([`Before::bridged`](crate::fusion::nonlinear::recovery::bridge::Before::bridged)).
            let d = old.c_in_w
                - fix.before.p
                - before.v * (span_s / 2.0)
                - before.a * (span_s.powi(2) / 10.0)
                - before.j * (span_s.powi(3) / 120.0);
            any |= anchored.add_range_anchor(RangeAnchor {
                t: first.t,
                l: old.l,
                half_span_s: span_s / 2.0,
                offset_m: -here.a * (span_s.powi(2) / 10.0) + here.j * (span_s.powi(3) / 120.0),
                range_m: d.xy().norm(),
                sigma_m: old.sigma_m.hypot(sigma_bridge).max(MIN_ANCHOR_SIGMA_M),
            });
        }
        if !any {
            return None;
        }
        anchored.optimize(self.config.iterations_at_start).ok()?;
        // A window that has to be bent to meet an anchor is a wrong one, or the anchor is.
        let first = *anchored.keyframes().next()?;
        let met = anchored.anchors.iter().all(|a| {
            anchored
                .ap(a.l)
                .is_some_and(|c| a.residual(&first, &c).abs() <= MAX_ANCHOR_RESIDUAL)
        });
        if !(met
            && passes_chi2(
                &anchored.fit(),
                anchored.border_dim(),
                self.config.chi2_significance,
            ))
        {
            return None;
        }
        let placement = self.placement(fix, &anchored).filter(|p| p.agrees)?;
        Some(Anchored {
            window: anchored,
            placement,
        })
    }
}
