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

use nalgebra::{Isometry3, Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use std::ops::AddAssign;

use crate::fusion::arrow::{Block, FRAME_DIM, Vec9, forward_substitute};
use crate::fusion::bearing::{Bearing, Side};
use crate::imu::{ImuBiases, Preintegrated};

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

/// Information contributed by one AoA factor: rows `jᵀ (c − p) + gᵀ b_g = y`.
#[derive(Clone, Copy, Debug)]
pub struct AoaInfo {
    /// `N = Σ w j jᵀ` (acts on `p` and `c` with opposite signs).
    pub n: Matrix3<f64>,
    /// `Σ w j y`: information vector of `c` (minus it for `p`).
    pub b_c: Vector3<f64>,
    /// `Σ w j gᵀ`: the `(c, b_g)` block (minus it for `(p, b_g)`).
    pub n_cg: Matrix3<f64>,
    /// `Σ w g gᵀ`: the `(b_g, b_g)` block.
    pub n_gg: Matrix3<f64>,
    /// `Σ w g y`: information vector of `b_g`.
    pub b_g: Vector3<f64>,
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
/// `n = up × u` (the bearing, σ_β the cone-angle σ mapped to azimuth) and `up` itself (the AP at
/// the array's height, σ_e).
///
/// Without a linearization point each row is the paper's algebraic one, `nᵀ x / λ` with
/// `x = c − p − R t_ba` and a given range λ. That residual shrinks with the geometry, so least
/// squares favours a too-small scale by O(σ²) (the pseudo-linear bias of bearing-only
/// localization). With a point `x̂` the row is the angle `nᵀ x / |x|` linearized there:
/// `J = (n − (nᵀû) û)ᵀ / |x̂|`, `J x̂ = 0`, right side `−nᵀû`; it does not change along `x̂`, so only
/// the IMU sets the scale. With `gyro = Some((Ψ_j, b̂_g))` the rows also take the gyro bias,
/// through `R_j = R̂_j Exp(Ψ_j δb_g)` (direction and array offset), linearized at the point.
/// `None` when the cone angle cannot be met by a horizontal direction
/// (array axis near vertical).
pub fn aoa_info(inp: &AoaFactorInput) -> Option<AoaInfo> {
    let rows = aoa_rows(inp)?;
    let mut info = AoaInfo {
        n: Matrix3::zeros(),
        b_c: Vector3::zeros(),
        n_cg: Matrix3::zeros(),
        n_gg: Matrix3::zeros(),
        b_g: Vector3::zeros(),
    };
    for &AoaRow { j, g, y, var } in rows.as_slice() {
        info.n += j * j.transpose() / var;
        info.b_c += j * y / var;
        info.n_cg += j * g.transpose() / var;
        info.n_gg += g * g.transpose() / var;
        info.b_g += g * y / var;
    }
    Some(info)
}

/// One row of an AoA factor: `jᵀ (c − p) + gᵀ b_g = y` with variance `var`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoaRow {
    /// Coefficients of `c` (and minus those of `p`).
    pub j: Vector3<f64>,
    /// Coefficients of the gyro bias (zero unless it is estimated).
    pub g: Vector3<f64>,
    /// Right side.
    pub y: f64,
    /// Variance.
    pub var: f64,
}

/// What an AoA factor needs (see [`aoa_info`]).
#[derive(Clone, Copy, Debug)]
pub struct AoaFactorInput<'a> {
    /// The bearing.
    pub bearing: &'a Bearing,
    /// `R_{b_j}^{b_0}` (at the gyro bias `b̂_j`).
    pub b0_from_bj: &'a UnitQuaternion<f64>,
    /// Upward gravity in `b_j` (any length).
    pub up_in_bj: &'a Vector3<f64>,
    /// Pose of the array on the body.
    pub body_from_array: &'a Isometry3<f64>,
    /// Where the rows are linearized.
    pub point: AoaPoint,
    /// `(Ψ_j, b̂_j)` when the gyro bias is an unknown.
    pub gyro: Option<(&'a Matrix3<f64>, &'a Vector3<f64>)>,
    /// The 1σ besides the bearing's own.
    pub sigmas: AoaSigmas,
}

/// The rows of [`aoa_info`]: at most two.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoaRows {
    rows: [AoaRow; 2],
    len: usize,
}

impl AoaRows {
    /// The rows.
    pub fn as_slice(&self) -> &[AoaRow] {
        &self.rows[..self.len]
    }
}

/// The rows of [`aoa_info`]. Algebraic (`AoaPoint::Range`): the horizontal normal and the
/// AP-at-array-height row. At a point (`AoaPoint::At`): with [`AoaSigmas::cone`] the exact
/// measurement of a linear array, the cone `âᵀ x / |x| = sin θ` (`â` the array axis in `b0`), no
/// elevation assumed and no side needed (the point is on one); else the two angle rows of the
/// horizontal model.
pub fn aoa_rows(inp: &AoaFactorInput) -> Option<AoaRows> {
    let AoaFactorInput {
        b0_from_bj,
        body_from_array,
        point,
        gyro,
        ..
    } = *inp;
    let t_ba = body_from_array.translation.vector;
    let offset = b0_from_bj * t_ba;
    let r_j = b0_from_bj.to_rotation_matrix().into_inner();
    // The row `dir_bᵀ R_jᵀ x / |x| = target` (or `… / λ` without a point) in `b_j`.
    let row = |&RowModel { dir_b, target, var }: &RowModel| {
        let dir = b0_from_bj * dir_b;
        let (j, r0, unit) = match point {
            AoaPoint::Range(range_m) => (dir / range_m, 0.0, None),
            AoaPoint::At(x) => {
                let range_m = x.norm();
                let unit = x / range_m;
                let along = dir.dot(&unit);
                ((dir - unit * along) / range_m, along, Some(unit))
            }
        };
        let mut y = j.dot(&offset) - r0 + target;
        let mut g = Vector3::zeros();
        if let (Some((psi, b_hat)), Some(unit)) = (gyro, unit) {
            // ∂r/∂b_g = jᵀ R̂ [t]× Ψ − ûᵀ R̂ [d_b]× Ψ.
            g = (j.transpose() * r_j * t_ba.cross_matrix() * psi
                - unit.transpose() * r_j * dir_b.cross_matrix() * psi)
                .transpose();
            y += g.dot(b_hat);
        }
        AoaRow { j, g, y, var }
    };
    let (models, len) = row_models(inp)?;
    Some(AoaRows {
        rows: [row(&models[0]), row(&models[1])],
        len,
    })
}

/// The residuals of [`aoa_rows`] at their own point, as `(dir · x/|x| − target, variance)` per
/// row (the row's `J x = 0` there, so the residual is the model's angle error itself, without
/// the Jacobians). `None` without a point (`AoaPoint::Range`) or where [`aoa_rows`] is `None`.
pub fn aoa_residuals(inp: &AoaFactorInput) -> Option<([(f64, f64); 2], usize)> {
    let AoaPoint::At(x) = inp.point else {
        return None;
    };
    let unit = x.try_normalize(0.0)?;
    let (models, len) = row_models(inp)?;
    let residual = |m: &RowModel| ((inp.b0_from_bj * m.dir_b).dot(&unit) - m.target, m.var);
    Some(([residual(&models[0]), residual(&models[1])], len))
}

/// One AoA row before linearization: `dir_bᵀ R_jᵀ x / |x| = target` with variance `var`.
#[derive(Clone, Copy, Debug)]
struct RowModel {
    dir_b: Vector3<f64>,
    target: f64,
    var: f64,
}

/// The rows' models of [`aoa_rows`] (the cone, or the horizontal model's two) and how many.
fn row_models(inp: &AoaFactorInput) -> Option<([RowModel; 2], usize)> {
    let AoaFactorInput {
        bearing,
        up_in_bj,
        body_from_array,
        point,
        sigmas,
        ..
    } = *inp;
    if sigmas.cone && matches!(point, AoaPoint::At(_)) {
        // δ sin θ = cos θ δθ; the attitude turns the axis by the same angle.
        let cos2 = bearing.aoa_rad.cos().max(COS_FLOOR).powi(2);
        let cone = RowModel {
            dir_b: body_from_array.rotation * Vector3::y(),
            target: bearing.aoa_rad.sin(),
            var: cos2 * (bearing.sigma_rad.powi(2) + sigmas.attitude_rad.powi(2)),
        };
        return Some(([cone, cone], 1));
    }
    let (u, up, s, sin_b) = horizontal_direction(bearing, up_in_bj, body_from_array)?;
    // δθ cos θ = −s sin β δβ.
    let sigma_beta = bearing.sigma_rad * bearing.aoa_rad.cos() / (s * sin_b.abs()).max(0.1);
    let models = [
        RowModel {
            dir_b: up.cross(&u),
            target: 0.0,
            var: sigma_beta.powi(2) + sigmas.attitude_rad.powi(2),
        },
        RowModel {
            dir_b: up,
            target: 0.0,
            var: sigmas.elevation_rad.powi(2),
        },
    ];
    Some((models, 2))
}

/// `cos θ` floor of the cone row's variance (θ near ±90° would make it vanish).
const COS_FLOOR: f64 = 0.1;

/// Where an AoA row is linearized (see [`aoa_info`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AoaPoint {
    /// The algebraic row with this range λ, m.
    Range(f64),
    /// The angle row at this estimate of `c − p − R t_ba` in `b0`, m (its norm must be positive).
    At(Vector3<f64>),
}

/// The 1σ of an AoA factor's rows besides the bearing's own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoaSigmas {
    /// Attitude 1σ, rad.
    pub attitude_rad: f64,
    /// 1σ of the AP-at-array-height assumption, rad.
    pub elevation_rad: f64,
    /// At a linearization point, use the exact cone row instead of the horizontal model.
    pub cone: bool,
}

#[cfg(test)]
mod tests;
