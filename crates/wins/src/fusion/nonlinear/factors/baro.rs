//! The barometer factor: an altitude `h` measured at `t`, inside keyframe `k`'s interval, with the
//! body height at `t` from the partial preintegration ([`pose_at`]) and the barometer's offset `o`
//! (a state of the window, m):
//!
//! ```text
//! r = p_t,z + o − h
//! ```

use crate::fusion::nonlinear::state::{NavState, Row15, pose_at, pose_at_jacobians};
use crate::imu::Preintegrated;

/// The barometer residual `r = p_t,z + o − h` (module doc) for an altitude `altitude_m` measured
/// at `partial.end` in keyframe `x`'s interval, with the offset `offset_m`.
pub fn baro_residual(
    x: &NavState,
    partial: &Preintegrated,
    g: f64,
    offset_m: f64,
    altitude_m: f64,
) -> f64 {
    pose_at(x, partial, g).p_b_in_w.z + offset_m - altitude_m
}

/// `(∂r/∂δx_k, ∂r/∂o)`: the z row of [`pose_at_jacobians`]'s position block, and 1 (`r` is
/// linear in `o` and `h`; the arguments mirror [`baro_residual`]).
pub fn baro_jacobian(
    x: &NavState,
    partial: &Preintegrated,
    g: f64,
    _offset_m: f64,
    _altitude_m: f64,
) -> (Row15, f64) {
    let (_, j_pos, _) = pose_at_jacobians(x, partial, g);
    (j_pos.fixed_rows::<1>(2).into_owned(), 1.0)
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::fusion::nonlinear::state::testing::{
        assert_close, central_difference, random_interval, random_state, sym3,
    };
    use crate::imu::STANDARD_GRAVITY_M_S2 as G;
    use nalgebra::SVector;

    #[test]
    fn baro_jacobian_matches_finite_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        for (n, seed) in [(1usize, 1u64), (7, 2), (90, 3)] {
            let partial = random_interval(n, seed);
            let mut x = random_state(&mut rng, partial.start);
            x.gyro_bias_rad_s = partial.bias.gyro_rad_s + sym3(&mut rng) * 0.02;
            x.accel_bias_m_s2 = partial.bias.accel_m_s2 + sym3(&mut rng) * 0.2;
            let (o, h) = (0.7, 3.1);
            let (jx, jo) = baro_jacobian(&x, &partial, G, o, h);
            let fd = central_difference(|d| {
                SVector::<f64, 1>::new(baro_residual(&x.boxplus(d), &partial, G, o, h))
            });
            assert_close(&fd, &jx, "∂r/∂x");
            let step = 1e-6;
            let fd_o = (baro_residual(&x, &partial, G, o + step, h)
                - baro_residual(&x, &partial, G, o - step, h))
                / (2.0 * step);
            assert!((fd_o - jo).abs() < 1e-8);
        }
    }

    #[test]
    fn baro_residual_is_zero_at_the_true_height() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let partial = random_interval(20, 4);
        let x = random_state(&mut rng, partial.start);
        let z = pose_at(&x, &partial, G).p_b_in_w.z;
        assert!(baro_residual(&x, &partial, G, -1.5, z - 1.5).abs() < 1e-12);
        assert!((baro_residual(&x, &partial, G, 0.0, z - 1.5) - 1.5).abs() < 1e-12);
    }
}
