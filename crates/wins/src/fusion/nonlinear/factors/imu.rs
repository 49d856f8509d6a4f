//! The IMU preintegration factor between keyframes `i` and `j` (Forster et al. RSS 2015 /
//! TRO 2017, eqs. 44–45; paper `eqn:imumodel` on the manifold).
//!
//! `pre` is the interval from `x_i.t` to `x_j.t`, linearized at `b̄ = pre.bias`; with
//! `δb = b_i − b̄` and `(α, β, ΔR) = pre.corrected(b_i)` (first order), `Δt = pre.dt_s()` and
//! `g_w = (0, 0, −g)`, the residual (ordered like the error state) is
//!
//! ```text
//! r_θ  = Log(ΔR(b_i)ᵀ R_iᵀ R_j)
//! r_p  = R_iᵀ (p_j − p_i − v_i Δt − ½ g_w Δt²) − α(b_i)
//! r_v  = R_iᵀ (v_j − v_i − g_w Δt) − β(b_i)
//! r_bg = b_g,j − b_g,i          r_ba = b_a,j − b_a,i
//! ```
//!
//! Forster orders the residual `[r_R, r_v, r_p]` and writes the paper's α as `Δp`; here the order
//! is the state's `[θ, p, v, b_g, b_a]`, and the bias random walk is part of the same factor.

use nalgebra::Matrix3;

use crate::fusion::nonlinear::state::{
    BA, BG, Mat15, NavState, POS, THETA, VEL, Vec15, gravity_in_w,
};
use crate::imu::Preintegrated;
use crate::rig::ImuNoise;
use crate::so3::{exp, log, right_jacobian, right_jacobian_inverse};

/// Added to every variance of [`imu_covariance`] so that it inverts even when a density is zero,
/// the interval is empty, or it spans a single IMU sub-interval (whose 9×9 preintegration
/// covariance has rank 6). Two to three orders below the smallest variance of a real IMU over a
/// 5 ms interval (gyro bias random walk of a MicroStrain 3DM-GX4-25: ≈ 1e-13 rad²/s²).
pub const IMU_VARIANCE_FLOOR: f64 = 1e-16;

/// The parts of the residual shared by [`imu_residual`] and [`imu_jacobians`].
struct Parts {
    /// `r`.
    r: Vec15,
    /// `R_iᵀ (p_j − p_i − v_i Δt − ½ g_w Δt²)`.
    dp_in_i: nalgebra::Vector3<f64>,
    /// `R_iᵀ (v_j − v_i − g_w Δt)`.
    dv_in_i: nalgebra::Vector3<f64>,
    /// `φ = J_θ δb`, the rotation's bias correction.
    phi: nalgebra::Vector3<f64>,
}

fn parts(pre: &Preintegrated, g: f64, xi: &NavState, xj: &NavState) -> Parts {
    let (alpha, beta, rot) = pre.corrected(&xi.biases());
    let jb = &pre.jacobian_bias;
    let phi = jb.fixed_view::<3, 3>(6, 0) * (xi.accel_bias_m_s2 - pre.bias.accel_m_s2)
        + jb.fixed_view::<3, 3>(6, 3) * (xi.gyro_bias_rad_s - pre.bias.gyro_rad_s);
    let dt = pre.dt_s();
    let g_w = gravity_in_w(g);
    let ri = xi.world_from_body;
    let dp_in_i = ri.inverse_transform_vector(
        &(xj.p_b_in_w - xi.p_b_in_w - xi.v_b_in_w * dt - g_w * (0.5 * dt * dt)),
    );
    let dv_in_i = ri.inverse_transform_vector(&(xj.v_b_in_w - xi.v_b_in_w - g_w * dt));
    let mut r = Vec15::zeros();
    r.fixed_rows_mut::<3>(THETA)
        .copy_from(&log(&(rot.inverse() * ri.inverse() * xj.world_from_body)));
    r.fixed_rows_mut::<3>(POS).copy_from(&(dp_in_i - alpha));
    r.fixed_rows_mut::<3>(VEL).copy_from(&(dv_in_i - beta));
    r.fixed_rows_mut::<3>(BG)
        .copy_from(&(xj.gyro_bias_rad_s - xi.gyro_bias_rad_s));
    r.fixed_rows_mut::<3>(BA)
        .copy_from(&(xj.accel_bias_m_s2 - xi.accel_bias_m_s2));
    Parts {
        r,
        dp_in_i,
        dv_in_i,
        phi,
    }
}

/// The IMU residual `[r_θ, r_p, r_v, r_bg, r_ba]` (module doc) for gravity magnitude `g`.
pub fn imu_residual(pre: &Preintegrated, g: f64, xi: &NavState, xj: &NavState) -> Vec15 {
    parts(pre, g, xi, xj).r
}

/// `(∂r/∂δx_i, ∂r/∂δx_j)`, analytic. With `J` = `pre.jacobian_bias` (rows α, β, θ; columns
/// `b_a`, `b_g`), `φ = J_θ δb` and `Δp̃`, `Δṽ` the bracketed terms of `r_p`, `r_v` in `b_i`:
///
/// ```text
/// ∂r_θ/∂δθ_i = −J_r⁻¹(r_θ) R_jᵀ R_i     ∂r_θ/∂δθ_j = J_r⁻¹(r_θ)
/// ∂r_θ/∂δb_i = −J_r⁻¹(r_θ) Exp(r_θ)ᵀ J_r(φ) J_θ         (Forster 2017 eq. 45 form)
/// ∂r_p/∂δθ_i = [Δp̃]×   ∂r_p/∂δp_i = −R_iᵀ   ∂r_p/∂δv_i = −R_iᵀ Δt   ∂r_p/∂δb_i = −J_α
/// ∂r_p/∂δp_j = R_iᵀ
/// ∂r_v/∂δθ_i = [Δṽ]×   ∂r_v/∂δv_i = −R_iᵀ   ∂r_v/∂δb_i = −J_β        ∂r_v/∂δv_j = R_iᵀ
/// ∂r_b/∂δb_i = −I       ∂r_b/∂δb_j = I
/// ```
pub fn imu_jacobians(pre: &Preintegrated, g: f64, xi: &NavState, xj: &NavState) -> (Mat15, Mat15) {
    let Parts {
        r,
        dp_in_i,
        dv_in_i,
        phi,
    } = parts(pre, g, xi, xj);
    let r_theta = r.fixed_rows::<3>(THETA).into_owned();
    let jri = right_jacobian_inverse(&r_theta);
    let ri_t = xi
        .world_from_body
        .to_rotation_matrix()
        .into_inner()
        .transpose();
    let rj_t_ri = (xj.world_from_body.inverse() * xi.world_from_body)
        .to_rotation_matrix()
        .into_inner();
    let jb = &pre.jacobian_bias;
    let dt = pre.dt_s();
    let d_rot_bias =
        -jri * exp(&r_theta).to_rotation_matrix().into_inner().transpose() * right_jacobian(&phi);
    let eye = Matrix3::identity();

    let mut ji = Mat15::zeros();
    ji.fixed_view_mut::<3, 3>(THETA, THETA)
        .copy_from(&(-jri * rj_t_ri));
    ji.fixed_view_mut::<3, 3>(THETA, BG)
        .copy_from(&(d_rot_bias * jb.fixed_view::<3, 3>(6, 3)));
    ji.fixed_view_mut::<3, 3>(THETA, BA)
        .copy_from(&(d_rot_bias * jb.fixed_view::<3, 3>(6, 0)));

    ji.fixed_view_mut::<3, 3>(POS, THETA)
        .copy_from(&dp_in_i.cross_matrix());
    ji.fixed_view_mut::<3, 3>(POS, POS).copy_from(&(-ri_t));
    ji.fixed_view_mut::<3, 3>(POS, VEL).copy_from(&(-ri_t * dt));
    ji.fixed_view_mut::<3, 3>(POS, BG)
        .copy_from(&(-jb.fixed_view::<3, 3>(0, 3)));
    ji.fixed_view_mut::<3, 3>(POS, BA)
        .copy_from(&(-jb.fixed_view::<3, 3>(0, 0)));

    ji.fixed_view_mut::<3, 3>(VEL, THETA)
        .copy_from(&dv_in_i.cross_matrix());
    ji.fixed_view_mut::<3, 3>(VEL, VEL).copy_from(&(-ri_t));
    ji.fixed_view_mut::<3, 3>(VEL, BG)
        .copy_from(&(-jb.fixed_view::<3, 3>(3, 3)));
    ji.fixed_view_mut::<3, 3>(VEL, BA)
        .copy_from(&(-jb.fixed_view::<3, 3>(3, 0)));

    ji.fixed_view_mut::<3, 3>(BG, BG).copy_from(&(-eye));
    ji.fixed_view_mut::<3, 3>(BA, BA).copy_from(&(-eye));

    let mut jj = Mat15::zeros();
    jj.fixed_view_mut::<3, 3>(THETA, THETA).copy_from(&jri);
    jj.fixed_view_mut::<3, 3>(POS, POS).copy_from(&ri_t);
    jj.fixed_view_mut::<3, 3>(VEL, VEL).copy_from(&ri_t);
    jj.fixed_view_mut::<3, 3>(BG, BG).copy_from(&eye);
    jj.fixed_view_mut::<3, 3>(BA, BA).copy_from(&eye);
    (ji, jj)
}

/// Covariance of the residual: `pre.covariance` (over `[δα, δβ, δθ]`) moved to the `[θ, p, v]`
/// slots, the bias random walks `σ_bg² Δt`, `σ_ba² Δt` (densities from `noise`) on the bias
/// slots, and [`IMU_VARIANCE_FLOOR`] added to every variance. At the true states the residual is
/// the preintegration's error `[δθ, δα, δβ]` (true − measured, rotation on the right), so the
/// blocks move without a sign change or transformation.
pub fn imu_covariance(pre: &Preintegrated, noise: &ImuNoise) -> Mat15 {
    // Preintegration rows/columns: α at 0, β at 3, θ at 6.
    let slot = [POS, VEL, THETA];
    let mut cov = Mat15::zeros();
    for (a, &sa) in slot.iter().enumerate() {
        for (b, &sb) in slot.iter().enumerate() {
            cov.fixed_view_mut::<3, 3>(sa, sb)
                .copy_from(&pre.covariance.fixed_view::<3, 3>(3 * a, 3 * b));
        }
    }
    let dt = pre.dt_s().max(0.0);
    let var_bg = noise.gyro_bias_random_walk_rad_s2_sqrt_hz.powi(2) * dt;
    let var_ba = noise.accel_bias_random_walk_m_s3_sqrt_hz.powi(2) * dt;
    for k in 0..3 {
        cov[(BG + k, BG + k)] += var_bg;
        cov[(BA + k, BA + k)] += var_ba;
    }
    for k in 0..15 {
        cov[(k, k)] += IMU_VARIANCE_FLOOR;
    }
    (cov + cov.transpose()) * 0.5
}

/// The information matrix `Σ⁻¹` of [`imu_covariance`], symmetric; `None` when the covariance is
/// not finite or not positive definite (Cholesky fails).
pub fn imu_information(pre: &Preintegrated, noise: &ImuNoise) -> Option<Mat15> {
    let cov = imu_covariance(pre, noise);
    if !cov.iter().all(|x| x.is_finite()) {
        return None;
    }
    let info = cov.cholesky()?.inverse();
    Some((info + info.transpose()) * 0.5)
}

#[cfg(test)]
#[path = "imu_tests.rs"]
mod tests;
