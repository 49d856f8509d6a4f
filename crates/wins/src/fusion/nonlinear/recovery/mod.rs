//! Holes in the information: an IMU gap ([`crate::imu::ImuGap`]) or a CSI outage longer than
//! [`NonlinearConfig::max_dead_reckoning_s`](super::NonlinearConfig::max_dead_reckoning_s).
//!
//! Across a hole the window's state is a guess: the IMU's straight line over a gap, or the IMU
//! alone for seconds over an outage. A window kept across it would solve its next keyframes from
//! that guess with two iterations and a marginalization prior linearized at it; on the simulated
//! circle a 2 s gap then drifted to metres. So a hole while tracking ends the window: at the
//! first frame after it the estimator restarts from the newest keyframe carried across the hole
//! by the IMU ([`crate::fusion::nonlinear::start`]; its linear window starts from zeros, the carried velocity and
//! attitude being guesses), no pose is given until the new window is accepted, and the APs the
//! lost window had placed are kept. When the new window is accepted, it is placed so
//! that its APs fall where the lost window had them (`relocated`): the APs do not move, so
//! they undo the drift of the guess. With one AP that fixes the position; with two or more, the
//! heading too (a rotation about the vertical through one AP leaves every bearing of it
//! unchanged, so one AP cannot). With one AP the heading comes from the path's continuity
//! across the hole (`recovery::bridge`). A new window whose APs' ranges from the bridge's end
//! disagree with the lost window's is refused (`Placement::agrees`), and an accepted one keeps
//! its APs where the lost window had them (in its prior). The height comes mostly from the
//! barometer, which runs on through an IMU gap: the new window's barometer offset, as placed, is
//! the lost window's give or take the offset's walk since, and is held there; an AP's own
//! height, weakly seen, weighs by its vertical σ.

pub(in crate::fusion::nonlinear) mod anchor;
pub(in crate::fusion::nonlinear) mod bridge;
pub(in crate::fusion::nonlinear) mod relocate;

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use crate::fusion::nonlinear::recovery::bridge::{Before, bridge_sigma_m, end_motion};

use crate::fusion::nonlinear::config::NonlinearConfig;

use crate::fusion::nonlinear::solve::NonlinearWindow;
use crate::time::Timestamp;

/// What a window lost to a hole (an IMU gap, a CSI outage) leaves for the next one.
#[derive(Clone, Debug)]
pub(super) struct HoleFix {
    /// Every AP the lost window had placed, in the output frame.
    pub(super) aps_in_w: Vec<LostAp>,
    /// The lost window's barometer offset in the output frame (`h = z + o`), m, when it had a
    /// barometer: the barometer runs on through an IMU gap, so the next window's height is
    /// placed by it.
    pub(super) baro_offset_m: Option<f64>,
    /// The first frame after the hole (where the new start leaves from).
    pub(super) t: Timestamp,
    /// 1σ of the carried position there, horizontal, m.
    pub(super) carried_sigma_m: f64,
    /// The lost window's newest keyframe, before the hole.
    pub(super) before: Before,
}

/// An AP a window lost to a hole had placed, in the output frame.
#[derive(Clone, Copy, Debug)]
pub(super) struct LostAp {
    /// Its index.
    pub(super) l: usize,
    /// Its position, m.
    pub(super) c_in_w: Vector3<f64>,
    /// Its horizontal σ, m.
    pub(super) sigma_m: f64,
    /// The variance of its height, m² (weakly seen: an AP near the drone's height is seen at
    /// an elevation near zero).
    pub(super) var_z_m2: f64,
}

/// What recovery reads of the estimator: its settings, and the output frame it moves.
#[derive(Clone, Copy, Debug)]
pub(in crate::fusion::nonlinear) struct Recovery<'a> {
    pub(in crate::fusion::nonlinear) config: &'a NonlinearConfig,
    /// Output `w` from the window's `w`.
    pub(in crate::fusion::nonlinear) anchor: Isometry3<f64>,
}

impl Recovery<'_> {
    /// What the tracking window leaves for the next one when it ends at `t`, its newest state
    /// carried `carried_s` by the IMU alone, across gaps of `imu_gap_s` s: its placed APs and
    /// that newest state in the output frame, and how far the carried position may be off.
    /// `None` without a window, a keyframe or a placed AP.
    pub(in crate::fusion::nonlinear) fn hole_fix(
        &self,
        w: &NonlinearWindow,
        t: Timestamp,
        carried_s: f64,
        imu_gap_s: f64,
    ) -> Option<HoleFix> {
        let newest = w.newest()?;
        let a = self.anchor;
        let aps_in_w: Vec<_> = (0..w.aps().len())
            .filter_map(|l| {
                Some(LostAp {
                    l,
                    c_in_w: a.transform_point(&w.ap(l)?.into()).coords,
                    sigma_m: w.ap_horizontal_sigma_m(l)?,
                    // The anchor turns about the vertical only: heights' variances stay.
                    var_z_m2: w.ap_covariance(l)?[(2, 2)],
                })
            })
            .collect();
        // How far the carried position may be off horizontally: the dead reckoning errs by
        // about 0.3 m per second it spans, and the straight line across an IMU gap of `h` s by
        // `j h³/6` under a jerk `j` (0.7 m after 2.3 s of a circle flown at 1.3 m/s, 6 m
        // after 5.3 s).
        let dead_reckoning_m = MIN_CARRIED_SIGMA_M + CARRIED_SIGMA_M_PER_S * carried_s.max(0.0);
        let straight_line_m = STRAIGHT_LINE_JERK_M_S3 * imu_gap_s.max(0.0).powi(3) / 6.0;
        let carried_sigma_m = dead_reckoning_m.hypot(straight_line_m);
        (!aps_in_w.is_empty()).then_some(HoleFix {
            aps_in_w,
            // The anchor turns about the vertical only: `z_out = z_w + t_z`.
            baro_offset_m: w.baro_offset_m().map(|o| o - a.translation.vector.z),
            t,
            carried_sigma_m,
            before: Before {
                t: newest.t,
                p: a.transform_point(&newest.p_b_in_w.into()).coords,
                motion: end_motion(w.keyframes().rev()).turned(&a.rotation),
            },
        })
    }

    /// Where a window `w` started after a hole goes, at its acceptance: the move of the output
    /// frame that puts the window's APs where the lost window had them and its first keyframe,
    /// when it is the first frame after the hole, where the IMU carried it and where the bridge
    /// from the lost window's last state with the new window's first motion puts it
    /// ([`Before::bridged`]; [`relocated`], each pair weighted by its inverse variance). With
    /// one AP the first keyframe's pairs fix the heading: the new window's own heading is the
    /// carried one, which the hole may have turned by tens of degrees, and a turn about the AP
    /// moves the whole trajectory by range × angle. The height goes mostly by the barometer
    /// (a pair on the height alone: the two windows' offsets). `w` is untrimmed (its first
    /// keyframe is the start's). `None` without a lost window's AP in `w`.
    pub(in crate::fusion::nonlinear) fn placement(
        &self,
        fix: &HoleFix,
        w: &NonlinearWindow,
    ) -> Option<Placement> {
        let mut pairs: Vec<Weighted> = fix
            .aps_in_w
            .iter()
            .filter_map(|old| {
                let new = self.anchor.transform_point(&w.ap(old.l)?.into()).coords;
                let sigma_new = w.ap_horizontal_sigma_m(old.l)?;
                let var = (old.sigma_m.powi(2) + sigma_new.powi(2)).max(MIN_PAIR_VAR_M2);
                // An AP's height is weakly determined ([`NonlinearWindow::ap_horizontal_sigma_m`]):
                // its pair weighs on the vertical by its own σ there.
                let var_z = old.var_z_m2 + w.ap_covariance(old.l)?[(2, 2)];
                Some(Weighted {
                    from: new,
                    to: old.c_in_w,
                    weight: var.recip(),
                    weight_z: var_z.max(MIN_PAIR_VAR_M2).recip(),
                })
            })
            .collect();
        let aps = pairs.clone();
        let mut agrees = true;
        if let Some(first) = w.keyframes().next()
            && first.t.secs_since(fix.t).abs() <= FIRST_KEYFRAME_WITHIN_S
            && !aps.is_empty()
        {
            let here = self.anchor.transform_point(&first.p_b_in_w.into()).coords;
            pairs.push(Weighted::even(here, here, fix.carried_sigma_m.powi(-2)));
            // The bridge: where the lost window's last state and the new window's first
            // motion, turned as the placement turns it, put the drone (found with the
            // placement, a few rounds; `recovery::bridge`).
            let before = fix.before;
            let here_motion = end_motion(w.keyframes()).turned(&self.anchor.rotation);
            let span_s = first.t.secs_since(before.t).max(0.0);
            let mut bridge = Weighted::even(here, here, bridge_sigma_m(span_s).powi(-2));
            for _ in 0..BRIDGE_ROUNDS {
                let mut all = pairs.clone();
                all.push(bridge);
                let Some(correction) = relocated(&all) else {
                    break;
                };
                bridge.to = before.bridged(first.t, &here_motion.turned(&correction.rotation));
            }
            pairs.push(bridge);
            // Each AP's horizontal range from the first keyframe, in the new window and from
            // the bridge's end in the lost one (no turn or shift changes either), agrees for
            // at least half of the APs: the lost window may have had one of several wrong.
            agrees = ranges_agree(&aps, &bridge);
        }
        // The barometer ran on through the hole: the new window's offset, in the output frame
        // as placed, is the lost window's (`o_new − (t_z + δz) = o_old`), give or take its walk
        // since; a pair on the height alone.
        if let (Some(o_old), Some(o_new)) = (fix.baro_offset_m, w.baro_offset_m()) {
            let dz = o_new - self.anchor.translation.vector.z - o_old;
            pairs.push(Weighted {
                from: Vector3::zeros(),
                to: Vector3::z() * dz,
                weight: 0.0,
                weight_z: self.baro_offset_variance_m2(fix, w).recip(),
            });
        }
        let correction = relocated(&pairs)?;
        Some(Placement { correction, agrees })
    }

    /// How far the barometer's offset may have walked between the lost window's last state and
    /// the newest keyframe of `w`, m² (at least [`MIN_BARO_VAR_M2`]).
    fn baro_offset_variance_m2(&self, fix: &HoleFix, w: &NonlinearWindow) -> f64 {
        let since_s = w
            .newest()
            .map_or(0.0, |x| x.t.secs_since(fix.before.t).max(0.0));
        (self.config.baro_offset_walk_m_sqrt_s.powi(2) * since_s).max(MIN_BARO_VAR_M2)
    }

    /// At the acceptance of a window started after a hole, its [`placement`](Self::placement):
    /// moves the output frame by it and holds the window's APs where the lost window had them.
    /// Called before the window is trimmed.
    pub(in crate::fusion::nonlinear) fn place_by_aps(
        &mut self,
        w: &mut NonlinearWindow,
        fix: HoleFix,
        placement: Option<Placement>,
    ) {
        if let Some(p) = placement {
            self.anchor = p.correction * self.anchor;
        }
        // The APs do not move: the new window keeps them where the lost window had them (in its
        // own frame, as now placed), or its drift after the placement moves the trajectory
        // against the one before the hole.
        let anchor = self.anchor;
        let baro_var = self.baro_offset_variance_m2(&fix, w);
        // The barometer ran on through the hole: its offset is the lost window's, give or
        // take its walk since.
        if let Some(o_old) = fix.baro_offset_m {
            w.hold_baro_offset(o_old + anchor.translation.vector.z, baro_var.recip());
        }
        for old in &fix.aps_in_w {
            let target = anchor.inverse_transform_point(&old.c_in_w.into()).coords;
            // Its height too is held by the horizontal σ: held by its own (larger) σ, the
            // AP's height and the window's drift together after the placement.
            let info = Matrix3::identity() * old.sigma_m.max(MIN_HELD_SIGMA_M).powi(-2);
            w.hold_ap(old.l, target, &info);
        }
    }
}

/// Where a window started after a hole is placed (`Recovery::placement`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Placement {
    /// The move of the output frame.
    pub(super) correction: Isometry3<f64>,
    /// Whether the window's APs agree with the lost window's: at least half of them have their
    /// horizontal range from the first keyframe within [`AGREEING_SIGMAS`] of the lost
    /// window's range from the bridge's end.
    pub(super) agrees: bool,
}

/// Whether at least half of the AP pairs `aps` (`from`: in the new window, `to`: in the lost
/// one) have their horizontal range from the `bridge` pair's ends within [`AGREEING_SIGMAS`]
/// of each other, σ from the pairs' weights. Neither range changes with a turn or a shift.
fn ranges_agree(aps: &[Weighted], bridge: &Weighted) -> bool {
    let agreeing = aps
        .iter()
        .filter(|ap| {
            let range_new = (ap.from - bridge.from).xy().norm();
            let range_old = (ap.to - bridge.to).xy().norm();
            let sigma = (ap.weight.recip() + bridge.weight.recip()).sqrt();
            (range_new - range_old).abs() <= AGREEING_SIGMAS * sigma
        })
        .count();
    2 * agreeing >= aps.len()
}

/// How many σ an AP's range from the bridge's end may differ between the two windows.
const AGREEING_SIGMAS: f64 = 3.0;
/// Rounds of the placement and the bridge it turns.
const BRIDGE_ROUNDS: usize = 3;
/// Floor of the carried position's σ, m …
const MIN_CARRIED_SIGMA_M: f64 = 0.1;
/// … its growth per second carried, m/s …
const CARRIED_SIGMA_M_PER_S: f64 = 0.3;
/// … and the jerk the straight line across an IMU gap misses, m/s³ (a circle of 2.5 m flown
/// at 1.3 m/s has 0.35).
const STRAIGHT_LINE_JERK_M_S3: f64 = 0.5;
/// Floor of the σ an AP is held to where the lost window had it, m.
const MIN_HELD_SIGMA_M: f64 = 0.05;
/// Floor of the variance a barometer offset is held to, m².
const MIN_BARO_VAR_M2: f64 = 1e-4;
/// Floor of an AP pair's variance, m².
const MIN_PAIR_VAR_M2: f64 = 1e-4;
/// The new window's first keyframe is taken as the carried state's when it is this close to
/// the first frame after the hole, s.
pub(super) const FIRST_KEYFRAME_WITHIN_S: f64 = 0.5;

/// A point in the new window's placement (`from`) and where it belongs (`to`), with the
/// pair's weights (1/m²) across and along the vertical.
#[derive(Clone, Copy, Debug)]
pub(super) struct Weighted {
    pub(super) from: Vector3<f64>,
    pub(super) to: Vector3<f64>,
    pub(super) weight: f64,
    pub(super) weight_z: f64,
}

impl Weighted {
    /// A pair weighing `weight` on every axis.
    pub(super) fn even(from: Vector3<f64>, to: Vector3<f64>, weight: f64) -> Self {
        Self {
            from,
            to,
            weight,
            weight_z: weight,
        }
    }
}

/// The rigid motion about the vertical that best moves each pair's `from` onto its `to`
/// (weighted least squares; the heading only from two or more pairs set apart horizontally, the
/// height by the vertical weights): `None` without pairs or weight.
pub(super) fn relocated(pairs: &[Weighted]) -> Option<Isometry3<f64>> {
    let total: f64 = pairs.iter().map(|p| p.weight).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let from_mean = pairs
        .iter()
        .map(|p| p.from * p.weight)
        .sum::<Vector3<f64>>()
        / total;
    let to_mean = pairs.iter().map(|p| p.to * p.weight).sum::<Vector3<f64>>() / total;
    // Heading: the angle that best turns the horizontal spreads (weighted 2-D Procrustes).
    let (mut s_cross, mut s_dot) = (0.0, 0.0);
    for p in pairs {
        let (da, db) = ((p.from - from_mean).xy(), (p.to - to_mean).xy());
        s_cross += p.weight * (da.x * db.y - da.y * db.x);
        s_dot += p.weight * da.dot(&db);
    }
    let yaw = if s_cross.hypot(s_dot) > 1e-9 * total {
        s_cross.atan2(s_dot)
    } else {
        0.0
    };
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let mut translation = to_mean - rotation * from_mean;
    // The vertical: a turn about it leaves heights alone, so the shift is the mean of the
    // pairs' height differences by their vertical weights (the horizontal one's without).
    let total_z: f64 = pairs.iter().map(|p| p.weight_z).sum();
    if total_z > 0.0 && total_z.is_finite() {
        translation.z = pairs
            .iter()
            .map(|p| (p.to.z - p.from.z) * p.weight_z)
            .sum::<f64>()
            / total_z;
    }
    Some(Isometry3::from_parts(
        Translation3::from(translation),
        rotation,
    ))
}

#[cfg(test)]
mod tests;
