//! Test helpers shared by the nonlinear factors' tests: random states, random preintegrated
//! intervals, central differences through `⊞`, and a relative comparison.

use nalgebra::{Dim, Matrix, RawStorage, SMatrix, SVector, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{NavState, Vec15};
use crate::imu::{ImuBiases, ImuSample, Preintegrated, Preintegrator};
use crate::so3::exp;
use crate::time::Timestamp;

/// Central-difference step along each error-state coordinate.
pub(crate) const STEP: f64 = 1e-6;
/// Relative tolerance of an analytic Jacobian against central differences.
pub(crate) const TOL: f64 = 1e-5;
/// IMU sample period of the random streams, ns (200 Hz).
pub(crate) const PERIOD_NS: i64 = 5_000_000;

/// A uniform draw in `[-1, 1]³`.
pub(crate) fn sym3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(
        2.0 * rng.random::<f64>() - 1.0,
        2.0 * rng.random::<f64>() - 1.0,
        2.0 * rng.random::<f64>() - 1.0,
    )
}

/// A random rotation (up to π about a random axis).
pub(crate) fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
    exp(&(sym3(rng) * 1.8))
}

/// A random keyframe state at `t`: any attitude, position within ±5 m, velocity within ±2 m/s,
/// biases of a consumer IMU.
pub(crate) fn random_state(rng: &mut ChaCha8Rng, t: Timestamp) -> NavState {
    NavState {
        t,
        world_from_body: random_rotation(rng),
        p_b_in_w: sym3(rng) * 5.0,
        v_b_in_w: sym3(rng) * 2.0,
        gyro_bias_rad_s: sym3(rng) * 0.01,
        accel_bias_m_s2: sym3(rng) * 0.1,
    }
}

/// A smooth random IMU stream from `t0` at 200 Hz: a few sinusoids per axis with seeded
/// amplitudes, frequencies and phases, the specific force around the 1 g of hover.
pub(crate) fn random_stream(n: usize, seed: u64, t0: Timestamp) -> Vec<ImuSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let waves: Vec<[(f64, f64, f64); 3]> = (0..6)
        .map(|_| {
            [0; 3].map(|_| {
                (
                    rng.random::<f64>() - 0.5,
                    0.2 + 3.0 * rng.random::<f64>(),
                    std::f64::consts::TAU * rng.random::<f64>(),
                )
            })
        })
        .collect();
    (0..n)
        .map(|i| {
            let t_ns = t0.0 + i as i64 * PERIOD_NS;
            let t = t_ns as f64 * 1e-9;
            let v = |k: usize| -> f64 {
                waves[k]
                    .iter()
                    .map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
                    .sum()
            };
            ImuSample {
                t: Timestamp(t_ns),
                gyro_rad_s: Vector3::new(v(0), v(1), v(2)) * 1.5,
                accel_m_s2: Vector3::new(v(3), v(4), 9.8 + 2.0 * v(5)),
            }
        })
        .collect()
}

/// Preintegrates `samples` (consumer MEMS noise, so the covariance is not zero) with the bias
/// estimate `bias`, from the first sample to the last.
pub(crate) fn integrate(samples: &[ImuSample], bias: ImuBiases) -> Preintegrated {
    let noise = crate::sim::imu::ImuModel::ConsumerMems.noise();
    let mut p = Preintegrator::new(noise, bias);
    let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
        panic!("no samples");
    };
    if samples.len() == 1 {
        p.push(first).unwrap();
        return p.cut(first.t, first).unwrap();
    }
    for s in &samples[..samples.len() - 1] {
        p.push(s).unwrap();
    }
    p.cut(last.t, last).unwrap()
}

/// The linearization bias of [`random_interval`].
pub(crate) fn interval_bias() -> ImuBiases {
    ImuBiases {
        gyro_rad_s: Vector3::new(0.004, -0.003, 0.002),
        accel_m_s2: Vector3::new(0.03, -0.05, 0.02),
    }
}

/// A preintegrated interval of `n` samples of a random stream starting at 10 s, linearized at
/// [`interval_bias`].
pub(crate) fn random_interval(n: usize, seed: u64) -> Preintegrated {
    integrate(
        &random_stream(n, seed, Timestamp(10_000_000_000)),
        interval_bias(),
    )
}

/// Central differences of `f` over a 15-dimensional error state: column `k` is
/// `(f(e_k h) − f(−e_k h)) / 2h`.
pub(crate) fn central_difference<const R: usize>(
    f: impl Fn(&Vec15) -> SVector<f64, R>,
) -> SMatrix<f64, R, 15> {
    central_difference_n(f)
}

/// Central differences of `f` over an `N`-dimensional increment (an error state, an AP's
/// position, a scalar of the border): column `k` is `(f(e_k h) − f(−e_k h)) / 2h`. Every
/// factor's Jacobian test goes through this one helper.
pub(crate) fn central_difference_n<const N: usize, const R: usize>(
    f: impl Fn(&SVector<f64, N>) -> SVector<f64, R>,
) -> SMatrix<f64, R, N> {
    let mut out = SMatrix::<f64, R, N>::zeros();
    for k in 0..N {
        let mut d = SVector::<f64, N>::zeros();
        d[k] = STEP;
        let col = (f(&d) - f(&-d)) / (2.0 * STEP);
        out.set_column(k, &col);
    }
    out
}

/// Asserts `|fd − an| ≤ TOL·(|an| + 10⁻³·max|an|) + 10⁻⁹` entry by entry.
pub(crate) fn assert_close<R1, C1, S1, R2, C2, S2>(
    fd: &Matrix<f64, R1, C1, S1>,
    an: &Matrix<f64, R2, C2, S2>,
    label: &str,
) where
    R1: Dim,
    C1: Dim,
    S1: RawStorage<f64, R1, C1>,
    R2: Dim,
    C2: Dim,
    S2: RawStorage<f64, R2, C2>,
{
    assert_eq!(fd.shape(), an.shape(), "{label}: shapes");
    let scale = an.amax();
    let rows = an.nrows();
    for (i, (a, b)) in fd.iter().zip(an.iter()).enumerate() {
        let tol = TOL * (b.abs() + 1e-3 * scale) + 1e-9;
        assert!(
            (a - b).abs() <= tol,
            "{label}: entry ({}, {}): finite difference {a} vs analytic {b}",
            i % rows,
            i / rows
        );
    }
}
