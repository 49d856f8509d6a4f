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
//! with `R_k = R_{b_k}^{b_0}` from the attitude stage. Its covariance is the preintegration
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

use nalgebra::{Isometry3, Matrix3, SMatrix, UnitQuaternion, Vector3};

use super::arrow::{Block, FRAME_DIM, Vec9};
use crate::fusion::bearing::{Bearing, Side};
use crate::imu::{ImuBiases, Preintegrated};

/// 9×3 block.
pub type Block93 = SMatrix<f64, FRAME_DIM, 3>;

/// Information contributed by one IMU factor.
#[derive(Clone, Debug)]
pub struct ImuInfo {
    /// `H_kk`.
    pub h_kk: Block,
    /// `H_k+1,k+1`.
    pub h_ll: Block,
    /// `H_k+1,k`.
    pub h_lk: Block,
    /// `H_b,k` transposed (9×3: frame rows, bias columns).
    pub h_kb: Block93,
    /// `H_b,k+1` transposed.
    pub h_lb: Block93,
    /// `H_bb`.
    pub h_bb: Matrix3<f64>,
    /// Information vector of frame k.
    pub b_k: Vec9,
    /// Information vector of frame k+1.
    pub b_l: Vec9,
    /// Information vector of the bias.
    pub b_b: Vector3<f64>,
}

/// What the IMU factor needs besides the preintegration.
pub struct ImuFactorInput<'a> {
    /// The interval k → k+1.
    pub pre: &'a Preintegrated,
    /// `R_{b_k}^{b_0}`.
    pub b0_from_bk: &'a UnitQuaternion<f64>,
    /// The current gyro bias estimate (α, β, ΔR are corrected to it to first order).
    pub gyro_bias_rad_s: Vector3<f64>,
    /// Previous estimates of `v_k+1`, `g_k+1` (for the noise mapping) and `|p_k+1 − p_k|`.
    pub v_next: Vector3<f64>,
    /// See `v_next`.
    pub g_next: Vector3<f64>,
    /// See `v_next`.
    pub step_m: f64,
    /// Attitude 1σ, rad.
    pub attitude_sigma_rad: f64,
}

/// Linearizes one IMU factor (module doc).
pub fn imu_info(inp: &ImuFactorInput) -> Option<ImuInfo> {
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
    let mut a_b = Block93::zeros();
    let j_alpha_a = pre.jacobian_bias.fixed_view::<3, 3>(0, 0);
    let j_beta_a = pre.jacobian_bias.fixed_view::<3, 3>(3, 0);
    a_b.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-j_alpha_a));
    a_b.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-j_beta_a));

    let mut z = Vec9::zeros();
    z.fixed_rows_mut::<3>(0)
        .copy_from(&(alpha - j_alpha_a * pre.bias.accel_m_s2));
    z.fixed_rows_mut::<3>(3)
        .copy_from(&(beta - j_beta_a * pre.bias.accel_m_s2));

    // Residual covariance.
    let mut m = Block::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-i3));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-i3));
    m.fixed_view_mut::<3, 3>(3, 6)
        .copy_from(&(-d_r * inp.v_next.cross_matrix()));
    m.fixed_view_mut::<3, 3>(6, 6)
        .copy_from(&(-d_r * inp.g_next.cross_matrix()));
    let mut cov = m * pre.covariance * m.transpose();
    let att = (inp.attitude_sigma_rad * inp.step_m).powi(2);
    for i in 0..3 {
        cov[(i, i)] += att + 1e-12;
        cov[(3 + i, 3 + i)] += 1e-10;
        cov[(6 + i, 6 + i)] += 1e-8;
    }
    let w = cov.try_inverse()?;
    let w = (w + w.transpose()) * 0.5;
    let wa_k = w * a_k;
    let wa_l = w * a_l;
    let wa_b = w * a_b;
    let wz = w * z;
    Some(ImuInfo {
        h_kk: a_k.transpose() * wa_k,
        h_ll: a_l.transpose() * wa_l,
        h_lk: a_l.transpose() * wa_k,
        h_kb: a_k.transpose() * wa_b,
        h_lb: a_l.transpose() * wa_b,
        h_bb: a_b.transpose() * wa_b,
        b_k: a_k.transpose() * wz,
        b_l: a_l.transpose() * wz,
        b_b: a_b.transpose() * wz,
    })
}

/// Information contributed by one AoA factor: `N (c − p)` rows.
#[derive(Clone, Copy, Debug)]
pub struct AoaInfo {
    /// `N = Σ w_i n_i n_iᵀ` (acts on `p` and `c` with opposite signs).
    pub n: Matrix3<f64>,
    /// `Σ w_i n_i (n_iᵀ R_j t_ba)`: information vector of `c` (minus it for `p`).
    pub b_c: Vector3<f64>,
}

/// The horizontal unit direction `u` in `b_j` with the bearing's cone angle on its side (see
/// [`aoa_info`]), with the unit `up`, the horizontal length `s` of the array axis and `sin β`.
pub fn horizontal_direction(
    bearing: &Bearing,
    up_in_bj: &Vector3<f64>,
    body_from_array: &Isometry3<f64>,
) -> Option<(Vector3<f64>, Vector3<f64>, f64, f64)> {
    let up = up_in_bj.try_normalize(1e-9)?;
    let y_a = body_from_array.rotation * Vector3::y();
    let x_a = body_from_array.rotation * Vector3::x();
    let h1 = y_a - up * y_a.dot(&up);
    let s = h1.norm();
    if s < 0.2 {
        return None;
    }
    let e1 = h1 / s;
    let e2 = up.cross(&e1);
    let cos_b = (bearing.aoa_rad.sin() / s).clamp(-1.0, 1.0);
    let sin_b_abs = (1.0 - cos_b * cos_b).max(0.0).sqrt();
    // Of the two horizontal directions with this cone angle, the one on the measured side.
    let front = (e1 * cos_b + e2 * sin_b_abs).dot(&x_a) >= (e1 * cos_b - e2 * sin_b_abs).dot(&x_a);
    let sin_b = match (bearing.side, front) {
        (Side::Front, true) | (Side::Back, false) => sin_b_abs,
        _ => -sin_b_abs,
    };
    let u = e1 * cos_b + e2 * sin_b;
    Some((u, up, s, sin_b))
}

/// Linearizes one AoA factor (module doc), for an AP at the array's height: the direction `u`
/// toward it is horizontal (`u · up = 0`, `up` the unit upward gravity in `b_j`) and has the
/// measured cone angle (`u · ŷ_a = sin θ`) on the measured side. Rows: the horizontal normal
/// `up × u` (the bearing, weight `1/(λ σ_β)²` with σ_β the cone-angle σ mapped to azimuth) and
/// `up` itself (the AP at the array's height, weight `1/(λ σ_e)²`). `None` when the cone angle
/// cannot be met by a horizontal direction (array axis near vertical).
#[allow(clippy::too_many_arguments)]
pub fn aoa_info(
    bearing: &Bearing,
    b0_from_bj: &UnitQuaternion<f64>,
    up_in_bj: &Vector3<f64>,
    body_from_array: &Isometry3<f64>,
    range_m: f64,
    attitude_sigma_rad: f64,
    elevation_sigma_rad: f64,
) -> Option<AoaInfo> {
    let (u, up, s, sin_b) = horizontal_direction(bearing, up_in_bj, body_from_array)?;
    // δθ cos θ = −s sin β δβ.
    let sigma_beta = bearing.sigma_rad * bearing.aoa_rad.cos() / (s * sin_b.abs()).max(0.1);
    let sigma_theta2 = sigma_beta.powi(2) + attitude_sigma_rad.powi(2);
    let offset = b0_from_bj * body_from_array.translation.vector;
    let mut n = Matrix3::zeros();
    let mut b_c = Vector3::zeros();
    for (dir_b, var) in [
        (up.cross(&u), sigma_theta2),
        (up, elevation_sigma_rad.powi(2)),
    ] {
        let dir = b0_from_bj * dir_b;
        let w = 1.0 / (range_m * range_m * var);
        n += w * dir * dir.transpose();
        b_c += w * dir * dir.dot(&offset);
    }
    Some(AoaInfo { n, b_c })
}
