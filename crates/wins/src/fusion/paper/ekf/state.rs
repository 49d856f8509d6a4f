//! The EKF's nominal state and its error-state layout (paper Sec. III, the 12-state vector
//! `[q_w^b; v_b^w; p_b^w; c^w]` with one AP, extended to any number of APs).
//!
//! Error state, in this order: δθ (3, body-side attitude error, `R = R̂·Exp(δθ)`), δv (3, `w`),
//! δp (3, `w`), then δc_l (3 each, `w`) for every AP `l`. Dimension `9 + 3·m`.

use nalgebra::{DVector, UnitQuaternion, Vector3};

use crate::time::Timestamp;

/// Offset of δθ (attitude) in the error state.
pub const ATTITUDE: usize = 0;
/// Offset of δv (velocity in `w`) in the error state.
pub const VELOCITY: usize = 3;
/// Offset of δp (position in `w`) in the error state.
pub const POSITION: usize = 6;
/// Dimension of the vehicle part of the error state (attitude, velocity, position).
pub const CORE_DIM: usize = 9;

/// Offset of δc_l (the position of AP `l` in `w`) in the error state.
pub const fn ap_offset(ap: usize) -> usize {
    CORE_DIM + 3 * ap
}

/// Error-state dimension with `num_aps` APs: `9 + 3·m`.
pub const fn error_dim(num_aps: usize) -> usize {
    CORE_DIM + 3 * num_aps
}

/// The nominal state: vehicle pose and velocity at time `t`, and every AP's position.
#[derive(Clone, Debug, PartialEq)]
pub struct EkfState {
    /// Time of the state, on the IMU clock.
    pub t: Timestamp,
    /// Attitude `R_w_b` (Hamilton): maps body vectors into `w`. Perturbed body-side,
    /// `R = R̂·Exp(δθ)`.
    pub world_from_body: UnitQuaternion<f64>,
    /// Velocity of the body (IMU) origin in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Position of the body (IMU) origin in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Position of each AP's antenna in `w`, m, in the EKF's AP numbering.
    pub c_in_w: Vec<Vector3<f64>>,
}

impl EkfState {
    /// Number of APs in the state.
    pub fn num_aps(&self) -> usize {
        self.c_in_w.len()
    }

    /// Error-state dimension, `9 + 3·m`.
    pub fn error_dim(&self) -> usize {
        error_dim(self.num_aps())
    }

    /// Whether every number is finite.
    pub fn is_finite(&self) -> bool {
        let q = self.world_from_body.quaternion();
        q.coords.iter().all(|x| x.is_finite())
            && self.v_b_in_w.iter().all(|x| x.is_finite())
            && self.p_b_in_w.iter().all(|x| x.is_finite())
            && self.c_in_w.iter().flatten().all(|x| x.is_finite())
    }

    /// `x ⊞ δx`: `R·Exp(δθ)`, `v + δv`, `p + δp`, `c_l + δc_l`. `dx` must have
    /// [`EkfState::error_dim`] entries; missing AP entries are taken as zero.
    pub fn boxplus(&self, dx: &DVector<f64>) -> EkfState {
        let block = |offset: usize| -> Vector3<f64> {
            if offset + 3 <= dx.len() {
                Vector3::new(dx[offset], dx[offset + 1], dx[offset + 2])
            } else {
                Vector3::zeros()
            }
        };
        EkfState {
            t: self.t,
            world_from_body: self.world_from_body
                * UnitQuaternion::from_scaled_axis(block(ATTITUDE)),
            v_b_in_w: self.v_b_in_w + block(VELOCITY),
            p_b_in_w: self.p_b_in_w + block(POSITION),
            c_in_w: self
                .c_in_w
                .iter()
                .enumerate()
                .map(|(l, c)| c + block(ap_offset(l)))
                .collect(),
        }
    }

    /// `self ⊟ reference`: the error state δx with `reference ⊞ δx = self`
    /// (`δθ = Log(R̂ᵀ R)`). APs beyond the shorter of the two states are left at zero.
    pub fn boxminus(&self, reference: &EkfState) -> DVector<f64> {
        let mut dx = DVector::zeros(self.error_dim());
        let d_theta = (reference.world_from_body.inverse() * self.world_from_body).scaled_axis();
        dx.fixed_rows_mut::<3>(ATTITUDE).copy_from(&d_theta);
        dx.fixed_rows_mut::<3>(VELOCITY)
            .copy_from(&(self.v_b_in_w - reference.v_b_in_w));
        dx.fixed_rows_mut::<3>(POSITION)
            .copy_from(&(self.p_b_in_w - reference.p_b_in_w));
        for (l, (c, c_ref)) in self.c_in_w.iter().zip(&reference.c_in_w).enumerate() {
            dx.fixed_rows_mut::<3>(ap_offset(l)).copy_from(&(c - c_ref));
        }
        dx
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> EkfState {
        EkfState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 2.0),
            v_b_in_w: Vector3::new(1.0, -0.5, 0.2),
            p_b_in_w: Vector3::new(3.0, 4.0, 1.5),
            c_in_w: vec![Vector3::new(1.0, 4.0, 1.5), Vector3::new(10.0, 1.0, 2.5)],
        }
    }

    #[test]
    fn boxminus_inverts_boxplus_and_perturbs_body_side() {
        let x = state();
        let dx = DVector::from_iterator(
            x.error_dim(),
            (0..x.error_dim()).map(|i| 0.01 * (i as f64 + 1.0).sin()),
        );
        let y = x.boxplus(&dx);
        assert!((y.boxminus(&x) - &dx).norm() < 1e-12);
        // Body side: R_y = R_x · Exp(δθ).
        let d_theta = Vector3::new(dx[0], dx[1], dx[2]);
        let expected = x.world_from_body * UnitQuaternion::from_scaled_axis(d_theta);
        assert!(y.world_from_body.angle_to(&expected) < 1e-12);
        assert_eq!(ap_offset(1), 12);
        assert_eq!(x.error_dim(), 15);
        assert!(x.is_finite());
        let mut bad = x;
        bad.c_in_w[1].y = f64::NAN;
        assert!(!bad.is_finite());
    }
}
