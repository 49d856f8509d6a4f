//! APs first seen (or first placeable) after the start: their bearings are kept against the
//! window's own estimate of each keyframe as it leaves the window, and the AP is triangulated
//! ([`crate::fusion::nonlinear::triangulate`]) from them every 25, and joins the window once its
//! horizontal σ passes the same bounds as a start's APs. That σ counts what the bearings hold,
//! not their number: the triangulation's covariance is widened by the long-run variance ratio of
//! its own residuals (`Triangulated::counting_persistence`), since a reflection repeats much
//! the same error for a second of packets, and an AP placed with the covariance of independent
//! bearings joined metres off while claiming centimetres (docs/ESTIMATOR.md).
//!
//! With `late_aps_from_window` (on by default), every fifth solve the AP is instead
//! triangulated from those and from the bearings of the keyframes still in the window, at the
//! window's current estimate of each. Its prior then holds only what the bearings that left say
//! (the window's own bearings of it are its factors from then on, and would otherwise count
//! twice). The bearings that left alone wait for the window to pass them on (2 s at first, then
//! 25 at a time): on the room family, a start that had placed one AP of three
//! then ran on that one alone while the others' bearings came at 30 per second, and was lost
//! when the one was gated (docs/ESTIMATOR.md, "APs placed from the window's own bearings").

use crate::fusion::nonlinear::solve::aps::within_bounds;
use nalgebra::{Isometry3, Matrix3};

use crate::fusion::nonlinear::estimator::NonlinearEstimator;
use crate::fusion::nonlinear::phase::Tracking;
use crate::fusion::nonlinear::solve::{Keyframe, NonlinearWindow};
use crate::fusion::nonlinear::state::pose_at;
use crate::fusion::nonlinear::triangulate::{LateSights, Sight, triangulate};
use crate::imu::STANDARD_GRAVITY_M_S2;

/// At most this many sights are kept per AP (the oldest leave first).
pub(super) const MAX_SIGHTS: usize = 3000;
/// A placement needs at least this many sights, kept and in the window (from the kept ones
/// alone: tried at every multiple of it).
const MIN_SIGHTS: usize = 25;
/// A placement is tried every this many solves (0.5 s at the default keyframe period).
const TRY_EVERY_SOLVES: usize = 5;
/// The information on an AP placed from the window's bearings alone, 1/m² (σ 10 m): a prior
/// that only keeps the solve from wandering.
const WINDOW_ONLY_INFORMATION: f64 = 1e-2;

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

    /// Places every AP the window lacks whose sights allow it (module doc).
    pub(super) fn place_late_aps(&mut self) {
        let body_from_array = self.sensors.body_from_array;
        let config = &self.config;
        let Some(tracking) = self.phase.tracking_mut() else {
            return;
        };
        let from_window = config.late_aps_from_window;
        let in_window = if from_window {
            tracking.window_sights(&body_from_array)
        } else {
            Vec::new()
        };
        if tracking.late_sights.len() < in_window.len() {
            tracking
                .late_sights
                .resize_with(in_window.len(), LateSights::default);
        }
        let w = &mut tracking.window;
        for (l, late) in tracking.late_sights.iter_mut().enumerate() {
            late.solves += 1;
            let here = in_window.get(l).map_or(&[][..], Vec::as_slice);
            let due = if from_window {
                here.len() + late.sights.len() >= MIN_SIGHTS && late.solves % TRY_EVERY_SOLVES == 0
            } else {
                late.seen > 0 && late.seen % MIN_SIGHTS == 0
            };
            if w.is_placed(l) || !due {
                continue;
            }
            let left = late.sights.make_contiguous();
            let sights: Vec<Sight> = left.iter().chain(here).copied().collect();
            let Some(t) = triangulate(&sights, config.cauchy_scale) else {
                continue;
            };
            let (t, _) = t.counting_persistence(&sights);
            if !within_bounds(&t, &sights, config) {
                continue;
            }
            let info = if from_window {
                triangulate(left, config.cauchy_scale)
                    .and_then(|o| o.counting_persistence(left).0.covariance.try_inverse())
                    .unwrap_or_else(|| Matrix3::identity() * WINDOW_ONLY_INFORMATION)
            } else {
                match t.covariance.try_inverse() {
                    Some(info) => info,
                    None => continue,
                }
            };
            w.place_ap(l, t.c_in_w, &((info + info.transpose()) * 0.5));
            late.sights.clear();
        }
    }
}

impl Tracking {
    /// The bearings of APs the window does not hold yet, from every keyframe in it, at the
    /// window's current estimate, by AP.
    fn window_sights(&self, body_from_array: &Isometry3<f64>) -> Vec<Vec<Sight>> {
        let mut by_ap: Vec<Vec<Sight>> = Vec::new();
        for kf in &self.window.keyframes {
            for (ap, sight) in unplaced_sights(&self.window, kf, body_from_array) {
                if by_ap.len() <= ap {
                    by_ap.resize_with(ap + 1, Vec::new);
                }
                if let Some(v) = by_ap.get_mut(ap) {
                    v.push(sight);
                }
            }
        }
        by_ap
    }

    /// Keeps the bearings of APs the window does not hold yet from its oldest keyframe (about to
    /// leave it), at that keyframe's estimate.
    fn keep_late_sights(&mut self, body_from_array: &Isometry3<f64>) {
        let Some(kf) = self.window.keyframes.front() else {
            return;
        };
        for (ap, sight) in unplaced_sights(&self.window, kf, body_from_array) {
            if self.late_sights.len() <= ap {
                self.late_sights.resize_with(ap + 1, LateSights::default);
            }
            let Some(late) = self.late_sights.get_mut(ap) else {
                continue;
            };
            if late.sights.len() >= MAX_SIGHTS {
                late.sights.pop_front();
            }
            late.sights.push_back(sight);
            late.seen += 1;
        }
    }
}

/// The bearings of keyframe `kf` of APs `w` does not hold yet, each as a sight from the frame's
/// pose at the window's estimate: (AP, sight).
fn unplaced_sights(
    w: &NonlinearWindow,
    kf: &Keyframe,
    body_from_array: &Isometry3<f64>,
) -> Vec<(usize, Sight)> {
    let mut out = Vec::new();
    for f in &kf.frames {
        let mut unplaced = f.bearings.iter().filter(|b| !w.is_placed(b.ap)).peekable();
        if unplaced.peek().is_none() {
            continue;
        }
        let pose = pose_at(&kf.x, &f.partial, STANDARD_GRAVITY_M_S2);
        out.extend(unplaced.map(|b| (b.ap, Sight::of(&pose, body_from_array, b))));
    }
    out
}
