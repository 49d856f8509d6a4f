//! The zero-velocity factor: a keyframe taken while the IMU is still ([`crate::fusion::nonlinear::start::still`]) and the
//! window's speed estimate is small holds its velocity at zero,
//!
//! ```text
//! r = v_k        (world frame, m/s; 1σ = NonlinearConfig::zero_velocity_sigma_m_s per axis)
//! ```
//!
//! With one AP, motion along the line of sight is unseen by the bearings once the drone stops
//! moving across it; the position is then held only by the IMU's integration, and a window whose
//! accelerometer bias is poorly known drifts (a window restarted after a hole most of all). On
//! the ground the IMU knows better: the velocity is zero. Consecutive still keyframes, tied by the
//! IMU factor between them, then also hold the position.
//!
//! The factor touches one keyframe: marginalizing it folds it into the prior like the keyframe's
//! other measurements. Its cost counts in the χ² tests, its residuals not among their degrees
//! of freedom ([`crate::fusion::nonlinear::passes_chi2`]).

use crate::fusion::nonlinear::state::{NavState, STATE_DIM, VEL};

/// The residual `r = v` (module doc), m/s.
pub fn zero_velocity_residual(x: &NavState) -> nalgebra::Vector3<f64> {
    x.v_b_in_w
}

/// `∂r/∂δx`: the identity on the velocity block (`v ⊞ δ = v + δv`).
pub fn zero_velocity_jacobian() -> nalgebra::SMatrix<f64, 3, STATE_DIM> {
    let mut j = nalgebra::SMatrix::<f64, 3, STATE_DIM>::zeros();
    j.fixed_view_mut::<3, 3>(0, VEL)
        .copy_from(&nalgebra::Matrix3::identity());
    j
}

#[cfg(test)]
mod tests {
    use nalgebra::{SVector, Vector3};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::fusion::nonlinear::state::testing::{
        assert_close, central_difference, random_state,
    };
    use crate::time::Timestamp;

    #[test]
    fn zero_velocity_jacobian_matches_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(51);
        for _ in 0..3 {
            let x = random_state(&mut rng, Timestamp(0));
            let fd = central_difference(|d| -> SVector<f64, 3> {
                zero_velocity_residual(&x.boxplus(d))
            });
            assert_close(&fd, &zero_velocity_jacobian(), "∂r/∂x");
        }
        let x = random_state(&mut rng, Timestamp(0));
        let still = NavState {
            v_b_in_w: Vector3::zeros(),
            ..x
        };
        assert_eq!(zero_velocity_residual(&still), Vector3::zeros());
    }
}
