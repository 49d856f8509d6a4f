//! Tests of the placement after a hole ([`super`]).

use nalgebra::Vector2;

use super::*;

fn pair(from: Vector3<f64>, to: Vector3<f64>, weight: f64) -> Weighted {
    Weighted::even(from, to, weight)
}

#[test]
fn one_ap_moves_the_frame_and_two_turn_it() {
    let shift = Vector3::new(1.0, -2.0, 0.5);
    let a = Vector3::new(3.0, 0.0, 2.0);
    let one = relocated(&[pair(a, a + shift, 1.0)]).expect("one pair");
    assert!((one.translation.vector - shift).norm() < 1e-12);
    assert!(one.rotation.angle() < 1e-12);

    let truth = Isometry3::from_parts(
        Translation3::new(0.4, 0.3, -0.2),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.35),
    );
    let aps = [Vector3::new(5.0, 0.0, 2.0), Vector3::new(0.0, 6.0, 1.0)];
    let pairs: Vec<_> = aps
        .iter()
        .map(|a| pair(*a, truth.transform_point(&(*a).into()).coords, 1.0))
        .collect();
    let two = relocated(&pairs).expect("two pairs");
    assert!((two.rotation.angle() - 0.35).abs() < 1e-9);
    assert!((two.translation.vector - truth.translation.vector).norm() < 1e-9);
    assert!(relocated(&[]).is_none());
    assert!(relocated(&[pair(a, a, 0.0)]).is_none());
}

/// The new window's AP 0.5 m nearer the drone than the lost window's is a wrong window
/// at σ 0.1 m, and a right one at σ 0.3 m; of three APs, one off is outvoted, two are not.
#[test]
fn a_window_agrees_when_its_ranges_do() {
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1.0);
    let drone = Vector3::new(1.0, 2.0, 1.5);
    let bridge = pair(drone, turn * drone + Vector3::new(0.3, -0.2, 0.0), 100.0);
    let ap = |old: Vector3<f64>, nearer_m: f64, sigma_m: f64| {
        let from_drone = turn.inverse() * (old - bridge.to);
        let new = drone + from_drone * (1.0 - nearer_m / from_drone.xy().norm());
        pair(new, old, (sigma_m * sigma_m - 0.01).recip())
    };
    let old = [
        Vector3::new(7.0, 1.0, 2.0),
        Vector3::new(-3.0, 5.0, 1.0),
        Vector3::new(2.0, -6.0, 2.5),
    ];
    assert!(ranges_agree(&[ap(old[0], 0.0, 0.12)], &bridge));
    assert!(!ranges_agree(&[ap(old[0], 0.5, 0.12)], &bridge));
    assert!(ranges_agree(&[ap(old[0], 0.5, 0.3)], &bridge));
    let one_off = [
        ap(old[0], 0.5, 0.12),
        ap(old[1], 0.0, 0.12),
        ap(old[2], 0.0, 0.12),
    ];
    assert!(ranges_agree(&one_off, &bridge));
    let two_off = [
        ap(old[0], 0.5, 0.12),
        ap(old[1], 0.6, 0.12),
        ap(old[2], 0.0, 0.12),
    ];
    assert!(!ranges_agree(&two_off, &bridge));
}

/// The height is the mean of the pairs' height differences by their vertical weights: an AP
/// pair tight across but loose along the vertical (its height weakly seen) leaves the
/// height to a pair on the height alone (the barometer's), which moves nothing across.
#[test]
fn the_height_goes_by_the_vertical_weights() {
    let a = Vector3::new(3.0, 0.0, 2.0);
    let ap = Weighted {
        from: a,
        to: a + Vector3::new(0.2, -0.1, 0.6),
        weight: 100.0,
        weight_z: 1.0,
    };
    let baro = Weighted {
        from: Vector3::zeros(),
        to: Vector3::z() * -0.1,
        weight: 0.0,
        weight_z: 9.0,
    };
    let fix = relocated(&[ap, baro]).expect("pairs");
    assert!((fix.translation.vector.z - (0.6 + 9.0 * -0.1) / 10.0).abs() < 1e-12);
    assert!((fix.translation.vector.xy() - Vector2::new(0.2, -0.1)).norm() < 1e-12);
    assert!(fix.rotation.angle() < 1e-12);
    // A pair weighing alike on every axis moves the height by its own difference.
    let even = relocated(&[pair(a, a + Vector3::z() * 0.6, 1.0)]).expect("a pair");
    assert!((even.translation.vector.z - 0.6).abs() < 1e-12);
}

/// One AP and the carried position: the frame turns about the carried position so that
/// the AP's direction from it is the lost window's, and the AP (the far tighter pair)
/// lands almost exactly.
#[test]
fn one_ap_and_the_carried_position_fix_the_heading() {
    let drone = Vector3::new(1.0, 1.0, 1.5);
    let ap_old = Vector3::new(7.0, 1.0, 1.5);
    // The new window's frame is turned by 35° about the drone (a heading carried across a
    // gap), and its AP sits 2 cm off along the range.
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -35f64.to_radians());
    let ap_new = drone + turn * (ap_old - drone) * (1.0 + 0.02 / 6.0);
    let fix = relocated(&[pair(ap_new, ap_old, 1e4), pair(drone, drone, 4.0)]).expect("two pairs");
    assert!((fix.rotation.angle() - 35f64.to_radians()).abs() < 1e-9);
    let ap_placed = fix.transform_point(&ap_new.into()).coords;
    assert!((ap_placed - ap_old).norm() < 0.03);
    let drone_placed = fix.transform_point(&drone.into()).coords;
    assert!((drone_placed - drone).norm() < 0.03);
}
