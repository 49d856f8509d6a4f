//! IMU propagation of the nominal state and of the error state between two IMU samples.
//!
//! Mid-point integration of the samples `u_0 = (ω_0, f_0)` at the start and `u_1 = (ω_1, f_1)` at
//! the end of an interval `Δt` (world `w` z up, gravity `g` pointing down, `f` the specific force):
//!
//! ```text
//! ΔR  = Exp(½(ω_0 + ω_1)·Δt)
//! f̄   = ½(f_0 + ΔR·f_1)                  mean specific force, in b at the start
//! a   = R·f̄ − g·e_z
//! R⁺  = R·ΔR,  v⁺ = v + a·Δt,  p⁺ = p + v·Δt + ½·a·Δt²,  c⁺ = c
//! ```
//!
//! Its exact Jacobian in the body-side error state (`R = R̂·Exp(δθ)`), the `F` of the paper's
//! `Φ_{k+1,k}` (the AP block is the identity):
//!
//! ```text
//! δθ⁺ = ΔRᵀ·δθ
//! δv⁺ = δv − R̂[f̄]×Δt·δθ
//! δp⁺ = δp + Δt·δv − ½R̂[f̄]×Δt²·δθ
//! ```
//!
//! Noise (docs/DESIGN.md §2): white noise of density σ_c averaged over Δt has variance σ_c²/Δt (the
//! per-sample σ_d = σ_c/√Δt); it enters δθ as `n_g·Δt`, δv as `R̂·n_a·Δt` and δp as `½R̂·n_a·Δt²`.

use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3};

use super::state::{ATTITUDE, CORE_DIM, EkfState, POSITION, VELOCITY};
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// A 9 × 9 matrix over the vehicle error state (δθ, δv, δp).
pub type Matrix9 = SMatrix<f64, CORE_DIM, CORE_DIM>;

/// One propagation interval: what the two IMU samples say about it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuStep {
    /// End of the interval.
    pub t_end: Timestamp,
    /// Length of the interval, s (> 0).
    pub dt_s: f64,
    /// Body rotation over the interval, `ΔR = R_{b_k b_{k+1}} = Exp(½(ω_0 + ω_1)·Δt)`.
    pub delta_r: UnitQuaternion<f64>,
    /// Mean specific force over the interval in the body frame at its start, `f̄`, m/s².
    pub f_mean_in_b: Vector3<f64>,
}

impl ImuStep {
    /// The interval from `start` to `to.t`, with `from` the sample at (or held since) `start`.
    /// `None` unless `to.t > start`.
    pub fn new(from: &ImuSample, to: &ImuSample, start: Timestamp) -> Option<Self> {
        if to.t <= start {
            return None;
        }
        let dt_s = to.t.secs_since(start);
        let omega_mean = 0.5 * (from.gyro_rad_s + to.gyro_rad_s);
        let delta_r = UnitQuaternion::from_scaled_axis(omega_mean * dt_s);
        let f_mean_in_b = 0.5 * (from.accel_m_s2 + delta_r * to.accel_m_s2);
        Some(Self {
            t_end: to.t,
            dt_s,
            delta_r,
            f_mean_in_b,
        })
    }

    /// World acceleration of the body over the interval from attitude `world_from_body` at the
    /// start: `a = R·f̄ − g·e_z`, m/s².
    fn acceleration_in_w(
        &self,
        world_from_body: &UnitQuaternion<f64>,
        gravity_m_s2: f64,
    ) -> Vector3<f64> {
        world_from_body * self.f_mean_in_b - Vector3::z() * gravity_m_s2
    }

    /// The nominal state at the end of the interval (module doc), time set to `t_end`.
    pub fn propagate(&self, state: &EkfState, gravity_m_s2: f64) -> EkfState {
        let dt = self.dt_s;
        let a = self.acceleration_in_w(&state.world_from_body, gravity_m_s2);
        EkfState {
            t: self.t_end,
            world_from_body: state.world_from_body * self.delta_r,
            v_b_in_w: state.v_b_in_w + a * dt,
            p_b_in_w: state.p_b_in_w + state.v_b_in_w * dt + 0.5 * a * dt * dt,
            c_in_w: state.c_in_w.clone(),
        }
    }

    /// `F`: the Jacobian of [`ImuStep::propagate`] in the vehicle error state (δθ, δv, δp),
    /// evaluated at `state` (module doc). The AP block of `Φ` is the identity.
    pub fn jacobian(&self, state: &EkfState) -> Matrix9 {
        let dt = self.dt_s;
        let r = state.world_from_body.to_rotation_matrix().into_inner();
        let r_f = r * self.f_mean_in_b.cross_matrix();
        let mut f = Matrix9::identity();
        f.fixed_view_mut::<3, 3>(ATTITUDE, ATTITUDE)
            .copy_from(&self.delta_r.to_rotation_matrix().into_inner().transpose());
        f.fixed_view_mut::<3, 3>(VELOCITY, ATTITUDE)
            .copy_from(&(-r_f * dt));
        f.fixed_view_mut::<3, 3>(POSITION, ATTITUDE)
            .copy_from(&(-0.5 * r_f * dt * dt));
        f.fixed_view_mut::<3, 3>(POSITION, VELOCITY)
            .copy_from(&(Matrix3::identity() * dt));
        f
    }

    /// `Q`: covariance of the vehicle error state added over the interval by white gyro and
    /// accelerometer noise of continuous densities `gyro_density_rad_s_sqrt_hz` and
    /// `accel_density_m_s2_sqrt_hz` (module doc; isotropic, so it does not depend on `R̂`).
    pub fn process_noise(
        &self,
        gyro_density_rad_s_sqrt_hz: f64,
        accel_density_m_s2_sqrt_hz: f64,
    ) -> Matrix9 {
        let dt = self.dt_s;
        // Variance of the interval mean of continuous white noise: σ_c²/Δt.
        let var_g = gyro_density_rad_s_sqrt_hz.powi(2) / dt;
        let var_a = accel_density_m_s2_sqrt_hz.powi(2) / dt;
        let i3 = Matrix3::<f64>::identity();
        let mut q = Matrix9::zeros();
        q.fixed_view_mut::<3, 3>(ATTITUDE, ATTITUDE)
            .copy_from(&(i3 * var_g * dt * dt));
        q.fixed_view_mut::<3, 3>(VELOCITY, VELOCITY)
            .copy_from(&(i3 * var_a * dt * dt));
        let vp = i3 * var_a * 0.5 * dt.powi(3);
        q.fixed_view_mut::<3, 3>(VELOCITY, POSITION).copy_from(&vp);
        q.fixed_view_mut::<3, 3>(POSITION, VELOCITY).copy_from(&vp);
        q.fixed_view_mut::<3, 3>(POSITION, POSITION)
            .copy_from(&(i3 * var_a * 0.25 * dt.powi(4)));
        q
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    const G: f64 = 9.806_65;

    fn sample(t_ns: i64, gyro: [f64; 3], accel: [f64; 3]) -> ImuSample {
        ImuSample {
            t: Timestamp(t_ns),
            gyro_rad_s: Vector3::from(gyro),
            accel_m_s2: Vector3::from(accel),
        }
    }

    fn state(rpy: [f64; 3]) -> EkfState {
        EkfState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
            v_b_in_w: Vector3::new(1.2, -0.4, 0.3),
            p_b_in_w: Vector3::new(6.0, 4.0, 1.5),
            c_in_w: vec![Vector3::new(1.0, 4.0, 1.5)],
        }
    }

    /// Central differences of the propagation, perturbing body-side (`x ⊞ ε·e_i`).
    fn numeric_jacobian(step: &ImuStep, x: &EkfState) -> Matrix9 {
        let eps = 1e-6;
        let mut j = Matrix9::zeros();
        for i in 0..CORE_DIM {
            let mut dx = DVector::zeros(x.error_dim());
            dx[i] = eps;
            let plus = step.propagate(&x.boxplus(&dx), G);
            let minus = step.propagate(&x.boxplus(&(-&dx)), G);
            let reference = step.propagate(x, G);
            let d = (plus.boxminus(&reference) - minus.boxminus(&reference)) / (2.0 * eps);
            // The AP block must not move.
            assert!(d.rows(CORE_DIM, d.len() - CORE_DIM).norm() < 1e-12);
            for r in 0..CORE_DIM {
                j[(r, i)] = d[r];
            }
        }
        j
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let cases = [
            // A generic turn, 100 Hz.
            (
                [0.1, -0.2, 2.0],
                sample(0, [0.3, -0.2, 0.5], [0.5, -0.3, 9.9]),
                sample(10_000_000, [0.35, -0.1, 0.45], [0.6, -0.2, 9.7]),
            ),
            // Zero rotation, at rest.
            (
                [0.0, 0.0, 0.0],
                sample(0, [0.0; 3], [0.0, 0.0, G]),
                sample(5_000_000, [0.0; 3], [0.0, 0.0, G]),
            ),
            // A fast spin over a long interval (large ΔR), upside down.
            (
                [3.0, 0.4, -1.0],
                sample(0, [4.0, -3.0, 2.0], [2.0, 1.0, -9.0]),
                sample(100_000_000, [3.5, -2.5, 2.5], [1.0, 2.0, -8.0]),
            ),
            // A tiny interval (1 µs).
            (
                [0.2, 0.1, -0.3],
                sample(0, [0.1, 0.2, 0.3], [0.1, 0.2, 9.8]),
                sample(1_000, [0.1, 0.2, 0.3], [0.1, 0.2, 9.8]),
            ),
        ];
        for (rpy, u0, u1) in cases {
            let x = state(rpy);
            let step = ImuStep::new(&u0, &u1, u0.t).expect("positive interval");
            let analytic = step.jacobian(&x);
            let numeric = numeric_jacobian(&step, &x);
            let err = (analytic - numeric).abs().max();
            assert!(
                err < 1e-7,
                "max |F − F_num| = {err:e}\n{analytic}\n{numeric}"
            );
        }
    }

    #[test]
    fn noise_is_the_discretized_density() {
        let u = sample(0, [0.0; 3], [0.0, 0.0, G]);
        let u1 = sample(10_000_000, [0.0; 3], [0.0, 0.0, G]);
        let step = ImuStep::new(&u, &u1, u.t).expect("positive interval");
        let q = step.process_noise(1e-3, 2e-3);
        // Over one interval: σ_θ² = σ_g,c²·Δt, σ_v² = σ_a,c²·Δt.
        assert!((q[(0, 0)] - 1e-6 * 0.01).abs() < 1e-20);
        assert!((q[(3, 3)] - 4e-6 * 0.01).abs() < 1e-20);
        assert!((q[(6, 6)] - 4e-6 * 0.25 * 1e-6).abs() < 1e-22);
        assert!((q - q.transpose()).norm() == 0.0);
        assert!(ImuStep::new(&u, &u, u.t).is_none());
    }

    #[test]
    fn hover_stays_put() {
        let x = state([0.0, 0.0, 0.7]);
        let x = EkfState {
            v_b_in_w: Vector3::zeros(),
            ..x
        };
        let u0 = sample(0, [0.0; 3], [0.0, 0.0, G]);
        let u1 = sample(10_000_000, [0.0; 3], [0.0, 0.0, G]);
        let step = ImuStep::new(&u0, &u1, u0.t).expect("positive interval");
        let y = step.propagate(&x, G);
        assert!(y.boxminus(&x).norm() < 1e-15);
        assert_eq!(y.t, u1.t);
    }
}
