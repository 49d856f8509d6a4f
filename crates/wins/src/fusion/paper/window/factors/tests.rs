//! Finite-difference checks of the window factors' Jacobians, gyro-bias columns included.

use nalgebra::{Isometry3, Matrix3, SVector, Translation3, UnitQuaternion, Vector3};

use super::*;
use crate::fusion::bearing::{Bearing, Side};
use crate::imu::{ImuBiases, ImuSample, Preintegrator};
use crate::rig::ImuNoise;
use crate::so3::exp;
use crate::time::Timestamp;

const H: f64 = 1e-6;

fn rot(x: f64, y: f64, z: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(x, y, z)
}

fn psi() -> Matrix3<f64> {
    Matrix3::new(4.0, 0.3, -0.2, 0.1, 3.5, 0.4, -0.3, 0.2, 4.2)
}

/// A row's direction in `b_j` and the value it should take.
type Target = (Vector3<f64>, f64);

#[test]
fn aoa_rows_match_finite_differences_of_the_angle() {
    let r_hat = rot(0.1, -0.05, 0.7);
    let psi = psi();
    let b_hat = Vector3::new(0.002, -0.001, 0.003);
    let up = Vector3::new(0.05, -0.03, 1.0);
    let body_from_array =
        Isometry3::from_parts(Translation3::new(0.1, 0.05, -0.02), rot(0.0, 0.0, 0.2));
    let bearing = Bearing {
        ap: 0,
        aoa_rad: 0.4,
        side: Side::Front,
        sigma_rad: 0.03,
    };
    let (u, up_unit, ..) = horizontal_direction(&bearing, &up, &body_from_array).unwrap();
    let dirs_b = [up_unit.cross(&u), up_unit];
    let t = body_from_array.translation.vector;
    let (c, p) = (Vector3::new(4.0, 2.0, 0.5), Vector3::new(0.3, -0.4, 0.1));
    let x_hat = c - p - r_hat * t;
    let sigmas = AoaSigmas {
        attitude_rad: 0.005,
        elevation_rad: 0.08,
        cone: false,
    };
    let input = AoaFactorInput {
        bearing: &bearing,
        b0_from_bj: &r_hat,
        up_in_bj: &up,
        body_from_array: &body_from_array,
        point: AoaPoint::At(x_hat),
        gyro: Some((&psi, &b_hat)),
        sigmas,
    };
    // The horizontal model's two angle rows, then the cone row `âᵀ x / |x| = sin θ`.
    let axis = body_from_array.rotation * Vector3::y();
    let models: [(bool, Vec<Target>); 2] = [
        (false, vec![(dirs_b[0], 0.0), (dirs_b[1], 0.0)]),
        (true, vec![(axis, bearing.aoa_rad.sin())]),
    ];
    for (cone, dirs) in models {
        let rows = aoa_rows(&AoaFactorInput {
            sigmas: AoaSigmas { cone, ..sigmas },
            ..input
        })
        .unwrap();
        assert_eq!(rows.as_slice().len(), dirs.len());
        // The residual of row i at (c, p, b_g).
        let angle = |i: usize, c: Vector3<f64>, p: Vector3<f64>, b: Vector3<f64>| {
            let r = r_hat * exp(&(psi * (b - b_hat)));
            let x = c - p - r * t;
            (r * dirs[i].0).dot(&x) / x.norm() - dirs[i].1
        };
        // The residuals alone (the lost test's) are the angles at the point, with the rows' σ.
        let (residuals, len) = aoa_residuals(&AoaFactorInput {
            sigmas: AoaSigmas { cone, ..sigmas },
            ..input
        })
        .unwrap();
        assert_eq!(len, dirs.len());
        for (i, ((e, var), row)) in residuals.iter().zip(rows.as_slice()).enumerate() {
            assert!(
                (e - angle(i, c, p, b_hat)).abs() < 1e-12,
                "cone {cone} row {i}"
            );
            assert_eq!(*var, row.var);
        }
        for (i, row) in rows.as_slice().iter().enumerate() {
            let lin = |c: Vector3<f64>, p: Vector3<f64>, b: Vector3<f64>| {
                row.j.dot(&(c - p)) + row.g.dot(&b) - row.y
            };
            assert!((lin(c, p, b_hat) - angle(i, c, p, b_hat)).abs() < 1e-12);
            for a in 0..3 {
                let e = Vector3::ith(a, H);
                let fd_c = (angle(i, c + e, p, b_hat) - angle(i, c - e, p, b_hat)) / (2.0 * H);
                let fd_p = (angle(i, c, p + e, b_hat) - angle(i, c, p - e, b_hat)) / (2.0 * H);
                let fd_b = (angle(i, c, p, b_hat + e) - angle(i, c, p, b_hat - e)) / (2.0 * H);
                assert!(
                    (fd_c - row.j[a]).abs() < 1e-7,
                    "cone {cone} row {i} c{a}: {fd_c} vs {}",
                    row.j[a]
                );
                assert!((fd_p + row.j[a]).abs() < 1e-7, "cone {cone} row {i} p{a}");
                assert!(
                    (fd_b - row.g[a]).abs() < 1e-6,
                    "cone {cone} row {i} b{a}: {fd_b} vs {}",
                    row.g[a]
                );
            }
        }
    }
    // Without a point the rows are the algebraic ones and ignore the gyro bias.
    let algebraic = aoa_rows(&AoaFactorInput {
        point: AoaPoint::Range(5.0),
        ..input
    })
    .unwrap();
    assert_eq!(algebraic.as_slice()[0].g, Vector3::zeros());
    let no_point = AoaFactorInput {
        point: AoaPoint::Range(5.0),
        ..input
    };
    assert!(aoa_residuals(&no_point).is_none());
    assert!((algebraic.as_slice()[0].j - r_hat * dirs_b[0] / 5.0).norm() < 1e-15);
}

/// A preintegrated second of rotating, accelerating motion with zero noise.
fn interval() -> Preintegrated {
    let noise = ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: 1e-4,
        gyro_bias_random_walk_rad_s2_sqrt_hz: 0.0,
        gyro_turn_on_bias_rad_s: 0.0,
        accel_noise_density_m_s2_sqrt_hz: 1e-3,
        accel_bias_random_walk_m_s3_sqrt_hz: 0.0,
        accel_turn_on_bias_m_s2: 0.0,
    };
    let mut pre = Preintegrator::new(noise, ImuBiases::zero());
    let sample = |i: i64| {
        let s = i as f64 * 0.005;
        ImuSample {
            t: Timestamp(i * 5_000_000),
            gyro_rad_s: Vector3::new(0.3 * s.sin(), -0.2, 0.8 * s.cos()),
            accel_m_s2: Vector3::new(1.0 + s, -0.5 * s, 9.81 - 0.3 * s),
        }
    };
    for i in 0..200 {
        pre.push(&sample(i)).unwrap();
    }
    pre.cut(Timestamp(200 * 5_000_000), &sample(200)).unwrap()
}

#[test]
fn imu_rows_match_finite_differences_of_the_model() {
    let pre = interval();
    let dt = pre.dt_s();
    let r_hat = rot(0.2, 0.1, -0.6);
    let psi = psi();
    let b_hat = Vector3::new(0.0, 0.0, 0.0);
    // A linearization point: frame k, frame k+1 (p in b0, v and g in their own frames).
    let x_k: SVector<f64, 9> =
        SVector::from_column_slice(&[0.1, 0.2, 0.0, 1.0, -0.5, 0.2, 0.3, -0.2, 9.8]);
    let x_l: SVector<f64, 9> =
        SVector::from_column_slice(&[1.2, 0.1, 0.3, 0.8, -0.1, 0.4, 0.25, 0.1, 9.79]);
    let rows = imu_rows(&ImuFactorInput {
        pre: &pre,
        b0_from_bk: &r_hat,
        gyro_bias_rad_s: b_hat,
        psi_k: Some((psi, b_hat)),
        v_next: x_l.fixed_rows::<3>(3).into_owned(),
        g_next: x_l.fixed_rows::<3>(6).into_owned(),
        step_in_b0: (x_l - x_k).fixed_rows::<3>(0).into_owned(),
        attitude_sigma_rad: 0.0,
    });
    // `eqn:imumodel` with R_k(b_g) and α, β, ΔR at the bias b = [b_a, b_g].
    let model = |x_k: &SVector<f64, 9>, x_l: &SVector<f64, 9>, b: &SVector<f64, 6>| {
        let b_g = b.fixed_rows::<3>(3).into_owned();
        let (alpha, beta, d_r) = pre.corrected(&ImuBiases {
            accel_m_s2: b.fixed_rows::<3>(0).into_owned(),
            gyro_rad_s: b_g,
        });
        let r_k = r_hat * exp(&(psi * (b_g - b_hat)));
        let (p_k, v_k, g_k) = (
            x_k.fixed_rows::<3>(0),
            x_k.fixed_rows::<3>(3),
            x_k.fixed_rows::<3>(6),
        );
        let (p_l, v_l, g_l) = (
            x_l.fixed_rows::<3>(0),
            x_l.fixed_rows::<3>(3),
            x_l.fixed_rows::<3>(6),
        );
        let mut e = SVector::<f64, 9>::zeros();
        e.fixed_rows_mut::<3>(0)
            .copy_from(&(r_k.inverse() * (p_l - p_k) - v_k * dt + g_k * (0.5 * dt * dt) - alpha));
        e.fixed_rows_mut::<3>(3)
            .copy_from(&(d_r * v_l - v_k + g_k * dt - beta));
        e.fixed_rows_mut::<3>(6).copy_from(&(d_r * g_l - g_k));
        e
    };
    let lin = |x_k: &SVector<f64, 9>, x_l: &SVector<f64, 9>, b: &SVector<f64, 6>| {
        rows.a_k * x_k + rows.a_l * x_l + rows.a_b * b - rows.z
    };
    let mut b0 = SVector::<f64, 6>::zeros();
    b0.fixed_rows_mut::<3>(3).copy_from(&b_hat);
    assert!((lin(&x_k, &x_l, &b0) - model(&x_k, &x_l, &b0)).norm() < 1e-9);
    for a in 0..9 {
        let e = SVector::<f64, 9>::ith(a, H);
        let fd_k = (model(&(x_k + e), &x_l, &b0) - model(&(x_k - e), &x_l, &b0)) / (2.0 * H);
        let fd_l = (model(&x_k, &(x_l + e), &b0) - model(&x_k, &(x_l - e), &b0)) / (2.0 * H);
        assert!((fd_k - rows.a_k.column(a)).norm() < 1e-6, "x_k {a}");
        assert!((fd_l - rows.a_l.column(a)).norm() < 1e-6, "x_l {a}");
    }
    for a in 0..6 {
        let e = SVector::<f64, 6>::ith(a, H);
        let fd = (model(&x_k, &x_l, &(b0 + e)) - model(&x_k, &x_l, &(b0 - e))) / (2.0 * H);
        assert!(
            (fd - rows.a_b.column(a)).norm() < 1e-5 * (1.0 + fd.norm()),
            "bias {a}: {fd} vs {}",
            rows.a_b.column(a)
        );
    }
}
