use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

fn yaw(deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(0.0, 0.0, deg.to_radians())
}

fn at(s: f64) -> Timestamp {
    Timestamp((s * 1e9).round() as i64)
}

const FILTER: TrackGains = TrackGains {
    angle: 0.3,
    rate_hz: 0.0,
};

#[test]
fn the_rotation_prediction_follows_a_yaw_and_a_lost_track_reacquires() {
    let mut track = Track::default();
    assert!(track.predict(at(0.0), &yaw(0.0), None).is_none());
    track.accept(0.2, at(0.0), yaw(0.0));
    let p = track.predict(at(0.02), &yaw(5.73), None).unwrap();
    assert!((p.predicted_aoa_rad() - (0.2 - 5.73f64.to_radians())).abs() < 1e-12);
    assert!(!track.miss(1));
    assert!(track.miss(1));
    assert!(matches!(track.state, TrackState::Acquiring { .. }));
}

#[test]
fn the_time_since_the_last_packet_is_told_and_a_silence_restarts_the_track_doubting_the_state() {
    let mut track = Track::default();
    assert_eq!(track.packet_at(at(0.0)), None);
    track.accept(0.2, at(0.0), yaw(0.0));
    track.side = Side::Back;
    assert_eq!(track.packet_at(at(0.5)), Some(0.5));
    assert_eq!(track.packet_at(at(6.5)), Some(6.0));
    track.restart_after_silence();
    assert!(matches!(track.state, TrackState::Acquiring { .. }));
    assert!(track.state_doubted);
    assert_eq!(track.side, Side::Back);
    // While acquiring no silence is told; the time of the packet is kept.
    assert_eq!(track.packet_at(at(9.0)), None);
    track.accept(0.1, at(9.0), yaw(0.0));
    assert_eq!(track.packet_at(at(9.02)), Some(0.02));
}

#[test]
fn a_turn_through_the_axis_carries_the_track_behind_the_array() {
    // The AP at 85° in front; the array turns by −10° about a_z, so the AP's azimuth goes to
    // 95°: behind the array, at a cone angle of 85° again.
    let mut track = Track::default();
    track.accept(85f64.to_radians(), at(0.0), yaw(0.0));
    let p = track.predict(at(0.1), &yaw(-10.0), None).unwrap();
    assert!(!p.in_front_after);
    assert!((p.predicted_aoa_rad() - 85f64.to_radians()).abs() < 1e-9);
    track.update(p.predicted_aoa_rad(), &p, FILTER, at(0.1), yaw(-10.0));
    assert_eq!(track.side, Side::Back);
    // Turning on, the AP goes further behind (azimuth 105°): the cone angle now falls, where
    // the same turn with the AP in front would have raised it.
    let q = track.predict(at(0.2), &yaw(-20.0), None).unwrap();
    assert!(!q.in_front_after);
    assert!((q.predicted_aoa_rad() - 75f64.to_radians()).abs() < 1e-9);
}

#[test]
fn the_track_follows_a_share_of_each_angle_and_a_run_of_jumps_restarts_it() {
    let mut track = Track::default();
    track.accept(0.0, at(0.0), yaw(0.0));
    let p = track.predict(at(0.1), &yaw(0.0), None).unwrap();
    track.update(0.1, &p, FILTER, at(0.1), yaw(0.0));
    let TrackState::Tracking { aoa_rad, .. } = track.state else {
        panic!("tracking");
    };
    assert!((aoa_rad - 0.03).abs() < 1e-12);
    assert!(!track.off_track(2));
    assert!(!track.off_track(2));
    // An accepted angle ends the run.
    let p = track.predict(at(0.2), &yaw(0.0), None).unwrap();
    track.update(0.03, &p, FILTER, at(0.2), yaw(0.0));
    assert!(!track.off_track(2));
    assert!(!track.off_track(2));
    assert!(track.off_track(2));
    assert!(matches!(track.state, TrackState::Acquiring { .. }));
}

/// Worst prediction error over the last half of a ramp of `rate_deg_s` sampled every
/// `period_s`, degrees.
fn ramp_lag_deg(gains: TrackGains, rate_deg_s: f64, period_s: f64) -> f64 {
    let mut track = Track::default();
    track.accept(0.0, at(0.0), yaw(0.0));
    let mut worst: f64 = 0.0;
    for k in 1..=40 {
        let t = k as f64 * period_s;
        let truth = (rate_deg_s * t).to_radians();
        let p = track.predict(at(t), &yaw(0.0), None).unwrap();
        if k > 20 {
            worst = worst.max((p.predicted_aoa_rad() - truth).abs().to_degrees());
        }
        track.update(truth, &p, gains, at(t), yaw(0.0));
    }
    worst
}

#[test]
fn a_steady_change_is_followed_without_lag_at_a_slow_packet_rate() {
    // 20°/s across (1 m/s at 3 m) seen at 10 packets/s: the first-order filter trails by
    // rate·period·(1 − gain)/gain = 4.7°, the alpha-beta track converges onto the ramp.
    let first_order = ramp_lag_deg(FILTER, 20.0, 0.1);
    assert!(first_order > 4.0, "{first_order}");
    let alpha_beta = TrackGains {
        angle: 0.5,
        rate_hz: 1.5,
    };
    let lag = ramp_lag_deg(alpha_beta, 20.0, 0.1);
    assert!(lag < 0.3, "{lag}");
}

#[test]
fn the_rate_restarts_after_a_gap_and_is_bounded() {
    let gains = TrackGains {
        angle: 0.5,
        rate_hz: 5.0,
    };
    let mut track = Track::default();
    track.accept(0.0, at(0.0), yaw(0.0));
    let p = track.predict(at(0.01), &yaw(0.0), None).unwrap();
    // A 0.5 rad jump over 10 ms would be 25 rad/s: bounded (1 m/s across at 1 m).
    track.update(0.5, &p, gains, at(0.01), yaw(0.0));
    let TrackState::Tracking { rate_rad_s, .. } = track.state else {
        panic!("tracking");
    };
    assert_eq!(rate_rad_s, MAX_RATE_RAD_S);
    // Beyond the horizon the rate is not extrapolated.
    let p = track.predict(at(5.0), &yaw(0.0), None).unwrap();
    assert!(p.translation_part_rad.abs() < 1e-12);
    track.update(0.4, &p, gains, at(5.0), yaw(0.0));
    let TrackState::Tracking { rate_rad_s, .. } = track.state else {
        panic!("tracking");
    };
    assert_eq!(rate_rad_s, 0.0);
}

#[test]
fn the_turns_tell_an_ap_behind_the_array() {
    // The AP at an azimuth of 140° (behind, cone angle 40°), the array yawing ±30° at
    // 0.5 Hz, 50 packets/s with 2° of noise; the track starts in front, as SpotFi cannot
    // tell. Without turns it stays in front.
    let azimuth = 140f64.to_radians();
    let cone = |yaw: f64| (azimuth - yaw).sin().asin();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for (amplitude_deg, behind) in [(30.0, true), (0.0, false)] {
        let mut track = Track::default();
        track.accept(cone(0.0), at(0.0), yaw(0.0));
        let mut switched_at = None;
        for k in 1..500 {
            let t = k as f64 * 0.02;
            let psi = (amplitude_deg * (std::f64::consts::TAU * 0.5 * t).sin()).to_radians();
            let noise: f64 = rng.random_range(-2.0..2.0);
            let measured = cone(psi) + noise.to_radians();
            let attitude = UnitQuaternion::from_euler_angles(0.0, 0.0, psi);
            if track.weigh_side(measured, at(t), &attitude, None, 3f64.to_radians()) {
                switched_at.get_or_insert(t);
            }
            let p = track.predict(at(t), &attitude, None).unwrap();
            track.update(measured, &p, FILTER, at(t), attitude);
        }
        assert_eq!(track.side == Side::Back, behind, "{amplitude_deg}");
        if behind {
            assert!(switched_at.is_some_and(|t| t < 3.0), "{switched_at:?}");
        }
    }
}
