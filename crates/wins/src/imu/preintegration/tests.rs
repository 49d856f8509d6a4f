//! Tests of `preintegration`: the integration against the truth, its bias Jacobians and
//! covariance, refused samples and gaps; appending intervals in [`append`].

mod append;

use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::sim::imu::normal3;
use crate::sim::motion::{BodyState, sample, specific_force_in_b};
use crate::sim::scenario::Scenario;
use crate::so3::{exp, log};

const PERIOD_NS: i64 = 5_000_000;

/// Noise-free samples and true states of the paper's circle at 200 Hz, for `n` samples.
fn circle(n: usize) -> (Vec<ImuSample>, Vec<BodyState>, f64) {
    let sc = Scenario::built_in("paper-circle").unwrap().airborne();
    let traj = sc.build_flight();
    let g = sc.gravity_m_s2;
    let mut samples = Vec::new();
    let mut states = Vec::new();
    for i in 0..n {
        let t_ns = 1_000_000_000 + i as i64 * PERIOD_NS;
        let s = sample(&traj, &sc.yaw, g, t_ns as f64 * 1e-9);
        samples.push(ImuSample {
            t: Timestamp(t_ns),
            gyro_rad_s: s.omega_b_in_b,
            accel_m_s2: specific_force_in_b(&s, g),
        });
        states.push(s);
    }
    (samples, states, g)
}

fn integrate(
    samples: &[ImuSample],
    noise: &ImuNoise,
    bias: ImuBiases,
    cut: Timestamp,
) -> Preintegrated {
    let mut p = Preintegrator::new(noise.clone(), bias);
    for (i, s) in samples.iter().enumerate() {
        if s.t >= cut {
            return p.cut(cut, s).unwrap();
        }
        p.push(s).unwrap();
        if i + 1 == samples.len() {
            return p.cut(cut, s).unwrap();
        }
    }
    unreachable!()
}

/// α, β, ΔR from the true states (`eqn:imumodel` solved for the measurements).
fn truth(
    a: &BodyState,
    b: &BodyState,
    g: f64,
) -> (Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>) {
    let dt = b.t_s - a.t_s;
    let r_w_bk = a.world_from_body;
    let g_in_bk = r_w_bk.inverse_transform_vector(&Vector3::new(0.0, 0.0, g));
    let v_in_bk = r_w_bk.inverse_transform_vector(&a.v_b_in_w);
    let alpha = r_w_bk.inverse_transform_vector(&(b.p_b_in_w - a.p_b_in_w)) - v_in_bk * dt
        + g_in_bk * (0.5 * dt * dt);
    let beta = r_w_bk.inverse_transform_vector(&(b.v_b_in_w - a.v_b_in_w)) + g_in_bk * dt;
    (alpha, beta, r_w_bk.inverse() * b.world_from_body)
}

fn zero_noise() -> ImuNoise {
    ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: 0.0,
        gyro_bias_random_walk_rad_s2_sqrt_hz: 0.0,
        gyro_turn_on_bias_rad_s: 0.0,
        accel_noise_density_m_s2_sqrt_hz: 0.0,
        accel_bias_random_walk_m_s3_sqrt_hz: 0.0,
        accel_turn_on_bias_m_s2: 0.0,
    }
}

#[test]
fn noise_free_samples_reproduce_the_true_relative_motion() {
    let (samples, states, g) = circle(401);
    // A 20 ms frame interval (the paper's 50 Hz PAoA) and a whole 2 s; the first cut falls between
    // samples (interpolated), the second on one.
    for (i0, t_end_ns, tol_pos, tol_rot) in [
        (0usize, 1_017_500_000i64, 1e-7, 1e-7),
        (0, 3_000_000_000, 5e-6, 5e-6),
    ] {
        let pre = integrate(
            &samples[i0..],
            &zero_noise(),
            ImuBiases::zero(),
            Timestamp(t_end_ns),
        );
        let t_end_s = t_end_ns as f64 * 1e-9;
        let sc = Scenario::built_in("paper-circle").unwrap().airborne();
        let end = sample(&sc.build_flight(), &sc.yaw, g, t_end_s);
        let (alpha, beta, rot) = truth(&states[i0], &end, g);
        let dt = pre.dt_s();
        assert!((dt - (t_end_s - states[i0].t_s)).abs() < 1e-12);
        let e_a = (pre.alpha - alpha).norm();
        let e_b = (pre.beta - beta).norm();
        let e_r = log(&(rot.inverse() * pre.bk_from_bk1)).norm();
        eprintln!("Δt {dt:.3} s: |δα| {e_a:.2e} m, |δβ| {e_b:.2e} m/s, |δθ| {e_r:.2e} rad");
        assert!(
            e_a < tol_pos && e_b < 10.0 * tol_pos && e_r < tol_rot,
            "{e_a} {e_b} {e_r}"
        );
        // The tolerances are small against the motion itself (not a vacuous comparison).
        assert!(alpha.norm() > 1e3 * tol_pos);
    }
}

#[test]
fn bias_jacobians_match_finite_differences() {
    let (samples, _, _) = circle(60);
    let noise = zero_noise();
    let b0 = ImuBiases {
        gyro_rad_s: Vector3::new(0.01, -0.02, 0.015),
        accel_m_s2: Vector3::new(0.05, 0.02, -0.03),
    };
    let cut = Timestamp(samples[57].t.0 + 1_000_000);
    let base = integrate(&samples, &noise, b0, cut);
    let h = 1e-6;
    for j in 0..6 {
        let mut b = b0;
        if j < 3 {
            b.accel_m_s2[j] += h;
        } else {
            b.gyro_rad_s[j - 3] += h;
        }
        let p = integrate(&samples, &noise, b, cut);
        let fd_a = (p.alpha - base.alpha) / h;
        let fd_b = (p.beta - base.beta) / h;
        let fd_r = log(&(base.bk_from_bk1.inverse() * p.bk_from_bk1)) / h;
        let col = base.jacobian_bias.column(j);
        for (k, fd) in [fd_a, fd_b, fd_r].iter().enumerate() {
            let an = col.fixed_rows::<3>(3 * k);
            assert!(
                (fd - an).norm() < 1e-5 * (1.0 + an.norm()),
                "bias {j}, block {k}: {fd} vs {an}"
            );
        }
        // `corrected` applies them: it matches re-integration to second order.
        let (a, bb, r) = base.corrected(&b);
        assert!((a - p.alpha).norm() < 1e-10 && (bb - p.beta).norm() < 1e-10);
        assert!(log(&(r.inverse() * p.bk_from_bk1)).norm() < 1e-10);
    }
}

/// Monte-Carlo: the spread of `[α, β, θ]` over seeded noise draws matches the propagated
/// covariance. With N draws of a 9-dimensional error the summed NEES is χ²(9N); the test asserts
/// it within the two-sided 99.9% band, and the trace of each 3×3 block within 15%.
#[test]
fn monte_carlo_spread_matches_the_propagated_covariance() {
    let noise = crate::sim::imu::ImuModel::ConsumerMems.noise();
    let (clean, _, _) = circle(101);
    let sigma_a = noise.accel_noise_density_m_s2_sqrt_hz / (PERIOD_NS as f64 * 1e-9).sqrt();
    let sigma_g = noise.gyro_noise_density_rad_s_sqrt_hz / (PERIOD_NS as f64 * 1e-9).sqrt();
    // A 20 ms interval of 4 samples (endpoint sharing matters most) and a 0.5 s one.
    for samples_in_interval in [4usize, 100] {
        let cut = clean[samples_in_interval].t;
        let reference = integrate(&clean, &noise, ImuBiases::zero(), cut);
        let info = reference.covariance.try_inverse().unwrap();
        let draws = 300;
        let mut rng = ChaCha8Rng::seed_from_u64(7 + samples_in_interval as u64);
        let mut nees_sum = 0.0;
        let mut second = Covariance9::zeros();
        for _ in 0..draws {
            let noisy: Vec<ImuSample> = clean
                .iter()
                .map(|s| ImuSample {
                    t: s.t,
                    gyro_rad_s: s.gyro_rad_s + normal3(&mut rng) * sigma_g,
                    accel_m_s2: s.accel_m_s2 + normal3(&mut rng) * sigma_a,
                })
                .collect();
            let p = integrate(&noisy, &noise, ImuBiases::zero(), cut);
            let mut e = SVector::<f64, 9>::zeros();
            e.fixed_rows_mut::<3>(0)
                .copy_from(&(p.alpha - reference.alpha));
            e.fixed_rows_mut::<3>(3)
                .copy_from(&(p.beta - reference.beta));
            e.fixed_rows_mut::<3>(6)
                .copy_from(&log(&(reference.bk_from_bk1.inverse() * p.bk_from_bk1)));
            nees_sum += (e.transpose() * info * e)[0];
            second += e * e.transpose();
        }
        let dof = 9.0 * draws as f64;
        // χ²(k) ≈ N(k, 2k) for large k; 3.29σ is the two-sided 99.9% band.
        let band = 3.29 * (2.0 * dof).sqrt();
        eprintln!(
            "{samples_in_interval} samples: NEES sum {nees_sum:.0} (χ² band {:.0}…{:.0})",
            dof - band,
            dof + band
        );
        assert!(
            (nees_sum - dof).abs() < band,
            "{nees_sum} vs {dof} ± {band}"
        );
        let sample_cov = second / draws as f64;
        for k in 0..3 {
            let mc = sample_cov.fixed_view::<3, 3>(3 * k, 3 * k).trace();
            let pr = reference
                .covariance
                .fixed_view::<3, 3>(3 * k, 3 * k)
                .trace();
            assert!((mc / pr - 1.0).abs() < 0.15, "block {k}: {mc} vs {pr}");
        }
    }
}

#[test]
fn bad_samples_are_refused_with_clear_errors() {
    let (samples, _, _) = circle(4);
    let mut p = Preintegrator::new(zero_noise(), ImuBiases::zero());
    assert_eq!(
        p.cut(samples[0].t, &samples[0]),
        Err(PreintegrationError::NoSamples {
            t_ns: samples[0].t.0
        })
    );
    p.push(&samples[1]).unwrap();
    assert!(matches!(
        p.push(&samples[0]),
        Err(PreintegrationError::OutOfOrder { .. })
    ));
    let mut nan = samples[2];
    nan.accel_m_s2.x = f64::NAN;
    assert!(matches!(
        p.push(&nan),
        Err(PreintegrationError::NonFinite { .. })
    ));
    assert!(matches!(
        p.cut(samples[3].t, &samples[2]),
        Err(PreintegrationError::CutOutsideSamples { .. })
    ));
    // The refused samples left the state alone.
    p.push(&samples[2]).unwrap();
    let pre = p.cut(samples[2].t, &samples[3]).unwrap();
    assert_eq!((pre.start, pre.end), (samples[1].t, samples[2].t));
    assert!(pre.alpha.iter().all(|x| x.is_finite()));
}

#[test]
fn a_gap_adds_the_unseen_motions_covariance_and_is_reported() {
    let (samples, _, _) = circle(400);
    // A 1 s hole: samples 100..300 never came.
    let kept: Vec<ImuSample> = samples
        .iter()
        .enumerate()
        .filter(|(i, _)| !(100..300).contains(i))
        .map(|(_, s)| *s)
        .collect();
    let noise = ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: 1e-4,
        accel_noise_density_m_s2_sqrt_hz: 1e-3,
        ..zero_noise()
    };
    let gap = ImuGap::default();
    let mut plain = Preintegrator::new(noise.clone(), ImuBiases::zero());
    let mut gapped = Preintegrator::new(noise, ImuBiases::zero()).with_gap(gap);
    for s in &kept[..100] {
        plain.push(s).unwrap();
        gapped.push(s).unwrap();
    }
    let after = kept[100];
    assert_eq!(plain.gap_before(&after), None, "no gap model, no gap");
    assert_eq!(gapped.gap_before(&after), Some(kept[99].t));
    assert_eq!(gapped.gap_before(&kept[1]), None);
    plain.push(&after).unwrap();
    gapped.push(&after).unwrap();
    let h = after.t.secs_since(kept[99].t);
    let added = gapped.running().covariance - plain.running().covariance;
    assert!((added - gap.covariance(h)).abs().max() < 1e-9, "{added}");
    // The means are the straight line either way.
    assert_eq!(gapped.running().alpha, plain.running().alpha);
}
