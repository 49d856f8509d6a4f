//! The AoA factor (module doc of [`super`]): an AP's bearing at a frame as rows on the AP's and
//! the frame's positions (and the gyro bias), algebraic with a range or angles linearized at a
//! point, their residuals, and the horizontal direction they assume.

use nalgebra::{Isometry3, Matrix3, UnitQuaternion, Vector3};

use crate::fusion::bearing::{Bearing, Side};

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
