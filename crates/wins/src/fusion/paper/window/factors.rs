//! The linear factors of the window (paper Sec. V) in information form.
//!
//! IMU factor between frames k and k+1 (`eqn:imumodel`), with the accelerometer bias `b_a` as an
//! extra (border) unknown entering through the preintegration Jacobians:
//!
//! ```text
//! R_kᵀ (p_k+1 − p_k) − v_k Δt + g_k Δt²/2 − J_αa b_a = α̂ − J_αa b̂_a
//! ΔR v_k+1 − v_k + g_k Δt − J_βa b_a               = β̂ − J_βa b̂_a
//! ΔR g_k+1 − g_k                                    = 0
//! ```
//!
//! with `R_k = R_{b_k}^{b_0}` chained from the gyro. The gyro bias `b_g` is a border unknown too:
//! with `R_k = R̂_k Exp(Ψ_k δb_g)` and `ΔR = ΔR̂ Exp(J_θg δb_g)` the bilinear terms are linearized
//! at the previous solution (`R_kᵀ Δp ≈ R̂_kᵀ Δp + [R̂_kᵀ Δp̂]× Ψ_k δb_g`, `ΔR v ≈ ΔR̂ v −
//! ΔR̂ [v̂]× J_θg δb_g`, likewise for g), plus α's and β's own `J_αg`, `J_βg`. Its covariance is the preintegration
//! covariance mapped through `∂r/∂[δα, δβ, δθ] = [−I 0 0; 0 −I −ΔR[v̂]×; 0 0 −ΔR[ĝ]×]` at the
//! previous solution, plus the attitude uncertainty seen by the position term (σ_R·|Δp̂|) and a
//! small floor (the gravity row has no noise along ĝ, a rotation keeps norms).
//!
//! AoA factor of AP l at frame j (`eqn:wifi_measurement_model`): with `u` the measured direction
//! (in `b_j`, rotated to `b0` by `R_j`) and `t_ba` the array's offset on the body,
//! `c_l − p_j − R_j t_ba` is parallel to `u`; the cross product's two independent rows are kept
//! with their own weights. The paper takes `u = (cos θ, sin θ, 0)` in the array frame (AP in the
//! array plane); a tilted MAV then mixes its roll into the angle. Here the AP is assumed at the
//! array's *height* instead (horizontal `u`, using the gravity estimate), which is the same
//! 5-DoF assumption without the tilt error; see [`aoa_info`].

mod aoa;

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use std::ops::AddAssign;

use crate::fusion::arrow::{Block, FRAME_DIM, Vec9, forward_substitute};
use crate::imu::{ImuBiases, Preintegrated};
pub use aoa::{
    AoaFactorInput, AoaInfo, AoaPoint, AoaRow, AoaRows, AoaSigmas, aoa_info, aoa_residuals,
    aoa_rows, horizontal_direction,
};

/// Number of bias unknowns at the head of the border: accelerometer, then gyro.
pub const BIAS_DIM: usize = 6;

/// 9×6 block (frame rows, bias columns).
pub type Block96 = SMatrix<f64, FRAME_DIM, BIAS_DIM>;

/// 6×6 block.
pub type Matrix6 = SMatrix<f64, BIAS_DIM, BIAS_DIM>;

/// 6-vector.
pub type Vector6 = SVector<f64, BIAS_DIM>;

/// Information contributed by one IMU factor.
#[derive(Clone, Debug)]
pub struct ImuInfo {
    /// `H_kk`.
    pub h_kk: Block,
    /// `H_k+1,k+1`.
    pub h_ll: Block,
    /// `H_k+1,k`.
    pub h_lk: Block,
    /// `H_b,k` transposed (9×6: frame rows, bias columns).
    pub h_kb: Block96,
    /// `H_b,k+1` transposed.
    pub h_lb: Block96,
    /// `H_bb`.
    pub h_bb: Matrix6,
    /// Information vector of frame k.
    pub b_k: Vec9,
    /// Information vector of frame k+1.
    pub b_l: Vec9,
    /// Information vector of the biases.
    pub b_b: Vector6,
}

/// What the IMU factor needs besides the preintegration.
pub struct ImuFactorInput<'a> {
    /// The interval k → k+1.
    pub pre: &'a Preintegrated,
    /// `R_{b_k}^{b_0}`.
    pub b0_from_bk: &'a UnitQuaternion<f64>,
    /// The current gyro bias estimate (α, β, ΔR are corrected to it to first order).
    pub gyro_bias_rad_s: Vector3<f64>,
    /// `Ψ_k = ∂R_k/∂b_g` (right perturbation) and the gyro bias `b̂_k` at which `R_k` was
    /// chained: `R_k(b_g) ≈ R̂_k Exp(Ψ_k (b_g − b̂_k))`. `None` keeps the gyro bias out.
    pub psi_k: Option<(Matrix3<f64>, Vector3<f64>)>,
    /// Previous estimates of `v_k+1`, `g_k+1` and `p_k+1 − p_k` (in `b0`): the noise mapping and
    /// the gyro-bias linearization.
    pub v_next: Vector3<f64>,
    /// See `v_next`.
    pub g_next: Vector3<f64>,
    /// See `v_next`.
    pub step_in_b0: Vector3<f64>,
    /// Attitude 1σ, rad.
    pub attitude_sigma_rad: f64,
}

/// One IMU factor's rows `A_k x_k + A_l x_l + A_b b = z` with residual covariance `cov`.
#[derive(Clone, Debug)]
pub struct ImuRows {
    /// `A_k`.
    pub a_k: Block,
    /// `A_l` (frame k+1).
    pub a_l: Block,
    /// `A_b` (bias columns: accelerometer, gyro).
    pub a_b: Block96,
    /// Right side.
    pub z: Vec9,
    /// Residual covariance.
    pub cov: Block,
}

/// Linearizes one IMU factor (module doc) into information form.
pub fn imu_info(inp: &ImuFactorInput) -> Option<ImuInfo> {
    let ImuRows {
        mut a_k,
        mut a_l,
        mut a_b,
        mut z,
        cov,
    } = imu_rows(inp);
    // Whitened by the Cholesky factor of the covariance (`Σ = L Lᵀ`, `A' = L⁻¹ A`), so that
    // `Aᵀ Σ⁻¹ A = A'ᵀ A'` without forming the inverse.
    let l = nalgebra::Cholesky::new(cov)?.unpack();
    forward_substitute(&l, a_k.as_mut_slice());
    forward_substitute(&l, a_l.as_mut_slice());
    forward_substitute(&l, a_b.as_mut_slice());
    forward_substitute(&l, z.as_mut_slice());
    Some(ImuInfo {
        h_kk: a_k.tr_mul(&a_k),
        h_ll: a_l.tr_mul(&a_l),
        h_lk: a_l.tr_mul(&a_k),
        h_kb: a_k.tr_mul(&a_b),
        h_lb: a_l.tr_mul(&a_b),
        h_bb: a_b.tr_mul(&a_b),
        b_k: a_k.tr_mul(&z),
        b_l: a_l.tr_mul(&z),
        b_b: a_b.tr_mul(&z),
    })
}

/// The rows of one IMU factor (module doc).
pub fn imu_rows(inp: &ImuFactorInput) -> ImuRows {
    let pre = inp.pre;
    let dt = pre.dt_s();
    let r_k_t = inp.b0_from_bk.to_rotation_matrix().into_inner().transpose();
    // α, β, ΔR corrected for the gyro bias estimate; the accelerometer bias is an unknown.
    let gyro_only = ImuBiases {
        gyro_rad_s: inp.gyro_bias_rad_s,
        accel_m_s2: pre.bias.accel_m_s2,
    };
    let (alpha, beta, bk_from_bk1) = pre.corrected(&gyro_only);
    let d_r = bk_from_bk1.to_rotation_matrix().into_inner();
    let i3 = Matrix3::identity();

    let mut a_k = Block::zeros();
    a_k.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-r_k_t));
    a_k.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-dt * i3));
    a_k.fixed_view_mut::<3, 3>(0, 6)
        .copy_from(&(0.5 * dt * dt * i3));
    a_k.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-i3));
    a_k.fixed_view_mut::<3, 3>(3, 6).copy_from(&(dt * i3));
    a_k.fixed_view_mut::<3, 3>(6, 6).copy_from(&(-i3));
    let mut a_l = Block::zeros();
    a_l.fixed_view_mut::<3, 3>(0, 0).copy_from(&r_k_t);
    a_l.fixed_view_mut::<3, 3>(3, 3).copy_from(&d_r);
    a_l.fixed_view_mut::<3, 3>(6, 6).copy_from(&d_r);
    // Bias columns; every bias term is linear in the deviation from its linearization point
    // `b̂`, so the right side carries `A_b b̂`.
    let jb = &pre.jacobian_bias;
    let mut a_b = Block96::zeros();
    a_b.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-jb.fixed_view::<3, 3>(0, 0)));
    a_b.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(-jb.fixed_view::<3, 3>(3, 0)));
    // The rotation's own linearization point differs from the preintegration's.
    let mut z_rot = Vec9::zeros();
    if let Some((psi_k, lin_k)) = inp.psi_k {
        let j_theta_g = jb.fixed_view::<3, 3>(6, 3);
        let c_rot = (r_k_t * inp.step_in_b0).cross_matrix() * psi_k;
        a_b.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-jb.fixed_view::<3, 3>(0, 3) + c_rot));
        z_rot
            .fixed_rows_mut::<3>(0)
            .copy_from(&(c_rot * (lin_k - inp.gyro_bias_rad_s)));
        a_b.fixed_view_mut::<3, 3>(3, 3).copy_from(
            &(-jb.fixed_view::<3, 3>(3, 3) - d_r * inp.v_next.cross_matrix() * j_theta_g),
        );
        a_b.fixed_view_mut::<3, 3>(6, 3)
            .copy_from(&(-d_r * inp.g_next.cross_matrix() * j_theta_g));
    }
    let mut b_hat = Vector6::zeros();
    b_hat.fixed_rows_mut::<3>(0).copy_from(&pre.bias.accel_m_s2);
    b_hat.fixed_rows_mut::<3>(3).copy_from(&inp.gyro_bias_rad_s);

    let mut z = a_b * b_hat + z_rot;
    z.fixed_rows_mut::<3>(0).add_assign(&alpha);
    z.fixed_rows_mut::<3>(3).add_assign(&beta);

    // Residual covariance.
    let mut m = Block::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-i3));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-i3));
    m.fixed_view_mut::<3, 3>(3, 6)
        .copy_from(&(-d_r * inp.v_next.cross_matrix()));
    m.fixed_view_mut::<3, 3>(6, 6)
        .copy_from(&(-d_r * inp.g_next.cross_matrix()));
    let mut cov = m * pre.covariance * m.transpose();
    let att = (inp.attitude_sigma_rad * inp.step_in_b0.norm()).powi(2);
    for i in 0..3 {
        cov[(i, i)] += att + 1e-12;
        cov[(3 + i, 3 + i)] += 1e-10;
        cov[(6 + i, 6 + i)] += 1e-8;
    }
    ImuRows {
        a_k,
        a_l,
        a_b,
        z,
        cov,
    }
}

#[cfg(test)]
mod tests;
