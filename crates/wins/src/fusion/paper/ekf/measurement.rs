//! The AoA measurement model: the cone angle of the AP seen from the array (paper Sec. III, the
//! `H_k` of `O(x*)`).
//!
//! With `body_from_array = (R_b_a, t_b_a)` and the state's `R_w_b`, `p`, `c_l`:
//!
//! ```text
//! b = R_w_bᵀ·(c_l − p)              AP relative to the IMU, in b
//! d = R_b_aᵀ·(b − t_b_a)             AP relative to the array centre, in a
//! h = asin(d_y / |d|)                [`aoa_rad`]: exact for a linear array, no elevation assumed
//! ```
//!
//! Jacobian, with `ρ = √(d_x² + d_z²)` (so `cos h = ρ/|d|`) and body-side attitude error
//! `R = R̂·Exp(δθ)` (so `δb = [b]×·δθ`):
//!
//! ```text
//! ∂h/∂d  = (e_y·|d|² − d_y·d)ᵀ / (|d|²·ρ)      (norm 1/|d|, direction undefined at ρ = 0)
//! ∂h/∂δθ = ∂h/∂d · R_b_aᵀ·[b]×
//! ∂h/∂δp = −∂h/∂d · R_b_aᵀ·R̂_w_bᵀ = −∂h/∂δc_l,   ∂h/∂δv = 0
//! ```

use nalgebra::{Isometry3, RowDVector, RowVector3, Vector3};

use super::state::{ATTITUDE, EkfState, POSITION, ap_offset};
use crate::aoa::steering::aoa_rad;
use crate::fusion::bearing::{Side, side_of};

/// Below this distance from the array the AP direction is undefined, m.
pub const MIN_AP_DISTANCE_M: f64 = 1e-6;
/// Below this |cos θ| (the AP on the array axis, θ = ±90°) the cone angle is not differentiable.
pub const MIN_COS_AOA: f64 = 1e-9;

/// Why a bearing cannot be predicted from a state.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum PredictionError {
    /// The AP index is not in the state.
    #[error("AP {ap} is not in the state ({num_aps} APs)")]
    UnknownAp {
        /// The AP asked for.
        ap: usize,
        /// APs in the state.
        num_aps: usize,
    },
    /// The AP is (almost) at the array centre.
    #[error("AP {ap} is {distance_m:e} m from the array centre")]
    ApAtArray {
        /// The AP.
        ap: usize,
        /// Its distance from the array centre, m.
        distance_m: f64,
    },
    /// The AP is on the array axis (θ = ±90°), where the cone angle has no derivative.
    #[error("AP {ap} is on the array axis (cos θ = {cos_aoa:e})")]
    OnArrayAxis {
        /// The AP.
        ap: usize,
        /// cos θ of the predicted direction.
        cos_aoa: f64,
    },
    /// The state holds non-finite numbers.
    #[error("the state is not finite")]
    NonFiniteState,
}

/// The predicted bearing to one AP and its linearization.
#[derive(Clone, Debug, PartialEq)]
pub struct BearingPrediction {
    /// Predicted cone angle `h(x̂)`, rad.
    pub aoa_rad: f64,
    /// Side of the array the AP is predicted on.
    pub side: Side,
    /// Vector from the array centre to the AP in the array frame `a`, m.
    pub ap_in_a: Vector3<f64>,
    /// `H = ∂h/∂δx`, one row over the whole error state (`9 + 3·m` columns), rad per unit.
    pub jacobian: RowDVector<f64>,
}

/// `h(x)` and `H` for AP `ap` seen from the array mounted at `body_from_array` (module doc).
pub fn predict_bearing(
    state: &EkfState,
    ap: usize,
    body_from_array: &Isometry3<f64>,
) -> Result<BearingPrediction, PredictionError> {
    let c_in_w = state.c_in_w.get(ap).ok_or(PredictionError::UnknownAp {
        ap,
        num_aps: state.num_aps(),
    })?;
    if !state.is_finite() {
        return Err(PredictionError::NonFiniteState);
    }
    let r_w_b = state.world_from_body.to_rotation_matrix().into_inner();
    let r_b_a = body_from_array.rotation.to_rotation_matrix().into_inner();
    let b = r_w_b.transpose() * (c_in_w - state.p_b_in_w);
    let d = r_b_a.transpose() * (b - body_from_array.translation.vector);
    let distance_m = d.norm();
    if !distance_m.is_finite() || distance_m < MIN_AP_DISTANCE_M {
        return Err(PredictionError::ApAtArray { ap, distance_m });
    }
    let rho = d.x.hypot(d.z);
    let cos_aoa = rho / distance_m;
    if cos_aoa.is_nan() || cos_aoa < MIN_COS_AOA {
        return Err(PredictionError::OnArrayAxis { ap, cos_aoa });
    }
    let d2 = distance_m * distance_m;
    let dh_dd = (Vector3::y() * d2 - d * d.y).transpose() / (d2 * rho);
    let dh_dtheta: RowVector3<f64> = dh_dd * r_b_a.transpose() * b.cross_matrix();
    let dh_dp: RowVector3<f64> = -dh_dd * r_b_a.transpose() * r_w_b.transpose();

    let mut jacobian = RowDVector::zeros(state.error_dim());
    jacobian
        .fixed_columns_mut::<3>(ATTITUDE)
        .copy_from(&dh_dtheta);
    jacobian.fixed_columns_mut::<3>(POSITION).copy_from(&dh_dp);
    jacobian
        .fixed_columns_mut::<3>(ap_offset(ap))
        .copy_from(&(-dh_dp));
    Ok(BearingPrediction {
        aoa_rad: aoa_rad(&d),
        side: side_of(&d),
        ap_in_a: d,
        jacobian,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DVector, Translation3, UnitQuaternion};

    use crate::time::Timestamp;

    fn state(rpy: [f64; 3], p: [f64; 3], aps: &[[f64; 3]]) -> EkfState {
        EkfState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
            v_b_in_w: Vector3::new(0.5, 1.0, -0.2),
            p_b_in_w: Vector3::from(p),
            c_in_w: aps.iter().map(|c| Vector3::from(*c)).collect(),
        }
    }

    fn mounted(t: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(Vector3::from(t)),
            UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
        )
    }

    /// Central differences of `h`, perturbing body-side (`x ⊞ ε·e_i`).
    fn numeric_jacobian(x: &EkfState, ap: usize, extrinsic: &Isometry3<f64>) -> RowDVector<f64> {
        let eps = 1e-7;
        let h = |dx: &DVector<f64>| {
            predict_bearing(&x.boxplus(dx), ap, extrinsic)
                .expect("non-degenerate")
                .aoa_rad
        };
        RowDVector::from_iterator(
            x.error_dim(),
            (0..x.error_dim()).map(|i| {
                let mut dx = DVector::zeros(x.error_dim());
                dx[i] = eps;
                (h(&dx) - h(&(-dx))) / (2.0 * eps)
            }),
        )
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let identity = Isometry3::identity();
        let offset = mounted([0.05, -0.02, 0.08], [0.1, -0.3, 0.4]);
        let aps = [[1.0, 4.0, 1.5], [9.0, 1.0, 2.7]];
        let cases = [
            // Generic: tilted vehicle, both APs, both mountings.
            (state([0.1, -0.2, 2.9], [6.0, 4.3, 1.4], &aps), identity),
            (state([0.1, -0.2, 2.9], [6.0, 4.3, 1.4], &aps), offset),
            (state([-0.3, 0.2, -1.0], [3.0, 2.0, 1.0], &aps), offset),
            // Level, the AP dead ahead (θ = 0).
            (
                state([0.0, 0.0, 0.0], [0.0, 0.0, 1.5], &[[5.0, 0.0, 1.5]]),
                identity,
            ),
            // Near endfire: θ ≈ 89.4° (AP almost along body y).
            (
                state([0.0, 0.0, 0.0], [0.0, 0.0, 1.5], &[[0.05, 5.0, 1.5]]),
                identity,
            ),
            // Behind the array.
            (
                state([0.0, 0.0, 0.5], [0.0, 0.0, 1.5], &[[-4.0, 1.0, 2.0]]),
                offset,
            ),
            // Close range, 10 cm.
            (
                state([0.2, 0.1, 0.0], [0.0, 0.0, 1.5], &[[0.08, 0.05, 1.52]]),
                identity,
            ),
        ];
        for (x, extrinsic) in &cases {
            for ap in 0..x.num_aps() {
                let pred = predict_bearing(x, ap, extrinsic).expect("non-degenerate");
                let numeric = numeric_jacobian(x, ap, extrinsic);
                let scale = pred.jacobian.norm().max(1.0);
                let err = (&pred.jacobian - &numeric).abs().max() / scale;
                assert!(
                    err < 1e-6,
                    "θ = {:.2}°, rel. err {err:e}\n{}\n{}",
                    pred.aoa_rad.to_degrees(),
                    pred.jacobian,
                    numeric
                );
                // Velocity never enters; p and c enter with opposite signs.
                assert_eq!(pred.jacobian.columns(3, 3).norm(), 0.0);
                let c = ap_offset(ap);
                let sum = pred.jacobian.columns(6, 3) + pred.jacobian.columns(c, 3);
                assert!(sum.norm() < 1e-15);
            }
        }
    }

    #[test]
    fn prediction_uses_the_steering_convention() {
        // Level body, AP to the front-left: +y in body = +a_y, so θ > 0, front.
        let x = state([0.0, 0.0, 0.0], [0.0, 0.0, 1.5], &[[3.0, 3.0, 1.5]]);
        let p = predict_bearing(&x, 0, &Isometry3::identity()).expect("non-degenerate");
        assert!((p.aoa_rad - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert_eq!(p.side, Side::Front);
        let behind = state([0.0, 0.0, 0.0], [0.0, 0.0, 1.5], &[[-3.0, 3.0, 1.5]]);
        let p = predict_bearing(&behind, 0, &Isometry3::identity()).expect("non-degenerate");
        assert!((p.aoa_rad - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert_eq!(p.side, Side::Back);
    }

    #[test]
    fn degenerate_geometry_is_an_error_not_a_nan() {
        let id = Isometry3::identity();
        let at = state([0.0; 3], [1.0, 2.0, 3.0], &[[1.0, 2.0, 3.0]]);
        assert!(matches!(
            predict_bearing(&at, 0, &id),
            Err(PredictionError::ApAtArray { .. })
        ));
        let axis = state([0.0; 3], [1.0, 2.0, 3.0], &[[1.0, 7.0, 3.0]]);
        assert!(matches!(
            predict_bearing(&axis, 0, &id),
            Err(PredictionError::OnArrayAxis { .. })
        ));
        assert!(matches!(
            predict_bearing(&axis, 3, &id),
            Err(PredictionError::UnknownAp { ap: 3, num_aps: 1 })
        ));
        let mut nan = axis.clone();
        nan.p_b_in_w.x = f64::NAN;
        assert_eq!(
            predict_bearing(&nan, 0, &id),
            Err(PredictionError::NonFiniteState)
        );
    }
}
