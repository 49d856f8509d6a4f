//! Unit tests of the filter itself (the Jacobians are tested next to their code).

use nalgebra::{DMatrix, Isometry3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::*;
use crate::fusion::bearing::Side;
use crate::time::Timestamp;

const G: f64 = STANDARD_GRAVITY_M_S2;
const DT_NS: i64 = 10_000_000;

fn hover_state() -> EkfState {
    EkfState {
        t: Timestamp(0),
        world_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3),
        v_b_in_w: Vector3::zeros(),
        p_b_in_w: Vector3::new(5.0, 4.0, 1.5),
        c_in_w: vec![Vector3::new(1.0, 4.0, 1.5)],
    }
}

fn small_covariance(n: usize) -> DMatrix<f64> {
    DMatrix::identity(n, n) * 1e-4
}

fn at_rest(k: i64) -> ImuSample {
    ImuSample {
        t: Timestamp(k * DT_NS),
        gyro_rad_s: Vector3::zeros(),
        accel_m_s2: Vector3::new(0.0, 0.0, G),
    }
}

#[test]
fn constructor_refuses_bad_input() {
    let ok = || Ekf::new(EkfConfig::default(), hover_state(), small_covariance(12));
    assert!(ok().is_ok());
    let mut s = hover_state();
    s.c_in_w[0].z = f64::INFINITY;
    assert_eq!(
        Ekf::new(EkfConfig::default(), s, small_covariance(12)).err(),
        Some(EkfError::NonFiniteState)
    );
    assert!(matches!(
        Ekf::new(EkfConfig::default(), hover_state(), small_covariance(9)),
        Err(EkfError::CovarianceShape {
            expected: 12,
            rows: 9,
            cols: 9
        })
    ));
    let mut p = small_covariance(12);
    p[(2, 5)] = 1e-5;
    assert!(matches!(
        Ekf::new(EkfConfig::default(), hover_state(), p),
        Err(EkfError::CovarianceNotSymmetric { row: 2, col: 5, .. })
    ));
    let mut p = small_covariance(12);
    p[(4, 4)] = -1.0;
    assert_eq!(
        Ekf::new(EkfConfig::default(), hover_state(), p).err(),
        Some(EkfError::CovarianceNotPositiveDefinite)
    );
    let mut p = small_covariance(12);
    p[(7, 7)] = f64::NAN;
    assert_eq!(
        Ekf::new(EkfConfig::default(), hover_state(), p).err(),
        Some(EkfError::CovarianceNotFinite { row: 7, col: 7 })
    );
    let config = EkfConfig {
        accel_noise_density_m_s2_sqrt_hz: -1.0,
        ..EkfConfig::default()
    };
    assert!(matches!(
        Ekf::new(config, hover_state(), small_covariance(12)),
        Err(EkfError::InvalidConfig {
            field: "accel_noise_density_m_s2_sqrt_hz",
            ..
        })
    ));
    let config = EkfConfig {
        mahalanobis_gate: Some(0.0),
        ..EkfConfig::default()
    };
    assert!(config.validate().is_err());
}

#[test]
fn add_ap_grows_state_and_covariance() {
    let mut ekf =
        Ekf::new(EkfConfig::default(), hover_state(), small_covariance(12)).expect("valid input");
    let l = ekf
        .add_ap(Vector3::new(9.0, 1.0, 2.0), Matrix3::identity() * 4.0)
        .expect("valid AP");
    assert_eq!(l, 1);
    assert_eq!(ekf.covariance().shape(), (15, 15));
    assert_eq!(ekf.covariance()[(13, 13)], 4.0);
    assert_eq!(ekf.covariance()[(13, 2)], 0.0);
    assert!(
        ekf.add_ap(Vector3::new(f64::NAN, 0.0, 0.0), Matrix3::identity())
            .is_err()
    );
    assert!(ekf.add_ap(Vector3::zeros(), -Matrix3::identity()).is_err());
    assert_eq!(ekf.state().num_aps(), 2);
}

#[test]
fn propagation_skips_bad_samples_and_counts_them() {
    let mut ekf =
        Ekf::new(EkfConfig::default(), hover_state(), small_covariance(12)).expect("valid input");
    assert_eq!(ekf.propagate(&at_rest(0)), ImuOutcome::Held);
    assert_eq!(ekf.propagate(&at_rest(1)), ImuOutcome::Propagated);
    assert_eq!(
        ekf.propagate(&at_rest(1)),
        ImuOutcome::Skipped(ImuSkip::OutOfOrder)
    );
    let mut nan = at_rest(2);
    nan.gyro_rad_s.y = f64::NAN;
    assert_eq!(ekf.propagate(&nan), ImuOutcome::Skipped(ImuSkip::NonFinite));
    assert_eq!(ekf.propagate(&at_rest(2)), ImuOutcome::Propagated);
    let r = ekf.report();
    assert_eq!(
        (r.imu_propagated, r.imu_out_of_order, r.imu_non_finite),
        (2, 1, 1)
    );
    // At rest nothing moves.
    assert!(ekf.state().boxminus(&hover_state()).norm() < 1e-12);
    assert_eq!(ekf.state().t, Timestamp(2 * DT_NS));
}

/// GTSAM-style: the covariance propagated from the densities matches the Monte-Carlo spread of
/// the nominal propagation driven by sampled noise σ_d = σ_c/√Δt.
#[test]
fn propagated_covariance_matches_monte_carlo() {
    let (gyro_density, accel_density) = (2e-3, 3e-3);
    let config = EkfConfig {
        gyro_noise_density_rad_s_sqrt_hz: gyro_density,
        accel_noise_density_m_s2_sqrt_hz: accel_density,
        ..EkfConfig::default()
    };
    let steps = 200;
    let x0 = hover_state();
    let p0 = DMatrix::identity(12, 12) * 1e-12;
    let mut ekf = Ekf::new(config, x0.clone(), p0).expect("valid input");
    for k in 0..=steps {
        ekf.propagate(&at_rest(k));
    }
    let dt = DT_NS as f64 * 1e-9;
    let sigma_g = Normal::new(0.0, gyro_density / dt.sqrt()).expect("valid σ");
    let sigma_a = Normal::new(0.0, accel_density / dt.sqrt()).expect("valid σ");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let runs = 400;
    let mut sum_sq = DMatrix::<f64>::zeros(12, 12);
    for _ in 0..runs {
        let mut x = x0.clone();
        let noisy = |k: i64, rng: &mut ChaCha8Rng| {
            let mut s = at_rest(k);
            s.gyro_rad_s += Vector3::from_fn(|_, _| sigma_g.sample(rng));
            s.accel_m_s2 += Vector3::from_fn(|_, _| sigma_a.sample(rng));
            s
        };
        let mut prev = noisy(0, &mut rng);
        for k in 1..=steps {
            let next = noisy(k, &mut rng);
            x = ImuStep::new(&prev, &next, x.t)
                .expect("increasing time")
                .propagate(&x, G);
            prev = next;
        }
        let e = x.boxminus(ekf.state());
        sum_sq += &e * e.transpose();
    }
    let mc = sum_sq / runs as f64;
    let p = ekf.covariance();
    for i in [0, 1, 2, 3, 4, 5, 6, 7, 8] {
        let ratio = mc[(i, i)] / p[(i, i)];
        eprintln!("state {i}: Monte-Carlo / propagated variance {ratio:.3}");
        assert!(
            (0.8..1.25).contains(&ratio),
            "state {i}: Monte-Carlo {:e} vs propagated {:e}",
            mc[(i, i)],
            p[(i, i)]
        );
    }
}

fn bearing_to(ekf: &Ekf, aoa_offset_rad: f64) -> Bearing {
    let pred = predict_bearing(ekf.state(), 0, &ekf.config().body_from_array).expect("generic");
    Bearing {
        ap: 0,
        aoa_rad: pred.aoa_rad + aoa_offset_rad,
        side: pred.side,
        sigma_rad: 1f64.to_radians(),
    }
}

#[test]
fn update_pulls_toward_the_bearing_and_shrinks_the_covariance() {
    let mut ekf =
        Ekf::new(EkfConfig::default(), hover_state(), small_covariance(12)).expect("valid input");
    let before = ekf.covariance().trace();
    let b = bearing_to(&ekf, 0.02);
    let BearingOutcome::Applied { residual_rad, .. } = ekf.update(&b) else {
        panic!("not applied");
    };
    assert!((residual_rad - 0.02).abs() < 1e-12);
    let after = bearing_to(&ekf, 0.0).aoa_rad;
    assert!((b.aoa_rad - after).abs() < 0.02, "moved toward the bearing");
    assert!(ekf.covariance().trace() < before);
    assert!(ekf.covariance().clone().cholesky().is_some());
    assert_eq!(ekf.report().bearings_applied, 1);
}

#[test]
fn bad_bearings_are_rejected_and_counted() {
    let config = EkfConfig {
        mahalanobis_gate: Some(10.83),
        ..EkfConfig::default()
    };
    let mut ekf = Ekf::new(config, hover_state(), small_covariance(12)).expect("valid input");
    let good = bearing_to(&ekf, 0.0);
    let outcomes = [
        ekf.update(&Bearing {
            sigma_rad: 0.0,
            ..good
        }),
        ekf.update(&Bearing { ap: 4, ..good }),
        ekf.update(&Bearing {
            side: match good.side {
                Side::Front => Side::Back,
                Side::Back => Side::Front,
            },
            ..good
        }),
        ekf.update(&Bearing {
            aoa_rad: good.aoa_rad + 0.5,
            ..good
        }),
    ];
    assert!(
        matches!(
            outcomes,
            [
                BearingOutcome::Rejected(BearingRejection::Invalid),
                BearingOutcome::Rejected(BearingRejection::Degenerate(
                    PredictionError::UnknownAp { ap: 4, num_aps: 1 }
                )),
                BearingOutcome::Rejected(BearingRejection::SideMismatch),
                BearingOutcome::Rejected(BearingRejection::Gated { .. }),
            ]
        ),
        "{outcomes:?}"
    );
    let r = ekf.report();
    assert_eq!(
        (
            r.bearings_invalid,
            r.bearings_degenerate,
            r.bearings_side_mismatch,
            r.bearings_gated,
            r.bearings_applied
        ),
        (1, 1, 1, 1, 0)
    );
    assert_eq!(ekf.state(), &hover_state());
}

#[test]
fn ap_at_the_vehicle_is_skipped_without_nans() {
    let mut s = hover_state();
    s.c_in_w[0] = s.p_b_in_w;
    let mut ekf =
        Ekf::new(EkfConfig::default(), s.clone(), small_covariance(12)).expect("valid input");
    let b = Bearing {
        ap: 0,
        aoa_rad: 0.1,
        side: Side::Front,
        sigma_rad: 0.01,
    };
    assert!(matches!(
        ekf.update(&b),
        BearingOutcome::Rejected(BearingRejection::Degenerate(
            PredictionError::ApAtArray { .. }
        ))
    ));
    assert_eq!(ekf.report().bearings_degenerate, 1);
    assert_eq!(ekf.state(), &s);
    // With the array mounted off the IMU, the AP at the IMU is at a finite distance: fine.
    let config = EkfConfig {
        body_from_array: Isometry3::translation(0.1, 0.0, 0.0),
        ..EkfConfig::default()
    };
    let mut ekf = Ekf::new(config, s, small_covariance(12)).expect("valid input");
    let b = Bearing {
        side: Side::Back,
        ..b
    };
    assert!(matches!(ekf.update(&b), BearingOutcome::Applied { .. }));
    assert!(ekf.state().is_finite());
}
