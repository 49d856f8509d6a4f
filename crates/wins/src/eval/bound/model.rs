//! The linearized models of the bound: the IMU's error propagation between two samples and the
//! bearing's sensitivity, both at the truth.
//!
//! The error state of one instant is `δx = (δθ, δv, δp)` (9), with the attitude perturbed on the
//! right as everywhere in the crate (`R = R̂ Exp(δθ)`, [`crate::so3`]), velocity and position in
//! the world; the IMU's bias errors `δb = (δb_g, δb_a)` (6) are constants of the flight. The
//! discrete model of one IMU step of length `Δt` with the true body rate `ω` and specific force
//! `f` (Forster et al. 2017, eq. 24–26 without the biases' walk):
//!
//! ```text
//! R' = R Exp((ω − b_g) Δt)
//! v' = v + (R (f − b_a) − g e_z) Δt
//! p' = p + v Δt + ½ (R (f − b_a) − g e_z) Δt²
//! ```
//!
//! so that `δx' = A δx + B δb + w` with
//!
//! ```text
//! A = [ ΔRᵀ          0    0 ]      B = [ −J_r(ωΔt) Δt   0         ]
//!     [ −R[f]× Δt    I    0 ]          [ 0              −R Δt     ]
//!     [ −½R[f]× Δt²  IΔt  I ]          [ 0              −½R Δt²   ]
//! ```
//!
//! and the white noise `w` of the gyro (density `N_g`) and accelerometer (`N_a`) entering the
//! attitude and the velocity (`Cov(w)` in [`step_noise`]).

use nalgebra::{Matrix3, Rotation3, SMatrix, UnitQuaternion, Vector3};

use crate::rig::ImuNoise;
use crate::so3;
use crate::time::Timestamp;

/// 9 × 9: one instant's error state `(δθ, δv, δp)`.
pub(super) type Mat9 = SMatrix<f64, 9, 9>;
/// 9 × 6: the error state's sensitivity to the biases `(δb_g, δb_a)`.
pub(super) type Mat9x6 = SMatrix<f64, 9, 6>;
/// 1 × 9: a scalar measurement's sensitivity to one instant's error state.
pub(super) type Row9 = SMatrix<f64, 1, 9>;

/// Offsets of the blocks in the 9-vector.
pub(super) const THETA: usize = 0;
/// Velocity block.
pub(super) const VEL: usize = 3;
/// Position block.
pub(super) const POS: usize = 6;

/// One IMU step at the truth: the attitude at its start and end, the specific force in `b`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Step {
    /// `world_from_body` at the step's start.
    pub world_from_body: Rotation3<f64>,
    /// The body's rotation over the step, `R_startᵀ R_end`.
    pub delta: Rotation3<f64>,
    /// Specific force in `b` at the step's start, m/s².
    pub f_b: Vector3<f64>,
    /// Length, s.
    pub dt_s: f64,
}

impl Step {
    /// `A` and `B` of the module's model for this step.
    pub fn transition(&self) -> (Mat9, Mat9x6) {
        let r = self.world_from_body.matrix();
        let dt = self.dt_s;
        let rf = r * self.f_b.cross_matrix();
        let mut a = Mat9::identity();
        a.fixed_view_mut::<3, 3>(THETA, THETA)
            .copy_from(&self.delta.matrix().transpose());
        a.fixed_view_mut::<3, 3>(VEL, THETA).copy_from(&(-rf * dt));
        a.fixed_view_mut::<3, 3>(POS, THETA)
            .copy_from(&(-0.5 * rf * dt * dt));
        a.fixed_view_mut::<3, 3>(POS, VEL)
            .copy_from(&(Matrix3::identity() * dt));
        let phi = so3::log(&UnitQuaternion::from_rotation_matrix(&self.delta));
        let mut b = Mat9x6::zeros();
        b.fixed_view_mut::<3, 3>(THETA, 0)
            .copy_from(&(-so3::right_jacobian(&phi) * dt));
        b.fixed_view_mut::<3, 3>(VEL, 3).copy_from(&(-r * dt));
        b.fixed_view_mut::<3, 3>(POS, 3)
            .copy_from(&(-0.5 * r * dt * dt));
        (a, b)
    }
}

/// The rotors' vibration on an IMU as the bound counts it: white near 0 Hz at its broadband's
/// density (the quadratic mean over the axes), added to the sensor's own while the rotors spin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuVibration {
    /// When the rotors start spinning, on the IMU's clock.
    pub from: Timestamp,
    /// When they stop.
    pub to: Timestamp,
    /// Accelerometer, m/s²/√Hz.
    pub accel_density_m_s2_sqrt_hz: f64,
    /// Gyro, rad/s/√Hz.
    pub gyro_density_rad_s_sqrt_hz: f64,
}

/// The IMU's white densities at `t`, (gyro, accelerometer): the sensor's `noise`, with the
/// `vibration` added in quadrature (independent noises' powers add) while the rotors spin.
pub(super) fn densities(
    noise: &ImuNoise,
    vibration: Option<&ImuVibration>,
    t: Timestamp,
) -> (f64, f64) {
    let (gyro, accel) = (
        noise.gyro_noise_density_rad_s_sqrt_hz,
        noise.accel_noise_density_m_s2_sqrt_hz,
    );
    match vibration.filter(|v| t >= v.from && t <= v.to) {
        Some(v) => (
            gyro.hypot(v.gyro_density_rad_s_sqrt_hz),
            accel.hypot(v.accel_density_m_s2_sqrt_hz),
        ),
        None => (gyro, accel),
    }
}

/// Covariance of the white noise one step adds: the gyro's `N_g² Δt` on the attitude, the
/// accelerometer's on the velocity and, integrated, on the position (`N_a²` times `Δt`, `Δt²/2`,
/// `Δt³/3`).
pub(super) fn step_noise(gyro_density: f64, accel_density: f64, dt_s: f64) -> Mat9 {
    let mut q = Mat9::zeros();
    let g2 = gyro_density * gyro_density;
    let a2 = accel_density * accel_density;
    for i in 0..3 {
        q[(THETA + i, THETA + i)] = g2 * dt_s;
        q[(VEL + i, VEL + i)] = a2 * dt_s;
        q[(POS + i, VEL + i)] = a2 * dt_s * dt_s / 2.0;
        q[(VEL + i, POS + i)] = a2 * dt_s * dt_s / 2.0;
        q[(POS + i, POS + i)] = a2 * dt_s * dt_s * dt_s / 3.0;
    }
    q
}

/// The bearing `s = sin θ` (the cone angle's sine, [`crate::aoa::steering`]) from the array to
/// an AP, and its sensitivity to the instant's error state and to the AP's position.
#[derive(Clone, Copy, Debug)]
pub(super) struct BearingLinearization {
    /// `∂s/∂δx`.
    pub h_state: Row9,
    /// `∂s/∂p_ap`.
    pub h_ap: SMatrix<f64, 1, 3>,
}

/// `s = ŷ_a · d_a / |d_a|` with `d_a = R_baᵀ (Rᵀ (p_ap − p) − t_ba)` and its Jacobians; `None`
/// when the AP sits at the array.
pub(super) fn bearing(
    world_from_body: &Rotation3<f64>,
    p_b_in_w: &Vector3<f64>,
    body_from_array: &nalgebra::Isometry3<f64>,
    p_ap_in_w: &Vector3<f64>,
) -> Option<BearingLinearization> {
    let r_t = world_from_body.matrix().transpose();
    let r_ba_t = body_from_array
        .rotation
        .to_rotation_matrix()
        .matrix()
        .transpose();
    let w = p_ap_in_w - p_b_in_w;
    let w_b = r_t * w;
    let d_a = r_ba_t * (w_b - body_from_array.translation.vector);
    let n = d_a.norm();
    if n.is_nan() || n <= 1e-9 {
        return None;
    }
    let u = d_a / n;
    let s = u.y;
    // ∂s/∂d_a = (ŷ − s û)ᵀ / |d_a|.
    let ds_dda = (Vector3::y() - s * u).transpose() / n;
    let d_theta = ds_dda * r_ba_t * w_b.cross_matrix();
    let d_ap = ds_dda * r_ba_t * r_t;
    let mut h_state = Row9::zeros();
    h_state.fixed_view_mut::<1, 3>(0, THETA).copy_from(&d_theta);
    h_state.fixed_view_mut::<1, 3>(0, POS).copy_from(&(-d_ap));
    Some(BearingLinearization {
        h_state,
        h_ap: d_ap,
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, SVector, Translation3};

    use super::*;

    const G: f64 = 9.81;

    /// The module's nonlinear step (the truth's rate and force, biases `b`).
    fn propagate(
        r: &Rotation3<f64>,
        v: &Vector3<f64>,
        p: &Vector3<f64>,
        b: &SVector<f64, 6>,
        step: &Step,
    ) -> (Rotation3<f64>, Vector3<f64>, Vector3<f64>) {
        let phi = so3::log(&UnitQuaternion::from_rotation_matrix(&step.delta));
        let bg = b.fixed_rows::<3>(0).into_owned();
        let ba = b.fixed_rows::<3>(3).into_owned();
        let dt = step.dt_s;
        let r1 = r * Rotation3::from_scaled_axis(phi - bg * dt);
        let a = r * (step.f_b - ba) - Vector3::z() * G;
        (r1, v + a * dt, p + v * dt + 0.5 * a * dt * dt)
    }

    /// `δx` of `(r, v, p)` about `(r0, v0, p0)`.
    fn error(
        r0: &Rotation3<f64>,
        v0: &Vector3<f64>,
        p0: &Vector3<f64>,
        r: &Rotation3<f64>,
        v: &Vector3<f64>,
        p: &Vector3<f64>,
    ) -> SVector<f64, 9> {
        let mut e = SVector::<f64, 9>::zeros();
        // Through the quaternion: the rotation matrix's own log loses precision at small angles.
        let q = UnitQuaternion::from_rotation_matrix(&(r0.transpose() * r));
        e.fixed_rows_mut::<3>(THETA).copy_from(&so3::log(&q));
        e.fixed_rows_mut::<3>(VEL).copy_from(&(v - v0));
        e.fixed_rows_mut::<3>(POS).copy_from(&(p - p0));
        e
    }

    fn a_step() -> (Rotation3<f64>, Vector3<f64>, Vector3<f64>, Step) {
        let r = Rotation3::from_euler_angles(0.2, -0.3, 1.1);
        let step = Step {
            world_from_body: r,
            delta: Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5) * 0.05),
            f_b: Vector3::new(1.5, -0.7, 9.9),
            dt_s: 0.05,
        };
        (
            r,
            Vector3::new(0.4, -1.0, 0.2),
            Vector3::new(1.0, 2.0, 0.5),
            step,
        )
    }

    #[test]
    fn the_step_jacobians_match_central_differences() {
        let (r0, v0, p0, step) = a_step();
        let (a, b) = step.transition();
        let zero = SVector::<f64, 6>::zeros();
        let (r1, v1, p1) = propagate(&r0, &v0, &p0, &zero, &step);
        let h = 1e-6;
        for j in 0..9 {
            let mut fd = SVector::<f64, 9>::zeros();
            for sign in [1.0, -1.0] {
                let mut d = SVector::<f64, 9>::zeros();
                d[j] = sign * h;
                let r = r0 * Rotation3::from_scaled_axis(d.fixed_rows::<3>(THETA).into_owned());
                let v = v0 + d.fixed_rows::<3>(VEL);
                let p = p0 + d.fixed_rows::<3>(POS);
                let (rr, vv, pp) = propagate(&r, &v, &p, &zero, &step);
                fd += sign * error(&r1, &v1, &p1, &rr, &vv, &pp) / (2.0 * h);
            }
            let col = a.column(j);
            assert!((col - fd).norm() < 1e-7, "A column {j}: {col} vs {fd}");
        }
        for j in 0..6 {
            let mut fd = SVector::<f64, 9>::zeros();
            for sign in [1.0, -1.0] {
                let mut bias = SVector::<f64, 6>::zeros();
                bias[j] = sign * h;
                let (rr, vv, pp) = propagate(&r0, &v0, &p0, &bias, &step);
                fd += sign * error(&r1, &v1, &p1, &rr, &vv, &pp) / (2.0 * h);
            }
            let col = b.column(j);
            assert!((col - fd).norm() < 1e-7, "B column {j}: {col} vs {fd}");
        }
    }

    #[test]
    fn the_bearing_jacobians_match_central_differences() {
        let r0 = Rotation3::from_euler_angles(0.1, 0.2, -0.8);
        let p0 = Vector3::new(1.0, -2.0, 1.5);
        let mount = Isometry3::from_parts(
            Translation3::new(0.05, 0.0, 0.08),
            UnitQuaternion::from_euler_angles(0.0, 0.1, 0.3),
        );
        let ap = Vector3::new(6.0, 1.0, 3.0);
        let lin = bearing(&r0, &p0, &mount, &ap).expect("AP away from the array");
        // The model's sin θ, computed the plain way.
        let s = |r: &Rotation3<f64>, p: &Vector3<f64>, a: &Vector3<f64>| {
            let d_b = r.inverse() * (a - p) - mount.translation.vector;
            (mount.rotation.inverse() * d_b).normalize().y
        };
        let h = 1e-6;
        for j in 0..9 {
            let mut fd = 0.0;
            for sign in [1.0, -1.0] {
                let mut d = SVector::<f64, 9>::zeros();
                d[j] = sign * h;
                let r = r0 * Rotation3::from_scaled_axis(d.fixed_rows::<3>(THETA).into_owned());
                let p = p0 + d.fixed_rows::<3>(POS);
                fd += sign * s(&r, &p, &ap) / (2.0 * h);
            }
            assert!(
                (lin.h_state[j] - fd).abs() < 1e-8,
                "state {j}: {} vs {fd}",
                lin.h_state[j]
            );
        }
        for j in 0..3 {
            let mut fd = 0.0;
            for sign in [1.0, -1.0] {
                let mut a = ap;
                a[j] += sign * h;
                fd += sign * s(&r0, &p0, &a) / (2.0 * h);
            }
            assert!(
                (lin.h_ap[j] - fd).abs() < 1e-8,
                "AP {j}: {} vs {fd}",
                lin.h_ap[j]
            );
        }
    }

    #[test]
    fn the_step_noise_is_that_of_a_velocity_random_walk() {
        // Two half steps compose to one whole step (p = ∫ v, v a random walk).
        let q = step_noise(0.01, 0.1, 0.2);
        let a = {
            let mut a = Mat9::identity();
            a.fixed_view_mut::<3, 3>(POS, VEL)
                .copy_from(&(Matrix3::identity() * 0.1));
            a
        };
        let half = step_noise(0.01, 0.1, 0.1);
        let composed = a * half * a.transpose() + half;
        assert!((composed - q).norm() < 1e-12, "{composed} vs {q}");
    }
}
