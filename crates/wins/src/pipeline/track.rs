//! One AP's AoA track (paper Algorithm 1): the first angle from SpotFi over the AP's first
//! packets, then PAoA per packet around a prediction: the previous angle turned by the gyro's
//! rotation since (the translation part, ~0.6° per packet at 50 Hz, is left to the ±20° window).
//! The estimated pose and AP give the side (front/back) and a gate once converged. A track that
//! finds no credible peak for too long starts over from SpotFi.
//!
//! A turn moves the cone angle of an AP in front one way and of an AP behind the other way, so the
//! prediction uses the track's side, and a turn through the array's axis carries the track to the
//! other side. SpotFi's first angle cannot tell the side: a track starts in front (the paper's
//! set-up) until the state says otherwise.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::aoa::AoaPrediction;
use crate::aoa::steering::aoa_rad;
use crate::csi::intel5300::CsiRecord;
use crate::fusion::bearing::{Side, side_of};

/// The array's pose in `b0` at one instant (from the estimator's propagated pose).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayPose {
    /// `R_{a}^{b_0}`.
    pub b0_from_array: UnitQuaternion<f64>,
    /// Array centre in `b0`, m.
    pub p_a_in_b0: Vector3<f64>,
}

impl ArrayPose {
    /// The array pose of a body pose in `b0`.
    pub fn of_body(
        b0_from_body: &UnitQuaternion<f64>,
        p_b_in_b0: &Vector3<f64>,
        body_from_array: &Isometry3<f64>,
    ) -> Self {
        Self {
            b0_from_array: b0_from_body * body_from_array.rotation,
            p_a_in_b0: p_b_in_b0 + b0_from_body * body_from_array.translation.vector,
        }
    }

    /// The cone angle and side of a point (in `b0`) seen from this pose, or `None` when the point
    /// is at the array centre.
    pub fn bearing_to(&self, point_in_b0: &Vector3<f64>) -> Option<(f64, Side)> {
        let d = self.b0_from_array.inverse() * (point_in_b0 - self.p_a_in_b0);
        (d.norm() > 1e-9).then(|| (aoa_rad(&d), side_of(&d)))
    }
}

/// Where a track is.
#[derive(Clone, Debug)]
pub enum TrackState {
    /// Collecting the first packets for SpotFi.
    Acquiring {
        /// Records collected so far.
        records: Vec<CsiRecord>,
    },
    /// Following the AP packet by packet.
    Tracking {
        /// The last angle (measured or SpotFi's), rad.
        aoa_rad: f64,
        /// The array's pose then (`None` before the estimator had a pose).
        pose: Option<ArrayPose>,
        /// Consecutive packets without a credible peak.
        misses: usize,
    },
}

/// One AP's track.
#[derive(Clone, Debug)]
pub struct Track {
    /// The current state.
    pub state: TrackState,
    /// Packets gated in a row after convergence (see `PipelineConfig::max_gated_in_row`).
    pub gated_in_row: usize,
    /// Packets off the track in a row (see `PipelineConfig::track_gate_deg`).
    pub off_track_in_row: usize,
    /// The side of the array the AP is on (front until a turn or the state says otherwise).
    pub side: Side,
}

impl Default for Track {
    fn default() -> Self {
        Self {
            state: TrackState::Acquiring {
                records: Vec::new(),
            },
            gated_in_row: 0,
            off_track_in_row: 0,
            side: Side::Front,
        }
    }
}

impl Track {
    /// The Algorithm-1 prediction before convergence: the previous angle turned by the array's
    /// rotation since (no translation part: the range is not known yet). `None` while acquiring.
    pub fn predict_by_rotation(&self, now: Option<&ArrayPose>) -> Option<AoaPrediction> {
        let TrackState::Tracking { aoa_rad, pose, .. } = &self.state else {
            return None;
        };
        let aj_from_ai = match (pose, now) {
            (Some(then), Some(now)) => now.b0_from_array.inverse() * then.b0_from_array,
            _ => UnitQuaternion::identity(),
        };
        Some(AoaPrediction::from_motion(
            *aoa_rad,
            self.side == Side::Front,
            &aj_from_ai,
            &Vector3::zeros(),
            f64::INFINITY,
        ))
    }

    /// Drops the array pose of the last angle (its frame is gone: the estimator restarted).
    pub fn forget_pose(&mut self) {
        if let TrackState::Tracking { pose, .. } = &mut self.state {
            *pose = None;
        }
    }

    /// Records an accepted angle.
    pub fn accept(&mut self, aoa_rad: f64, pose: Option<ArrayPose>) {
        self.state = TrackState::Tracking {
            aoa_rad,
            pose,
            misses: 0,
        };
    }

    /// Records a measured angle `aoa_rad` against the track's `prediction`: the track moves by
    /// `gain` of the difference (a first-order filter: one packet's multipath error does not
    /// become the next packet's window centre, which let tracks random-walk onto reflections;
    /// `gain = 1` keeps the raw angle, the paper's Algorithm 1), and takes the predicted side (a
    /// turn through the array's axis carries the AP to the other side).
    pub fn update(
        &mut self,
        aoa_rad: f64,
        prediction: &AoaPrediction,
        gain: f64,
        pose: Option<ArrayPose>,
    ) {
        self.off_track_in_row = 0;
        self.side = if prediction.in_front_after {
            Side::Front
        } else {
            Side::Back
        };
        let predicted_rad = prediction.predicted_aoa_rad();
        self.accept(predicted_rad + gain * (aoa_rad - predicted_rad), pose);
    }

    /// Records a packet whose angle jumped off the track; returns `true` when more than
    /// `max_in_row` did so in a row: the track is then lost (acquiring again).
    pub fn off_track(&mut self, max_in_row: usize) -> bool {
        self.off_track_in_row += 1;
        if self.off_track_in_row > max_in_row {
            self.restart();
            return true;
        }
        false
    }

    /// Starts over from SpotFi (the side is kept).
    fn restart(&mut self) {
        *self = Self {
            side: self.side,
            ..Self::default()
        };
    }

    /// Records a packet without a credible peak; returns `true` when the track was lost (it is
    /// then acquiring again).
    pub fn miss(&mut self, max_misses: usize) -> bool {
        if let TrackState::Tracking { misses, .. } = &mut self.state {
            *misses += 1;
            if *misses > max_misses {
                self.restart();
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_ahead_and_to_the_left_is_in_front_at_a_positive_angle() {
        let pose = ArrayPose {
            b0_from_array: UnitQuaternion::identity(),
            p_a_in_b0: Vector3::zeros(),
        };
        let (aoa, side) = pose.bearing_to(&Vector3::new(1.0, 1.0, 0.0)).unwrap();
        assert!((aoa - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert_eq!(side, Side::Front);
        let (aoa, side) = pose.bearing_to(&Vector3::new(-1.0, 1.0, 0.0)).unwrap();
        assert!((aoa - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert_eq!(side, Side::Back);
        assert!(pose.bearing_to(&Vector3::zeros()).is_none());
    }

    #[test]
    fn the_rotation_prediction_follows_a_yaw_and_a_lost_track_reacquires() {
        let mut track = Track::default();
        assert!(track.predict_by_rotation(None).is_none());
        let then = ArrayPose {
            b0_from_array: UnitQuaternion::identity(),
            p_a_in_b0: Vector3::zeros(),
        };
        track.accept(0.2, Some(then));
        let now = ArrayPose {
            b0_from_array: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.1),
            ..then
        };
        let p = track.predict_by_rotation(Some(&now)).unwrap();
        assert!((p.predicted_aoa_rad() - 0.1).abs() < 1e-12);
        assert!(!track.miss(1));
        assert!(track.miss(1));
        assert!(matches!(track.state, TrackState::Acquiring { .. }));
    }

    #[test]
    fn a_turn_through_the_axis_carries_the_track_behind_the_array() {
        // The AP at 85° in front; the array turns by −10° about a_z, so the AP's azimuth goes to
        // 95°: behind the array, at a cone angle of 85° again.
        let mut track = Track::default();
        let pose = |yaw_deg: f64| ArrayPose {
            b0_from_array: UnitQuaternion::from_euler_angles(0.0, 0.0, yaw_deg.to_radians()),
            p_a_in_b0: Vector3::zeros(),
        };
        track.accept(85f64.to_radians(), Some(pose(0.0)));
        let p = track.predict_by_rotation(Some(&pose(-10.0))).unwrap();
        assert!(!p.in_front_after);
        assert!((p.predicted_aoa_rad() - 85f64.to_radians()).abs() < 1e-9);
        track.update(p.predicted_aoa_rad(), &p, 1.0, Some(pose(-10.0)));
        assert_eq!(track.side, Side::Back);
        // Turning on, the AP goes further behind (azimuth 105°): the cone angle now falls, where
        // the same turn with the AP in front would have raised it.
        let q = track.predict_by_rotation(Some(&pose(-20.0))).unwrap();
        assert!(!q.in_front_after);
        assert!((q.predicted_aoa_rad() - 75f64.to_radians()).abs() < 1e-9);
    }

    #[test]
    fn the_track_follows_a_share_of_each_angle_and_a_run_of_jumps_restarts_it() {
        let mut track = Track::default();
        track.accept(0.0, None);
        let at = |rad: f64| AoaPrediction {
            previous_aoa_rad: rad,
            rotation_part_rad: 0.0,
            translation_part_rad: 0.0,
            in_front_after: true,
        };
        track.update(0.1, &at(0.0), 0.3, None);
        let TrackState::Tracking { aoa_rad, .. } = track.state else {
            panic!("tracking");
        };
        assert!((aoa_rad - 0.03).abs() < 1e-12);
        assert!(!track.off_track(2));
        assert!(!track.off_track(2));
        // An accepted angle ends the run.
        track.update(0.03, &at(0.03), 0.3, None);
        assert!(!track.off_track(2));
        assert!(!track.off_track(2));
        assert!(track.off_track(2));
        assert!(matches!(track.state, TrackState::Acquiring { .. }));
    }
}
