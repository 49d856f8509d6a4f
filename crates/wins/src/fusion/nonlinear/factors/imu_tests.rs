use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::fusion::nonlinear::state::testing::{
    assert_close, central_difference, random_interval, random_rotation, random_state, sym3,
};
use crate::fusion::nonlinear::state::{NavState, pose_at};
use crate::imu::{ImuSample, STANDARD_GRAVITY_M_S2 as G};
use crate::time::Timestamp;

/// `x_j` from `x_i` through the interval itself (the residual is zero there), with the biases
/// carried over.
fn consistent_j(pre: &Preintegrated, xi: &NavState) -> NavState {
    let p = pose_at(xi, pre, G);
    NavState {
        t: pre.end,
        world_from_body: p.world_from_body,
        p_b_in_w: p.p_b_in_w,
        v_b_in_w: p.v_b_in_w,
        ..*xi
    }
}

/// A keyframe `i` at the start of `pre` whose biases are away from `pre.bias` (δb ≠ 0).
fn state_i(rng: &mut ChaCha8Rng, pre: &Preintegrated) -> NavState {
    let mut xi = random_state(rng, pre.start);
    xi.gyro_bias_rad_s = pre.bias.gyro_rad_s + sym3(rng) * 0.03;
    xi.accel_bias_m_s2 = pre.bias.accel_m_s2 + sym3(rng) * 0.2;
    xi
}

#[test]
fn residual_vanishes_when_j_follows_from_i_through_the_interval() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (n, seed) in [(2usize, 1u64), (5, 2), (60, 3), (400, 4)] {
        let pre = random_interval(n, seed);
        for xi in [state_i(&mut rng, &pre), {
            let mut x = random_state(&mut rng, pre.start);
            x.gyro_bias_rad_s = pre.bias.gyro_rad_s;
            x.accel_bias_m_s2 = pre.bias.accel_m_s2;
            x
        }] {
            let xj = consistent_j(&pre, &xi);
            let r = imu_residual(&pre, G, &xi, &xj);
            assert!(r.norm() < 1e-9, "{n} samples: {r}");
        }
    }
}

/// Against the simulator's ground truth (its specific force uses `g_w = (0, 0, −g)` the same way):
/// noise-free samples of the paper's circle, true states at both ends; the residual is the
/// integration error only (cf. the preintegration tests: ~1e-8 over 20 ms).
#[test]
fn residual_at_the_true_states_of_a_simulated_flight_is_the_integration_error() {
    use crate::sim::motion::{sample, specific_force_in_b};
    use crate::sim::scenario::Scenario;
    let sc = Scenario::built_in("paper-circle").unwrap().airborne();
    let traj = sc.build_flight();
    let g = sc.gravity_m_s2;
    let mut p = crate::imu::Preintegrator::new(
        crate::sim::imu::ImuModel::Ideal.noise(),
        crate::imu::ImuBiases::zero(),
    );
    let t_ns = |i: i64| 3_000_000_000 + i * 5_000_000;
    let state = |t: i64| {
        let s = sample(&traj, &sc.yaw, g, t as f64 * 1e-9);
        let x = NavState {
            t: Timestamp(t),
            world_from_body: s.world_from_body,
            p_b_in_w: s.p_b_in_w,
            v_b_in_w: s.v_b_in_w,
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        };
        let imu = ImuSample {
            t: Timestamp(t),
            gyro_rad_s: s.omega_b_in_b,
            accel_m_s2: specific_force_in_b(&s, g),
        };
        (x, imu)
    };
    for i in 0..4 {
        p.push(&state(t_ns(i)).1).unwrap();
    }
    let (xj, last) = state(t_ns(4));
    let pre = p.cut(last.t, &last).unwrap();
    let (xi, _) = state(t_ns(0));
    let r = imu_residual(&pre, g, &xi, &xj);
    assert!(r.norm() < 1e-7, "{r}");
    // With the wrong sign of gravity the residual would be g·Δt ≈ 0.2 m/s in r_v.
    let wrong = imu_residual(&pre, -g, &xi, &xj);
    assert!(wrong.fixed_rows::<3>(VEL).norm() > 0.1);
}

#[test]
fn jacobians_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    for (n, seed) in [(5usize, 5u64), (40, 6), (120, 7), (300, 8)] {
        let pre = random_interval(n, seed);
        for _ in 0..3 {
            let xi = state_i(&mut rng, &pre);
            // j near the consistent state but off it, so every residual block is non-zero.
            let mut xj = consistent_j(&pre, &xi);
            xj.world_from_body *= random_rotation(&mut rng).powf(0.3);
            xj.p_b_in_w += sym3(&mut rng);
            xj.v_b_in_w += sym3(&mut rng) * 0.5;
            xj.gyro_bias_rad_s += sym3(&mut rng) * 0.01;
            xj.accel_bias_m_s2 += sym3(&mut rng) * 0.1;
            let r0 = imu_residual(&pre, G, &xi, &xj);
            assert!(r0.fixed_rows::<3>(THETA).norm() > 0.05);
            let (ji, jj) = imu_jacobians(&pre, G, &xi, &xj);
            let fd_i = central_difference(|d| imu_residual(&pre, G, &xi.boxplus(d), &xj));
            let fd_j = central_difference(|d| imu_residual(&pre, G, &xi, &xj.boxplus(d)));
            assert_close(&fd_i, &ji, &format!("∂r/∂x_i ({n} samples)"));
            assert_close(&fd_j, &jj, &format!("∂r/∂x_j ({n} samples)"));
            // The bias columns are not trivially zero.
            assert!(ji.fixed_view::<3, 3>(THETA, BG).norm() > 1e-3);
            // ∂α/∂b_a ≈ −½Δt² I: ≥ 5e-5 for the shortest (4-step, 20 ms) interval.
            assert!(ji.fixed_view::<3, 3>(POS, BA).norm() > 5e-5);
        }
    }
}

#[test]
fn covariance_moves_the_preintegration_blocks_and_inverts() {
    let pre = random_interval(50, 9);
    let noise = crate::sim::imu::ImuModel::ConsumerMems.noise();
    let cov = imu_covariance(&pre, &noise);
    let pc = &pre.covariance;
    let floor = Matrix3::identity() * IMU_VARIANCE_FLOOR;
    let block = |r: usize, c: usize| cov.fixed_view::<3, 3>(r, c).into_owned();
    let close = |a: Matrix3<f64>, b: Matrix3<f64>| (a - b).norm() <= 1e-12 * b.norm() + 1e-30;
    assert!(close(
        block(THETA, THETA),
        pc.fixed_view::<3, 3>(6, 6) + floor
    ));
    assert!(close(block(POS, POS), pc.fixed_view::<3, 3>(0, 0) + floor));
    assert!(close(block(VEL, VEL), pc.fixed_view::<3, 3>(3, 3) + floor));
    assert!(close(
        block(POS, THETA),
        pc.fixed_view::<3, 3>(0, 6).into_owned()
    ));
    assert!(close(
        block(THETA, VEL),
        pc.fixed_view::<3, 3>(6, 3).into_owned()
    ));
    assert!(close(
        block(POS, VEL),
        pc.fixed_view::<3, 3>(0, 3).into_owned()
    ));
    assert!(block(POS, THETA).norm() > 0.0);
    let dt = pre.dt_s();
    let var_bg = noise.gyro_bias_random_walk_rad_s2_sqrt_hz.powi(2) * dt;
    assert!((cov[(BG, BG)] - var_bg - IMU_VARIANCE_FLOOR).abs() < 1e-24);
    let var_ba = noise.accel_bias_random_walk_m_s3_sqrt_hz.powi(2) * dt;
    assert!((cov[(BA + 2, BA + 2)] - var_ba - IMU_VARIANCE_FLOOR).abs() < 1e-24);
    assert_eq!(cov.fixed_view::<6, 9>(BG, 0).norm(), 0.0);
    assert_eq!(cov.fixed_view::<3, 3>(BG, BA).norm(), 0.0);
    let info = imu_information(&pre, &noise).unwrap();
    assert_eq!(info, info.transpose());
    assert!((info * cov - Mat15::identity()).norm() < 1e-6);

    // An ideal IMU, an empty interval and a one-sub-interval interval still invert.
    let ideal = crate::sim::imu::ImuModel::Ideal.noise();
    for p in [
        random_interval(2, 10),
        random_interval(1, 11),
        random_interval(30, 12),
    ] {
        assert!(imu_information(&p, &noise).is_some());
        assert!(imu_information(&p, &ideal).is_some());
    }
    let mut bad = pre.clone();
    bad.covariance[(0, 0)] = f64::NAN;
    assert!(imu_information(&bad, &noise).is_none());
}
