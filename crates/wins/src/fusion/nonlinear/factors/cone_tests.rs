use nalgebra::{Isometry3, SVector, Translation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::aoa::steering::aoa_rad;
use crate::fusion::nonlinear::state::testing::{
    assert_close, central_difference, random_interval, random_state, sym3,
};
use crate::imu::STANDARD_GRAVITY_M_S2 as G;
use crate::so3::exp;

/// A tilted array 12 cm off the IMU, as on a real frame.
fn mount() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.12, -0.05, 0.08),
        exp(&Vector3::new(0.3, -0.4, 1.1)),
    )
}

/// The AP at `range` m from the array centre along `toward_in_a` (array frame) at the pose of
/// `x` at `partial.end`.
fn ap_along(
    x: &NavState,
    partial: &Preintegrated,
    body_from_array: &Isometry3<f64>,
    toward_in_a: &Vector3<f64>,
    range: f64,
) -> Vector3<f64> {
    let pose = pose_at(x, partial, G);
    let world_from_body = Isometry3::from_parts(pose.p_b_in_w.into(), pose.world_from_body);
    let world_from_array = world_from_body * body_from_array;
    (world_from_array * nalgebra::Point3::from(toward_in_a.normalize() * range)).coords
}

/// Directions (array frame) in front, behind, above, below, and near both endfires.
fn directions(rng: &mut ChaCha8Rng) -> Vec<Vector3<f64>> {
    let mut out = vec![
        Vector3::new(1.0, 0.3, 0.2),
        Vector3::new(-1.0, 0.5, 0.1),
        Vector3::new(0.4, -0.2, 1.0),
        Vector3::new(-0.3, 0.6, -1.0),
        Vector3::new(0.05, 1.0, 0.1),
        Vector3::new(-0.1, -1.0, 0.05),
    ];
    for _ in 0..4 {
        out.push(sym3(rng));
    }
    out
}

#[test]
fn cone_jacobian_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let mounts = [mount(), Isometry3::identity()];
    for (n, seed) in [(1usize, 1u64), (6, 2), (80, 3)] {
        let partial = random_interval(n, seed);
        for m in &mounts {
            for dir in directions(&mut rng) {
                let mut x = random_state(&mut rng, partial.start);
                x.gyro_bias_rad_s = partial.bias.gyro_rad_s + sym3(&mut rng) * 0.02;
                x.accel_bias_m_s2 = partial.bias.accel_m_s2 + sym3(&mut rng) * 0.2;
                let range = 2.0 + 10.0 * rng.random::<f64>();
                let c = ap_along(&x, &partial, m, &dir, range) + sym3(&mut rng) * 0.3;
                let meas = 0.1;
                let jac = cone_jacobian(&x, &partial, G, m, &c, meas).unwrap();
                let r = cone_residual(&x, &partial, G, m, &c, meas).unwrap();
                assert_eq!(jac.residual, r);
                let fd = central_difference(|d| {
                    SVector::<f64, 1>::new(
                        cone_residual(&x.boxplus(d), &partial, G, m, &c, meas).unwrap(),
                    )
                });
                assert_close(&fd, &jac.d_state, &format!("∂r/∂x, direction {dir}"));
                let h = 1e-6;
                let mut fd_c = RowVector3::zeros();
                for k in 0..3 {
                    let mut e = Vector3::zeros();
                    e[k] = h;
                    let rp = cone_residual(&x, &partial, G, m, &(c + e), meas).unwrap();
                    let rm = cone_residual(&x, &partial, G, m, &(c - e), meas).unwrap();
                    fd_c[k] = (rp - rm) / (2.0 * h);
                }
                assert_close(&fd_c, &jac.d_ap, &format!("∂r/∂c, direction {dir}"));
                // Not vacuous: the bearing moves with the state and the AP.
                assert!(jac.d_state.norm() > 1e-3 && jac.d_ap.norm() > 1e-3);
            }
        }
    }
}

#[test]
fn the_true_ap_and_bearing_give_zero_and_agree_with_the_steering_convention() {
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    let partial = random_interval(30, 4);
    let m = mount();
    for dir in directions(&mut rng) {
        let x = random_state(&mut rng, partial.start);
        let c = ap_along(&x, &partial, &m, &dir, 7.5);
        // The AoA of the direction we placed the AP along, by the steering module's definition.
        let theta = aoa_rad(&dir);
        let r = cone_residual(&x, &partial, G, &m, &c, theta.sin()).unwrap();
        assert!(r.abs() < 1e-12, "{dir}: {r}");
        // The prediction alone is sin θ (measured 0), so its arcsine is steering's AoA.
        let s = cone_residual(&x, &partial, G, &m, &c, 0.0).unwrap();
        assert!(
            (s.asin() - theta).abs() < 1e-9,
            "{dir}: {} vs {theta}",
            s.asin()
        );
    }
    // A source behind the array has the cone angle of its mirror image in front.
    let x = random_state(&mut rng, partial.start);
    let front = ap_along(&x, &partial, &m, &Vector3::new(1.0, 0.4, 0.2), 5.0);
    let back = ap_along(&x, &partial, &m, &Vector3::new(-1.0, 0.4, 0.2), 5.0);
    let rf = cone_residual(&x, &partial, G, &m, &front, 0.0).unwrap();
    let rb = cone_residual(&x, &partial, G, &m, &back, 0.0).unwrap();
    assert!((rf - rb).abs() < 1e-12);
}

#[test]
fn an_ap_at_the_array_centre_has_no_bearing() {
    let mut rng = ChaCha8Rng::seed_from_u64(33);
    let partial = random_interval(10, 5);
    let x = random_state(&mut rng, partial.start);
    let m = mount();
    let c = ap_along(&x, &partial, &m, &Vector3::x(), 0.0);
    assert!(cone_residual(&x, &partial, G, &m, &c, 0.0).is_none());
    assert!(cone_jacobian(&x, &partial, G, &m, &c, 0.0).is_none());
    let near = ap_along(&x, &partial, &m, &Vector3::x(), 1e-6);
    assert!(cone_jacobian(&x, &partial, G, &m, &near, 0.0).is_some());
}

#[test]
fn sin_sigma_follows_cos_theta_and_is_floored_at_endfire() {
    let s = 0.05;
    assert!((sin_sigma(0.0, s) - s).abs() < 1e-15);
    let t = 60f64.to_radians();
    assert!((sin_sigma(t, s) - 0.5 * s).abs() < 1e-12);
    assert!((sin_sigma(-t, s) - 0.5 * s).abs() < 1e-12);
    for deg in [80.0f64, 89.0, 90.0, -90.0] {
        assert!((sin_sigma(deg.to_radians(), s) - COS_FLOOR * s).abs() < 1e-15);
    }
}
