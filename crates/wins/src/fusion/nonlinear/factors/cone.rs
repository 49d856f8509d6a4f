//! The exact AoA model of a linear array (the cone factor).
//!
//! The array frame `a` sits on the body at `body_from_array = (R_ba, t_ba)`. A bearing measured at
//! `t`, inside keyframe `k`'s interval, to an AP at `c` (in `w`): with the body pose at `t` from the
//! partial preintegration ([`pose_at`]: `R_t`, `p_t`),
//!
//! ```text
//! d_a = R_baᵀ (R_tᵀ (c − p_t) − t_ba)       (toward the AP, in the array frame)
//! s   = ŷ_a · d_a / |d_a|                    (= sin θ, crate::aoa::steering::sin_aoa)
//! r   = s − sin θ_measured
//! ```
//!
//! A linear array measures only this cone angle (an AP behind the array gives the same `s`), so
//! no front/back decision and no assumption on the AP's height are needed. Unlike the paper's
//! planar model (`eqn:aoa`), the AP's height and the body's tilt enter exactly.

use nalgebra::{Isometry3, RowVector3, Vector3};

use crate::aoa::steering::sin_aoa;
use crate::fusion::nonlinear::state::{NavState, Row15, pose_at, pose_at_jacobians};
use crate::imu::Preintegrated;

/// Below this distance (m) between the AP and the array centre the bearing is undefined.
const MIN_RANGE_M: f64 = 1e-9;

/// The lower bound on `cos θ` in [`sin_sigma`].
///
/// `s = sin θ` is flat near endfire (`ds/dθ = cos θ → 0` as `|θ| → 90°`), so an angle σ maps to a
/// vanishing σ of `s` and an endfire bearing would get an unbounded weight, exactly where the
/// first-order mapping is worst (the second-order bias `−½ sin θ σ_θ²` dominates) and where AoA
/// estimators are least reliable. The floor caps the weight at that of a bearing at
/// `acos 0.2 ≈ 78.5°`.
pub const COS_FLOOR: f64 = 0.2;

/// A cone factor's residual and its Jacobians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeJacobian {
    /// `r = s − sin θ_measured`.
    pub residual: f64,
    /// `∂r/∂δx_k` (the keyframe's error state).
    pub d_state: Row15,
    /// `∂r/∂c` (the AP's position in `w`).
    pub d_ap: RowVector3<f64>,
}

/// `d_a` and the body pose's parts it needs: `(d_a, R_tᵀ (c − p_t))`.
fn toward_ap_in_a(
    x: &NavState,
    partial: &Preintegrated,
    g: f64,
    body_from_array: &Isometry3<f64>,
    c_in_w: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let pose = pose_at(x, partial, g);
    let d_b = pose
        .world_from_body
        .inverse_transform_vector(&(c_in_w - pose.p_b_in_w));
    let d_a = body_from_array
        .rotation
        .inverse_transform_vector(&(d_b - body_from_array.translation.vector));
    (d_a, d_b)
}

/// The cone residual `r = ŷ_a · d_a/|d_a| − sin_measured` (module doc) for a bearing at
/// `partial.end` in keyframe `x`'s interval; `None` when the AP is at the array centre
/// (`|d_a| < 1e-9` m).
pub fn cone_residual(
    x: &NavState,
    partial: &Preintegrated,
    g: f64,
    body_from_array: &Isometry3<f64>,
    c_in_w: &Vector3<f64>,
    sin_measured: f64,
) -> Option<f64> {
    let (d_a, _) = toward_ap_in_a(x, partial, g, body_from_array, c_in_w);
    if d_a.norm() < MIN_RANGE_M {
        return None;
    }
    Some(sin_aoa(&d_a) - sin_measured)
}

/// [`cone_residual`] with its Jacobians. With `n = |d_a|`, `s = d_a,y / n` and the pose
/// Jacobians `J_θt`, `J_pt` of [`pose_at_jacobians`] (`θ_t` the right perturbation of `R_t`):
///
/// ```text
/// ∂s/∂d_a = (ŷ_a − s d_a/n)ᵀ / n
/// ∂d_a/∂θ_t = R_baᵀ [R_tᵀ (c − p_t)]×     ∂d_a/∂p_t = −R_baᵀ R_tᵀ     ∂d_a/∂c = R_baᵀ R_tᵀ
/// ∂r/∂δx_k = ∂s/∂d_a (∂d_a/∂θ_t J_θt + ∂d_a/∂p_t J_pt)
/// ```
pub fn cone_jacobian(
    x: &NavState,
    partial: &Preintegrated,
    g: f64,
    body_from_array: &Isometry3<f64>,
    c_in_w: &Vector3<f64>,
    sin_measured: f64,
) -> Option<ConeJacobian> {
    let (d_a, d_b) = toward_ap_in_a(x, partial, g, body_from_array, c_in_w);
    let n = d_a.norm();
    if n < MIN_RANGE_M {
        return None;
    }
    let s = sin_aoa(&d_a);
    let ds_dd = (Vector3::y() - d_a * (s / n)).transpose() / n;
    let r_ba_t = body_from_array
        .rotation
        .to_rotation_matrix()
        .into_inner()
        .transpose();
    let pose = pose_at(x, partial, g);
    let r_t_t = pose
        .world_from_body
        .to_rotation_matrix()
        .into_inner()
        .transpose();
    let (j_rot, j_pos, _) = pose_at_jacobians(x, partial, g);
    let dd_dstate = r_ba_t * d_b.cross_matrix() * j_rot - r_ba_t * r_t_t * j_pos;
    Some(ConeJacobian {
        residual: s - sin_measured,
        d_state: ds_dd * dd_dstate,
        d_ap: ds_dd * r_ba_t * r_t_t,
    })
}

/// σ of the sin-residual for an AoA `aoa_rad` measured with σ `sigma_rad`:
/// `max(cos θ, COS_FLOOR)·σ_θ` (first-order `ds = cos θ dθ`, floored near endfire: see
/// [`COS_FLOOR`]).
pub fn sin_sigma(aoa_rad: f64, sigma_rad: f64) -> f64 {
    aoa_rad.cos().abs().max(COS_FLOOR) * sigma_rad
}

/// The bearings' robust loss (one reflection cannot drag the solution): the Cauchy loss
/// `ρ(s) = c² ln(1 + s/c²)` on a squared whitened residual `s`, and its IRLS weight
/// `ρ'(s) = 1 / (1 + s/c²)`.
pub fn cauchy(s: f64, c: f64) -> (f64, f64) {
    let c2 = c * c;
    (c2 * (s / c2).ln_1p(), 1.0 / (1.0 + s / c2))
}

#[cfg(test)]
#[path = "cone_tests.rs"]
mod tests;
