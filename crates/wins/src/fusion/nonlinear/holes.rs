//! Holes in the information: an IMU gap ([`crate::imu::ImuGap`]) or a CSI outage longer than
//! [`NonlinearConfig::max_dead_reckoning_s`](super::NonlinearConfig::max_dead_reckoning_s).
//!
//! Across a hole the window's state is a guess: the IMU's straight line over a gap, or the IMU
//! alone for seconds over an outage. A window kept across it would solve its next keyframes from
//! that guess with two iterations and a marginalization prior linearized at it; on the simulated
//! circle a 2 s gap then drifted to metres. So a hole while tracking ends the window: at the
//! first frame after it the estimator restarts from the newest keyframe carried across the hole
//! by the IMU ([`super::start`]; its linear window starts from zeros, the carried velocity and
//! attitude being guesses), no pose is given until the new window is accepted, and the APs the
//! lost window had placed are kept. When the new window is accepted, it is placed so
//! that its APs fall where the lost window had them ([`relocated`]): the APs do not move, so
//! they undo the drift of the guess. With one AP that fixes the position; with two or more, the
//! heading too (a rotation about the vertical through one AP leaves every bearing of it
//! unchanged, so one AP cannot).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::estimator::NonlinearEstimator;
use super::state::{NavState, pose_at};
use crate::fusion::estimator::Wins;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::time::Timestamp;

impl NonlinearEstimator {
    /// Whether a frame at `t` comes after a hole in the tracking window's information: an IMU
    /// gap since the last frame, or no keyframe for longer than the dead-reckoning limit.
    pub(super) fn after_hole(&self, t: Timestamp, imu_gap: bool) -> bool {
        let Some(newest) = self.window.as_ref().and_then(|w| w.newest()) else {
            return false;
        };
        imu_gap || t.secs_since(newest.t) > self.config.max_dead_reckoning_s
    }

    /// Ends the tracking window at the frame `t` after a hole, `interval` the IMU since the
    /// last frame: restarts from the newest keyframe carried to `t` by the IMU, keeping its
    /// placed APs for the new window ([`relocated`]).
    pub(super) fn restart_after_hole(&mut self, t: Timestamp, interval: &Preintegrated) {
        let Some(w) = self.window.as_ref() else {
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
        let aps_in_w = (0..w.aps().len())
            .filter_map(|l| Some((l, a.transform_point(&w.ap(l)?.into()).coords)))
            .collect();
        self.stats.restarts += 1;
        self.epoch += 1;
        self.begin_start(t, Some(from));
        // The carried velocity and attitude are guesses: the linear window starts from zeros.
        self.linear = Some(Wins::new(self.linear_config.clone()));
        self.ap_fix = Some(aps_in_w);
    }

    /// After a hole the start cannot leave from a known state: the dead reckoning is dropped
    /// and the linear window starts from zeros, as in a start in the air.
    pub(super) fn forget_reference(&mut self) {
        self.reference = None;
        self.reference_is_rest = false;
        self.dead_reckoned = None;
        self.linear = Some(Wins::new(self.linear_config.clone()));
    }

    /// At the acceptance of a window started after a hole: moves the output frame so that the
    /// window's APs fall where the lost window had them ([`relocated`]).
    pub(super) fn place_by_aps(&mut self) {
        let Some(fix) = self.ap_fix.take() else {
            return;
        };
        let Some(w) = self.window.as_ref() else {
            return;
        };
        let pairs: Vec<(Vector3<f64>, Vector3<f64>)> = fix
            .iter()
            .filter_map(|(l, old)| {
                let new = self.anchor.transform_point(&w.ap(*l)?.into()).coords;
                Some((new, *old))
            })
            .collect();
        if let Some(correction) = relocated(&pairs) {
            self.anchor = correction * self.anchor;
        }
    }
}

/// The rigid motion about the vertical that best moves each pair's first point onto its second
/// (least squares; heading only from two or more pairs set apart horizontally): `None` without
/// pairs.
pub(super) fn relocated(pairs: &[(Vector3<f64>, Vector3<f64>)]) -> Option<Isometry3<f64>> {
    if pairs.is_empty() {
        return None;
    }
    let n = pairs.len() as f64;
    let from_mean = pairs.iter().map(|(a, _)| a).sum::<Vector3<f64>>() / n;
    let to_mean = pairs.iter().map(|(_, b)| b).sum::<Vector3<f64>>() / n;
    // Heading: the angle that best turns the horizontal spreads (2-D Procrustes).
    let (mut s_cross, mut s_dot) = (0.0, 0.0);
    for (a, b) in pairs {
        let (da, db) = ((a - from_mean).xy(), (b - to_mean).xy());
        s_cross += da.x * db.y - da.y * db.x;
        s_dot += da.dot(&db);
    }
    let yaw = if s_cross.hypot(s_dot) > 1e-6 {
        s_cross.atan2(s_dot)
    } else {
        0.0
    };
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let translation = to_mean - rotation * from_mean;
    Some(Isometry3::from_parts(
        Translation3::from(translation),
        rotation,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_ap_moves_the_frame_and_two_turn_it() {
        let shift = Vector3::new(1.0, -2.0, 0.5);
        let one = relocated(&[(
            Vector3::new(3.0, 0.0, 2.0),
            Vector3::new(3.0, 0.0, 2.0) + shift,
        )])
        .expect("one pair");
        assert!((one.translation.vector - shift).norm() < 1e-12);
        assert!(one.rotation.angle() < 1e-12);

        let truth = Isometry3::from_parts(
            Translation3::new(0.4, 0.3, -0.2),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.35),
        );
        let aps = [Vector3::new(5.0, 0.0, 2.0), Vector3::new(0.0, 6.0, 1.0)];
        let pairs: Vec<_> = aps
            .iter()
            .map(|a| (*a, truth.transform_point(&(*a).into()).coords))
            .collect();
        let two = relocated(&pairs).expect("two pairs");
        assert!((two.rotation.angle() - 0.35).abs() < 1e-9);
        assert!((two.translation.vector - truth.translation.vector).norm() < 1e-9);
        assert!(relocated(&[]).is_none());
    }
}
