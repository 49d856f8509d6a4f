//! One keyframe's navigation state, its 15-number error state, and the body pose at an instant
//! inside the interval after a keyframe (from the partial preintegration to that instant).
//!
//! Error state `δx = [δθ, δp, δv, δb_g, δb_a]` (slots [`THETA`], [`POS`], [`VEL`], [`BG`], [`BA`]):
//!
//! ```text
//! x ⊞ δx = (R Exp(δθ), p + δp, v + δv, b_g + δb_g, b_a + δb_a)      (rotation on the right)
//! y ⊟ x  = (Log(R_xᵀ R_y), p_y − p_x, v_y − v_x, b_g,y − b_g,x, b_a,y − b_a,x)
//! ```
//!
//! Positions and velocities are perturbed additively in `w`, the rotation in the body.

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use crate::imu::{ImuBiases, Preintegrated};
use crate::so3::{exp, log, right_jacobian};
use crate::time::Timestamp;

/// Size of a keyframe's error state.
pub const STATE_DIM: usize = 15;
/// Slot of the attitude error `δθ` (body side, rad).
pub const THETA: usize = 0;
/// Slot of the position error `δp` (in `w`, m).
pub const POS: usize = 3;
/// Slot of the velocity error `δv` (in `w`, m/s).
pub const VEL: usize = 6;
/// Slot of the gyro bias error `δb_g` (rad/s).
pub const BG: usize = 9;
/// Slot of the accelerometer bias error `δb_a` (m/s²).
pub const BA: usize = 12;

/// A keyframe's error state (or a residual ordered like it).
pub type Vec15 = SVector<f64, 15>;
/// A 15×15 block (Jacobian, covariance, information).
pub type Mat15 = SMatrix<f64, 15, 15>;
/// One row over a keyframe's error state.
pub type Row15 = SMatrix<f64, 1, 15>;
/// A 3×15 Jacobian block.
pub type Mat3x15 = SMatrix<f64, 3, 15>;

/// One keyframe's navigation state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState {
    /// The keyframe's time (IMU clock).
    pub t: Timestamp,
    /// Attitude `R`: maps body vectors into `w`.
    pub world_from_body: UnitQuaternion<f64>,
    /// Body (IMU) position in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Body velocity in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Gyro bias, rad/s, body frame.
    pub gyro_bias_rad_s: Vector3<f64>,
    /// Accelerometer bias, m/s², body frame.
    pub accel_bias_m_s2: Vector3<f64>,
}

impl NavState {
    /// `x ⊞ δx`: `R Exp(δθ)`, `p + δp`, `v + δv`, `b_g + δb_g`, `b_a + δb_a`.
    pub fn boxplus(&self, d: &Vec15) -> Self {
        let rot = self.world_from_body * exp(&d.fixed_rows::<3>(THETA).into_owned());
        Self {
            t: self.t,
            world_from_body: UnitQuaternion::new_normalize(*rot.quaternion()),
            p_b_in_w: self.p_b_in_w + d.fixed_rows::<3>(POS),
            v_b_in_w: self.v_b_in_w + d.fixed_rows::<3>(VEL),
            gyro_bias_rad_s: self.gyro_bias_rad_s + d.fixed_rows::<3>(BG),
            accel_bias_m_s2: self.accel_bias_m_s2 + d.fixed_rows::<3>(BA),
        }
    }

    /// `self ⊟ base`: `[Log(R_baseᵀ R), p − p_base, v − v_base, b_g − b_g,base, b_a − b_a,base]`,
    /// so that `base ⊞ (self ⊟ base) = self`.
    pub fn boxminus(&self, base: &Self) -> Vec15 {
        let mut d = Vec15::zeros();
        d.fixed_rows_mut::<3>(THETA).copy_from(&log(
            &(base.world_from_body.inverse() * self.world_from_body)
        ));
        d.fixed_rows_mut::<3>(POS)
            .copy_from(&(self.p_b_in_w - base.p_b_in_w));
        d.fixed_rows_mut::<3>(VEL)
            .copy_from(&(self.v_b_in_w - base.v_b_in_w));
        d.fixed_rows_mut::<3>(BG)
            .copy_from(&(self.gyro_bias_rad_s - base.gyro_bias_rad_s));
        d.fixed_rows_mut::<3>(BA)
            .copy_from(&(self.accel_bias_m_s2 - base.accel_bias_m_s2));
        d
    }

    /// The biases as the IMU code takes them.
    pub fn biases(&self) -> ImuBiases {
        ImuBiases {
            gyro_rad_s: self.gyro_bias_rad_s,
            accel_m_s2: self.accel_bias_m_s2,
        }
    }

    /// Every number finite.
    pub fn is_finite(&self) -> bool {
        self.world_from_body.coords.iter().all(|x| x.is_finite())
            && [
                &self.p_b_in_w,
                &self.v_b_in_w,
                &self.gyro_bias_rad_s,
                &self.accel_bias_m_s2,
            ]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()))
    }
}

/// `g_w = (0, 0, −g)`: gravity in the z-up world frame for a gravity magnitude `g` (m/s²).
pub fn gravity_in_w(g: f64) -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -g)
}

/// The body pose (and velocity) at one instant, in `w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseAt {
    /// Attitude `R_t`: maps body vectors into `w`.
    pub world_from_body: UnitQuaternion<f64>,
    /// Body position in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Body velocity in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
}

/// α, β, ΔR of `partial` at `x`'s biases (first order, [`Preintegrated::corrected`]) and the
/// rotation correction `φ = J_θ δb` with `δb = b_x − b̄`.
fn corrected_at(
    x: &NavState,
    partial: &Preintegrated,
) -> (
    Vector3<f64>,
    Vector3<f64>,
    UnitQuaternion<f64>,
    Vector3<f64>,
) {
    let (alpha, beta, rot) = partial.corrected(&x.biases());
    let j = &partial.jacobian_bias;
    let phi = j.fixed_view::<3, 3>(6, 0) * (x.accel_bias_m_s2 - partial.bias.accel_m_s2)
        + j.fixed_view::<3, 3>(6, 3) * (x.gyro_bias_rad_s - partial.bias.gyro_rad_s);
    (alpha, beta, rot, phi)
}

/// The body pose at `partial.end`, inside the interval after keyframe `x` (`partial.start` is
/// `x.t`; the caller keeps them equal), with `Δt = partial.dt_s()` and `g_w` from
/// [`gravity_in_w`] (paper `eqn:imumodel` solved for the later state, Forster et al. 2017 eq. 33):
///
/// ```text
/// R_t = R ΔR(b)      p_t = p + v Δt + ½ g_w Δt² + R α(b)      v_t = v + g_w Δt + R β(b)
/// ```
///
/// with α, β, ΔR corrected to `x`'s biases to first order. An empty `partial` (Δt = 0) gives `x`'s
/// own pose.
pub fn pose_at(x: &NavState, partial: &Preintegrated, gravity_m_s2: f64) -> PoseAt {
    let (alpha, beta, rot, _) = corrected_at(x, partial);
    let dt = partial.dt_s();
    let g_w = gravity_in_w(gravity_m_s2);
    let r = x.world_from_body;
    PoseAt {
        world_from_body: UnitQuaternion::new_normalize(*(r * rot).quaternion()),
        p_b_in_w: x.p_b_in_w + x.v_b_in_w * dt + g_w * (0.5 * dt * dt) + r * alpha,
        v_b_in_w: x.v_b_in_w + g_w * dt + r * beta,
    }
}

/// Jacobians of [`pose_at`] with respect to `δx` (the keyframe's error state): rotation (the right
/// perturbation of `R_t`), position and velocity, each 3×15. With `J` = `partial.jacobian_bias`
/// (rows α, β, θ; columns b_a, b_g) and `φ = J_θ δb`:
///
/// ```text
/// ∂θ_t/∂δθ = ΔR(b)ᵀ         ∂θ_t/∂δb = J_r(φ) J_θ
/// ∂p_t/∂δθ = −R [α(b)]×     ∂p_t/∂δp = I     ∂p_t/∂δv = Δt I     ∂p_t/∂δb = R J_α
/// ∂v_t/∂δθ = −R [β(b)]×     ∂v_t/∂δv = I                         ∂v_t/∂δb = R J_β
/// ```
///
/// Gravity enters additively and has no Jacobian term (the argument mirrors [`pose_at`]).
pub fn pose_at_jacobians(
    x: &NavState,
    partial: &Preintegrated,
    _gravity_m_s2: f64,
) -> (Mat3x15, Mat3x15, Mat3x15) {
    let (alpha, beta, rot, phi) = corrected_at(x, partial);
    let dt = partial.dt_s();
    let r = x.world_from_body.to_rotation_matrix().into_inner();
    let j = &partial.jacobian_bias;
    let jr = right_jacobian(&phi);

    let mut d_rot = Mat3x15::zeros();
    d_rot
        .fixed_view_mut::<3, 3>(0, THETA)
        .copy_from(&rot.to_rotation_matrix().into_inner().transpose());
    d_rot
        .fixed_view_mut::<3, 3>(0, BG)
        .copy_from(&(jr * j.fixed_view::<3, 3>(6, 3)));
    d_rot
        .fixed_view_mut::<3, 3>(0, BA)
        .copy_from(&(jr * j.fixed_view::<3, 3>(6, 0)));

    let mut d_pos = Mat3x15::zeros();
    d_pos
        .fixed_view_mut::<3, 3>(0, THETA)
        .copy_from(&(-r * alpha.cross_matrix()));
    d_pos
        .fixed_view_mut::<3, 3>(0, POS)
        .copy_from(&Matrix3::identity());
    d_pos
        .fixed_view_mut::<3, 3>(0, VEL)
        .copy_from(&(Matrix3::identity() * dt));
    d_pos
        .fixed_view_mut::<3, 3>(0, BG)
        .copy_from(&(r * j.fixed_view::<3, 3>(0, 3)));
    d_pos
        .fixed_view_mut::<3, 3>(0, BA)
        .copy_from(&(r * j.fixed_view::<3, 3>(0, 0)));

    let mut d_vel = Mat3x15::zeros();
    d_vel
        .fixed_view_mut::<3, 3>(0, THETA)
        .copy_from(&(-r * beta.cross_matrix()));
    d_vel
        .fixed_view_mut::<3, 3>(0, VEL)
        .copy_from(&Matrix3::identity());
    d_vel
        .fixed_view_mut::<3, 3>(0, BG)
        .copy_from(&(r * j.fixed_view::<3, 3>(3, 3)));
    d_vel
        .fixed_view_mut::<3, 3>(0, BA)
        .copy_from(&(r * j.fixed_view::<3, 3>(3, 0)));
    (d_rot, d_pos, d_vel)
}

#[cfg(test)]
pub(crate) mod testing;

#[cfg(test)]
mod tests {
    use super::testing::{assert_close, central_difference, random_interval, random_state};
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    const G: f64 = crate::imu::STANDARD_GRAVITY_M_S2;

    #[test]
    fn boxplus_and_boxminus_are_inverse() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..20 {
            let x = random_state(&mut rng, Timestamp(0));
            let y = random_state(&mut rng, Timestamp(0));
            let d = y.boxminus(&x);
            let back = x.boxplus(&d);
            assert!(back.boxminus(&y).norm() < 1e-12);
            assert!(x.boxminus(&x).norm() < 1e-15);
            assert!(x.is_finite());
        }
        let mut bad = random_state(&mut rng, Timestamp(0));
        bad.v_b_in_w.y = f64::NAN;
        assert!(!bad.is_finite());
    }

    #[test]
    fn pose_at_of_an_empty_interval_is_the_keyframe() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let x = random_state(&mut rng, Timestamp(5_000_000_000));
        let partial = Preintegrated::empty(x.t, ImuBiases::zero());
        let p = pose_at(&x, &partial, G);
        assert_eq!(p.p_b_in_w, x.p_b_in_w);
        assert_eq!(p.v_b_in_w, x.v_b_in_w);
        assert!(log(&(x.world_from_body.inverse() * p.world_from_body)).norm() < 1e-15);
        // Its Jacobians are the identity on the pose slots and zero on the biases.
        let (jr, jp, jv) = pose_at_jacobians(&x, &partial, G);
        assert_eq!(jr.fixed_view::<3, 3>(0, THETA), Matrix3::identity());
        assert_eq!(jp.fixed_view::<3, 3>(0, POS), Matrix3::identity());
        assert_eq!(jv.fixed_view::<3, 3>(0, VEL), Matrix3::identity());
        assert_eq!(jr.columns(BG, 6).norm() + jp.columns(BG, 6).norm(), 0.0);
    }

    #[test]
    fn pose_at_jacobians_match_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for seed in 0..4 {
            let partial = random_interval(40 + 30 * seed as usize, seed);
            let mut x = random_state(&mut rng, partial.start);
            // Biases away from the linearization point, so the correction terms matter.
            x.gyro_bias_rad_s = partial.bias.gyro_rad_s + Vector3::new(0.02, -0.01, 0.03);
            x.accel_bias_m_s2 = partial.bias.accel_m_s2 + Vector3::new(-0.1, 0.2, 0.05);
            let base = pose_at(&x, &partial, G);
            let (jr, jp, jv) = pose_at_jacobians(&x, &partial, G);
            let f = |d: &Vec15| {
                let p = pose_at(&x.boxplus(d), &partial, G);
                let mut out = SVector::<f64, 9>::zeros();
                out.fixed_rows_mut::<3>(0)
                    .copy_from(&log(&(base.world_from_body.inverse() * p.world_from_body)));
                out.fixed_rows_mut::<3>(3).copy_from(&p.p_b_in_w);
                out.fixed_rows_mut::<3>(6).copy_from(&p.v_b_in_w);
                out
            };
            let fd = central_difference(f);
            assert_close(&fd.rows(0, 3), &jr, "rotation");
            assert_close(&fd.rows(3, 3), &jp, "position");
            assert_close(&fd.rows(6, 3), &jv, "velocity");
        }
    }
}
