//! Observability of the Sec. III model (paper `eqn:nullspace`), through the EKF's own Jacobians:
//! at the true states the observability matrix has the 4-dimensional nullspace of global
//! translation and rotation about gravity; at estimates it loses the rotation (spurious yaw
//! information); flying straight at the AP adds unobservable directions.

use nalgebra::{DMatrix, DVector, Isometry3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::FRAC_PI_2;

use wins::aoa::steering::aoa_rad;
use wins::fusion::bearing::{Bearing, side_of};
use wins::fusion::paper::ekf::{Ekf, EkfConfig, EkfState};
use wins::fusion::paper::observability::{
    LinearizationPoint, Spectrum, gravity_rotation_nullspace, nullspace_residual,
    observability_matrix, propagate_states, translation_nullspace,
};
use wins::imu::ImuSample;
use wins::sim::imu::ImuModel;
use wins::sim::motion::STANDARD_GRAVITY_M_S2;
use wins::sim::{Scenario, simulate};
use wins::time::Timestamp;

const IMU_RATE_HZ: f64 = 100.0;
/// One bearing every this many IMU samples (20 Hz).
const BEARING_EVERY: usize = 5;
/// Flight length of the observability runs, s.
const FLIGHT_S: f64 = 20.0;
/// `‖O·N‖ / (‖O‖·‖N‖)` below which `N` counts as in the nullspace.
const NULLSPACE_TOLERANCE: f64 = 1e-9;
/// Singular values below this fraction of the largest count as zero.
const RANK_TOLERANCE: f64 = 1e-10;

/// The paper's Sec. III setting: the array at the IMU.
fn config() -> EkfConfig {
    EkfConfig {
        body_from_array: Isometry3::identity(),
        ..EkfConfig::default()
    }
}

/// The paper's circle (noise-free IMU) from the simulator: its first state and IMU samples.
fn circle() -> (EkfState, Vec<ImuSample>) {
    let mut s = Scenario::built_in("paper-circle")
        .expect("built in")
        .airborne();
    s.duration_s = FLIGHT_S;
    s.imu.rate_hz = IMU_RATE_HZ;
    s.imu.model = ImuModel::Ideal;
    s.radio.packet_rate_hz = 0.1;
    let out = simulate(&s, &mut |_| {}).expect("valid scenario");
    let (t, b) = out.states[0];
    let x0 = EkfState {
        t,
        world_from_body: b.world_from_body,
        v_b_in_w: b.v_b_in_w,
        p_b_in_w: b.p_b_in_w,
        c_in_w: vec![Vector3::from(out.aps[0].config.position_m)],
    };
    (x0, out.imu)
}

/// Straight at the AP: level, facing it (yaw π, the AP along −x), starting at rest 10 m away and
/// speeding up and slowing down along the line of sight with world acceleration
/// `−A·sin(ωt)·e_x` (speed `A(1 − cos ωt)/ω`, never backwards); ends about 2.5 m from the AP.
fn toward_the_ap() -> (EkfState, Vec<ImuSample>, Vector3<f64>) {
    let n = (FLIGHT_S * IMU_RATE_HZ) as usize + 1;
    let (amplitude, omega) = (0.3, 0.8);
    let world_from_body = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::PI);
    let imu = (0..n)
        .map(|k| {
            let t_s = k as f64 / IMU_RATE_HZ;
            let a_in_w = Vector3::new(-amplitude * (omega * t_s).sin(), 0.0, 0.0);
            ImuSample {
                t: Timestamp((t_s * 1e9).round() as i64),
                gyro_rad_s: Vector3::zeros(),
                accel_m_s2: world_from_body
                    .inverse_transform_vector(&(a_in_w + Vector3::z() * STANDARD_GRAVITY_M_S2)),
            }
        })
        .collect();
    let x0 = EkfState {
        t: Timestamp(0),
        world_from_body,
        v_b_in_w: Vector3::zeros(),
        p_b_in_w: Vector3::new(11.0, 4.0, 1.5),
        c_in_w: vec![Vector3::new(1.0, 4.0, 1.5)],
    };
    (x0, imu, -Vector3::x())
}

/// Linearization at the true states: the initial state propagated by the EKF's own discrete
/// model (so `Φ` is consistent), a bearing every [`BEARING_EVERY`] samples.
fn at_truth(x0: &EkfState, imu: &[ImuSample]) -> Vec<LinearizationPoint> {
    let states = propagate_states(&config(), x0, imu).expect("increasing IMU times");
    states
        .into_iter()
        .zip(imu)
        .enumerate()
        .map(|(i, (x, u))| LinearizationPoint::at(x, *u, observed(i)))
        .collect()
}

fn observed(i: usize) -> Vec<usize> {
    if i.is_multiple_of(BEARING_EVERY) {
        vec![0]
    } else {
        vec![]
    }
}

fn print_spectrum(label: &str, s: &Spectrum) {
    let rel: Vec<String> = (1..=s.singular_values.len())
        .map(|k| format!("{:.1e}", s.relative(k)))
        .collect();
    eprintln!("{label}: σ_k/σ_1 = [{}]", rel.join(", "));
}

/// Each linearization point independently perturbed (attitude σ `att_rad`, velocity `vel`,
/// positions `pos`): Jacobians at estimates that are not one consistent trajectory.
fn perturbed(
    points: &[LinearizationPoint],
    att_rad: f64,
    vel: f64,
    pos: f64,
    seed: u64,
) -> Vec<LinearizationPoint> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let unit = Normal::new(0.0, 1.0).expect("valid σ");
    let mut noise = |x: &EkfState| {
        let dx = DVector::from_iterator(
            x.error_dim(),
            (0..x.error_dim()).map(|i| {
                let sigma = match i {
                    0..3 => att_rad,
                    3..6 => vel,
                    _ => pos,
                };
                sigma * unit.sample(&mut rng)
            }),
        );
        x.boxplus(&dx)
    };
    points
        .iter()
        .map(|p| {
            let x = noise(&p.measure_at);
            LinearizationPoint::at(x, p.imu, p.observed_aps.clone())
        })
        .collect()
}

/// Linearization as a real EKF does it, on the circle with the paper's noise (IMU σ 0.01 per
/// sample, bearings 1°): `H_k` at the prior, `Φ_{k+1,k}` at the posterior.
fn ekf_linearization(
    x0: &EkfState,
    imu: &[ImuSample],
    seed: u64,
) -> (EkfConfig, Vec<LinearizationPoint>) {
    let truth = propagate_states(&config(), x0, imu).expect("increasing IMU times");
    let mut imu_rng = ChaCha8Rng::seed_from_u64(seed);
    let mut aoa_rng = ChaCha8Rng::seed_from_u64(seed ^ 0xB0A0);
    let sigma_per_sample = 0.01;
    let imu_noise = Normal::new(0.0, sigma_per_sample).expect("valid σ");
    let aoa_sigma_rad = 1f64.to_radians();
    let aoa_noise = Normal::new(0.0, aoa_sigma_rad).expect("valid σ");
    let density = sigma_per_sample / IMU_RATE_HZ.sqrt();
    let config = EkfConfig {
        gyro_noise_density_rad_s_sqrt_hz: density,
        accel_noise_density_m_s2_sqrt_hz: density,
        ..config()
    };
    let p0 = DMatrix::from_diagonal(&DVector::from_iterator(
        12,
        [1e-3, 1e-2, 1e-2, 1e-2].iter().flat_map(|s| [s * s; 3]),
    ));
    let mut ekf = Ekf::new(config.clone(), x0.clone(), p0).expect("valid initial state");
    let mut points = Vec::with_capacity(imu.len());
    for (i, (u, x)) in imu.iter().zip(&truth).enumerate() {
        let mut noise = || Vector3::from_fn(|_, _| imu_noise.sample(&mut imu_rng));
        let noisy = ImuSample {
            t: u.t,
            gyro_rad_s: u.gyro_rad_s + noise(),
            accel_m_s2: u.accel_m_s2 + noise(),
        };
        ekf.propagate(&noisy);
        let prior = ekf.state().clone();
        let observed_aps = observed(i);
        if !observed_aps.is_empty() {
            // Array at the IMU: the AP direction in `a` is the one in `b`.
            let d = x
                .world_from_body
                .inverse_transform_vector(&(x.c_in_w[0] - x.p_b_in_w));
            let aoa = aoa_rad(&d) + aoa_noise.sample(&mut aoa_rng);
            ekf.update(&Bearing {
                ap: 0,
                aoa_rad: aoa.clamp(-FRAC_PI_2, FRAC_PI_2),
                side: side_of(&d),
                sigma_rad: aoa_sigma_rad,
            });
        }
        points.push(LinearizationPoint {
            imu: noisy,
            propagate_at: ekf.state().clone(),
            measure_at: prior,
            observed_aps,
        });
    }
    assert_eq!(
        ekf.report().bearings_applied,
        imu.len().div_ceil(BEARING_EVERY)
    );
    (config, points)
}

/// `N_r` at a point as a one-column matrix.
fn n_r(state: &EkfState) -> DMatrix<f64> {
    let n = gravity_rotation_nullspace(state);
    DMatrix::from_column_slice(n.len(), 1, n.as_slice())
}

/// `‖N − V·Vᵀ·N‖ / ‖N‖` with `V` the right singular vectors of the `k` smallest singular values:
/// 0 when `N` lies in their span.
fn outside_smallest_subspace(s: &Spectrum, k: usize, n: &DMatrix<f64>) -> f64 {
    let cols = s.right_singular_vectors.ncols();
    let v = s.right_singular_vectors.columns(cols - k, k);
    (n - v * (v.transpose() * n)).norm() / n.norm()
}

/// Paper `eqn:nullspace`: at the true states `O·N_t = 0`, `O·N_r = 0`, and rank O = 12 − 4 = 8,
/// with a clear gap (measured on the circle: σ_8/σ_1 ≈ 1e-5, σ_9/σ_1 ≈ 1e-29). Holds for the
/// paper's array-at-the-IMU and for an offset, rotated array alike.
#[test]
fn true_states_leave_translation_and_yaw_unobservable() {
    let (x0, imu) = circle();
    let points = at_truth(&x0, &imu);
    let offset = EkfConfig {
        body_from_array: Isometry3::new(
            Vector3::new(0.03, -0.02, 0.08),
            Vector3::new(0.1, -0.2, 0.3),
        ),
        ..config()
    };
    for (label, config) in [("array at the IMU", config()), ("offset array", offset)] {
        let o = observability_matrix(&config, &points).expect("generic geometry");
        let n_t = translation_nullspace(1);
        let n_r = n_r(&x0);
        let (res_t, res_r) = (nullspace_residual(&o, &n_t), nullspace_residual(&o, &n_r));
        let s = Spectrum::of(&o).expect("finite");
        eprintln!(
            "circle at the truth, {label}: ‖O·N_t‖ {res_t:.1e}, ‖O·N_r‖ {res_r:.1e} (relative)"
        );
        print_spectrum(&format!("circle at the truth, {label}"), &s);
        assert_eq!(o.shape(), (imu.len().div_ceil(BEARING_EVERY), 12));
        assert!(
            res_t < NULLSPACE_TOLERANCE && res_r < NULLSPACE_TOLERANCE,
            "{res_t:e} {res_r:e}"
        );
        assert_eq!(s.rank(RANK_TOLERANCE), 8);
        assert!(
            s.relative(8) > 1e4 * RANK_TOLERANCE,
            "gap: σ_8/σ_1 = {:e}",
            s.relative(8)
        );
        // The numerical nullspace is exactly [N_t | N_r].
        let mut n = DMatrix::zeros(12, 4);
        n.columns_mut(0, 3).copy_from(&n_t);
        n.column_mut(3).copy_from(&n_r.column(0));
        let outside = outside_smallest_subspace(&s, 4, &n);
        assert!(outside < 1e-6, "{outside:e}");
    }
}

/// Paper Sec. III: at estimates, `O(x̂)·N_t = 0` still (it does not depend on the linearization
/// point) but `O(x̂)·N̂_r ≠ 0` and the rank rises to 9: the filter gains spurious information
/// about yaw. Both for independently perturbed states (attitude 0.1°, velocity 1 cm/s,
/// positions 1 cm) and for the prior/posterior pairs of an actual EKF run with the paper's noise.
#[test]
fn estimates_gain_spurious_yaw_information() {
    let (x0, imu) = circle();
    let truth = at_truth(&x0, &imu);
    let perturbed = perturbed(&truth, 0.1f64.to_radians(), 0.01, 0.01, 3);
    let (ekf_config, ekf_points) = ekf_linearization(&x0, &imu, 5);
    for (label, config, points) in [
        ("perturbed states", config(), perturbed),
        ("EKF prior/posterior", ekf_config, ekf_points),
    ] {
        let o = observability_matrix(&config, &points).expect("generic geometry");
        let res_t = nullspace_residual(&o, &translation_nullspace(1));
        let res_r = nullspace_residual(&o, &n_r(&points[0].measure_at));
        let s = Spectrum::of(&o).expect("finite");
        eprintln!("circle, {label}: ‖O·N_t‖ {res_t:.1e}, ‖O·N̂_r‖ {res_r:.1e} (relative)");
        print_spectrum(&format!("circle, {label}"), &s);
        assert!(res_t < NULLSPACE_TOLERANCE, "{res_t:e}");
        assert!(res_r > 1e-6, "N̂_r still unobservable: {res_r:e}");
        assert_eq!(s.rank(RANK_TOLERANCE), 9);
        assert!(
            s.relative(9) > 1e4 * RANK_TOLERANCE,
            "σ_9/σ_1 = {:e}",
            s.relative(9)
        );
        // What is left unobservable is the translation.
        let outside = outside_smallest_subspace(&s, 3, &translation_nullspace(1));
        assert!(outside < 1e-6, "{outside:e}");
    }
}

/// Paper Sec. III: moving along the line to the AP, the bearings do not change, and the position
/// and velocity along that line become unobservable. Measured: rank O drops from 8 (circle) to 3:
/// besides the line-of-sight position and velocity, a level flight at the AP's height also hides
/// the vertical position, vertical velocity and pitch (the cone angle is flat in elevation at
/// zero elevation, and no rotation or turn mixes them in).
#[test]
fn flying_straight_at_the_ap_adds_unobservable_directions() {
    let (x0, imu) = circle();
    let circle_o = observability_matrix(&config(), &at_truth(&x0, &imu)).expect("generic");
    let circle_s = Spectrum::of(&circle_o).expect("finite");
    let (x0, imu, line_of_sight) = toward_the_ap();
    let toward_o = observability_matrix(&config(), &at_truth(&x0, &imu)).expect("generic");
    let toward_s = Spectrum::of(&toward_o).expect("finite");
    print_spectrum("toward the AP, truth", &toward_s);
    let (circle_8, toward_8) = (circle_s.relative(8), toward_s.relative(8));
    eprintln!(
        "smallest non-gauge σ_8/σ_1: circle {circle_8:.1e}, toward the AP {toward_8:.1e}; \
         rank {} vs {}",
        circle_s.rank(RANK_TOLERANCE),
        toward_s.rank(RANK_TOLERANCE)
    );
    assert!(circle_8 > 1e-6, "{circle_8:e}");
    assert!(toward_8 < 1e-12, "{toward_8:e}");
    assert_eq!(toward_s.rank(RANK_TOLERANCE), 3);
    // Position and velocity along the line of sight: unobservable here, observable on the circle.
    for offset in [6, 3] {
        let mut d = DMatrix::zeros(12, 1);
        d.view_mut((offset, 0), (3, 1)).copy_from(&line_of_sight);
        let (toward, circle) = (
            nullspace_residual(&toward_o, &d),
            nullspace_residual(&circle_o, &d),
        );
        eprintln!(
            "line-of-sight direction at error-state offset {offset}: ‖O·d‖ toward {toward:.1e}, circle {circle:.1e}"
        );
        assert!(toward < NULLSPACE_TOLERANCE, "{toward:e}");
        assert!(circle > 1e-6, "{circle:e}");
    }
}
