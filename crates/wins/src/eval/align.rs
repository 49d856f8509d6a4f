//! Alignment of estimated positions onto truth positions before the ATE, two ways
//! ([`AlignMode`]):
//!
//! - **yaw and translation** (the default, 4 degrees of freedom): what an inertial estimator
//!   leaves free. Gravity fixes roll and pitch, so a trajectory that comes out tilted, upside
//!   down or mirrored is an error, not a frame to rotate away; only the heading and the origin of
//!   the estimate's world are arbitrary (the tutorial of Zhang and Scaramuzza, IROS 2018, §III-A:
//!   "position and yaw" for visual-inertial odometry). The yaw maximizes `Σ tᵢ · R_z(ψ) eᵢ` over
//!   the centred pairs: `ψ = atan2(C_yx − C_xy, C_xx + C_yy)` with `C = Σ (tᵢ − t̄)(eᵢ − ē)ᵀ`.
//! - **SE(3)** (rotation and translation, no scale: Umeyama 1991), exactly what `evo_ape … -a`
//!   applies, for comparison with evo.
//!
//! Poses whose positions cannot fix the rotation (a take-off straight up and a hover: a line)
//! take it from their attitudes instead ([`align_poses`], `super::attitude_alignment`), and the
//! alignment says so ([`Alignment::rotation_from_attitudes`]).

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::EvalError;
use super::attitude_alignment::AttitudeMean;
use crate::dataset::truth::Pose;

/// Which rigid motions the alignment may apply to the estimate (module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AlignMode {
    /// A rotation about the vertical and a translation (gravity is observed).
    #[default]
    PosYaw,
    /// Any rotation and a translation (evo's `-a`).
    Se3,
}

impl AlignMode {
    /// The name written in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::PosYaw => "posyaw",
            Self::Se3 => "se3",
        }
    }
}

/// Fewest point pairs that can fix a rotation.
pub const MIN_ALIGNMENT_PAIRS: usize = 3;

/// The second singular value of the cross-covariance must exceed this fraction of the first;
/// below it the points are collinear (or do not move) and the rotation about their line is free.
pub const MIN_RELATIVE_SINGULAR_VALUE: f64 = 1e-9;

/// The rigid transform `truth_world_from_est_world` found by [`umeyama`]:
/// `p_in_truth_w = R · p_in_est_w + t`. Serialized as `{"rotation_xyzw": [x, y, z, w],
/// "translation_m": [x, y, z]}` so that it can be re-applied elsewhere.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Alignment {
    /// Rotation `R` as a Hamilton unit quaternion, components `[x, y, z, w]`.
    pub rotation_xyzw: [f64; 4],
    /// Translation `t`, m.
    pub translation_m: [f64; 3],
    /// The positions could not fix the rotation (all on one line, or still), so it was taken
    /// from the attitudes (module doc).
    #[serde(default)]
    pub rotation_from_attitudes: bool,
}

impl Alignment {
    /// The identity (no alignment).
    pub fn identity() -> Self {
        Self::from_isometry(&Isometry3::identity())
    }

    /// From a rigid transform `truth_world_from_est_world`.
    pub fn from_isometry(truth_w_from_est_w: &Isometry3<f64>) -> Self {
        let q = truth_w_from_est_w.rotation.quaternion();
        let t = truth_w_from_est_w.translation.vector;
        Self {
            rotation_xyzw: [q.i, q.j, q.k, q.w],
            translation_m: [t.x, t.y, t.z],
            rotation_from_attitudes: false,
        }
    }

    /// The rigid transform `truth_world_from_est_world` (the quaternion is renormalized).
    pub fn isometry(&self) -> Isometry3<f64> {
        let [x, y, z, w] = self.rotation_xyzw;
        let [tx, ty, tz] = self.translation_m;
        Isometry3::from_parts(
            Translation3::new(tx, ty, tz),
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)),
        )
    }

    /// A point of the estimate's world expressed in the truth's world.
    pub fn apply_point(&self, p_in_est_w: &Vector3<f64>) -> Vector3<f64> {
        self.isometry()
            .transform_point(&(*p_in_est_w).into())
            .coords
    }

    /// An estimated pose expressed in the truth's world (`T_align · T_est`, as evo aligns).
    pub fn apply_pose(&self, est: &Pose) -> Pose {
        let iso = self.isometry();
        Pose {
            t: est.t,
            p_b_in_w: iso.transform_point(&est.p_b_in_w.into()).coords,
            world_from_body: iso.rotation * est.world_from_body,
        }
    }
}

/// Least-squares rigid transform taking `est[i]` onto `truth[i]` (Umeyama 1991, eqs. 34–43 with
/// scale fixed to 1; the reflection guard of eq. 43 keeps `det R = +1`).
///
/// Errors: different lengths, fewer than `MIN_ALIGNMENT_PAIRS` pairs, or a degenerate
/// cross-covariance (all points on one line, or all equal: see `MIN_RELATIVE_SINGULAR_VALUE`).
/// Planar point sets are fine: the reflection guard fixes the third axis.
pub fn umeyama(est: &[Vector3<f64>], truth: &[Vector3<f64>]) -> Result<Alignment, EvalError> {
    align(est, truth, AlignMode::Se3)
}

/// Least-squares rigid transform of `mode` taking `est[i]` onto `truth[i]` (module doc; SE(3)
/// is [`umeyama`]).
///
/// Errors: different lengths, fewer than `MIN_ALIGNMENT_PAIRS` pairs, or points that cannot fix
/// the rotation (SE(3): all on one line or all equal; yaw: no horizontal spread).
pub fn align(
    est: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    mode: AlignMode,
) -> Result<Alignment, EvalError> {
    align_pairs(est, truth, mode, |p| p, |c, x, y| c.push(x, y))
}

/// [`align`] of the poses' positions; when they cannot fix the rotation, the rotation of the
/// poses' attitudes (module doc). Errors: as [`align`], but a line of positions is aligned.
pub fn align_poses(
    est: &[&Pose],
    truth: &[&Pose],
    mode: AlignMode,
) -> Result<Alignment, EvalError> {
    align_pairs(
        est,
        truth,
        mode,
        |p| &p.p_b_in_w,
        |c, x, y| c.push_pose(x, y),
    )
}

/// The two passes of an alignment over pairs of `T`: the means of their `position`s, then
/// `second` over each pair.
fn align_pairs<T>(
    est: &[T],
    truth: &[T],
    mode: AlignMode,
    position: impl Fn(&T) -> &Vector3<f64>,
    second: impl Fn(&mut UmeyamaCross, &T, &T),
) -> Result<Alignment, EvalError> {
    if est.len() != truth.len() {
        return Err(EvalError::LengthMismatch {
            est: est.len(),
            truth: truth.len(),
        });
    }
    let mut means = UmeyamaMeans::default();
    est.iter()
        .zip(truth)
        .for_each(|(x, y)| means.push(position(x), position(y)));
    let mut cross = means.cross()?;
    est.iter()
        .zip(truth)
        .for_each(|(x, y)| second(&mut cross, x, y));
    cross.alignment(mode)
}

/// The first pass of [`umeyama`] over point pairs given one at a time: their sums.
#[derive(Clone, Debug, Default)]
pub(crate) struct UmeyamaMeans {
    n: usize,
    sum_est: Vector3<f64>,
    sum_truth: Vector3<f64>,
}

impl UmeyamaMeans {
    /// One pair, `est` going onto `truth`.
    pub(crate) fn push(&mut self, est: &Vector3<f64>, truth: &Vector3<f64>) {
        self.n += 1;
        self.sum_est += est;
        self.sum_truth += truth;
    }

    /// The second pass, over the same pairs in the same order (fewer than
    /// `MIN_ALIGNMENT_PAIRS` pairs is an error).
    pub(crate) fn cross(&self) -> Result<UmeyamaCross, EvalError> {
        if self.n < MIN_ALIGNMENT_PAIRS {
            return Err(EvalError::TooFewPairs {
                pairs: self.n,
                needed: MIN_ALIGNMENT_PAIRS,
            });
        }
        let inv_n = 1.0 / self.n as f64;
        Ok(UmeyamaCross {
            inv_n,
            mean_est: self.sum_est * inv_n,
            mean_truth: self.sum_truth * inv_n,
            sum: Matrix3::zeros(),
            attitudes: AttitudeMean::default(),
        })
    }
}

/// The second pass of [`umeyama`]: the cross-covariance about the means of the first.
#[derive(Clone, Debug)]
pub(crate) struct UmeyamaCross {
    inv_n: f64,
    mean_est: Vector3<f64>,
    mean_truth: Vector3<f64>,
    sum: Matrix3<f64>,
    attitudes: AttitudeMean,
}

impl UmeyamaCross {
    /// One pair, as given to [`UmeyamaMeans::push`].
    pub(crate) fn push(&mut self, est: &Vector3<f64>, truth: &Vector3<f64>) {
        self.sum += (truth - self.mean_truth) * (est - self.mean_est).transpose();
    }

    /// One pose pair, as given to [`UmeyamaMeans::push`] by position: its position and its
    /// attitudes (for pairs whose positions cannot fix the rotation).
    pub(crate) fn push_pose(&mut self, est: &Pose, truth: &Pose) {
        self.push(&est.p_b_in_w, &truth.p_b_in_w);
        self.attitudes.push(est, truth);
    }

    /// The alignment of the pairs allowed by `mode`; when their positions cannot fix the
    /// rotation, from the attitudes given with [`Self::push_pose`] (module doc).
    pub(crate) fn alignment(&self, mode: AlignMode) -> Result<Alignment, EvalError> {
        let by_position = match mode {
            AlignMode::PosYaw => self.yaw_alignment(),
            AlignMode::Se3 => self.se3_alignment(),
        };
        match by_position {
            Err(EvalError::Degenerate { singular_values }) => {
                let rotation = self
                    .attitudes
                    .rotation(mode == AlignMode::PosYaw)
                    .ok_or(EvalError::Degenerate { singular_values })?;
                let t = self.mean_truth - rotation * self.mean_est;
                let mut alignment =
                    Alignment::from_isometry(&Isometry3::from_parts(t.into(), rotation));
                alignment.rotation_from_attitudes = true;
                Ok(alignment)
            }
            other => other,
        }
    }

    /// The yaw and translation (module doc).
    fn yaw_alignment(&self) -> Result<Alignment, EvalError> {
        let c = self.sum * self.inv_n;
        let (sin, cos) = (c[(1, 0)] - c[(0, 1)], c[(0, 0)] + c[(1, 1)]);
        let horizontal = c.fixed_view::<2, 2>(0, 0).norm();
        if !c.iter().all(|x| x.is_finite())
            || horizontal <= 0.0
            || sin.hypot(cos) <= MIN_RELATIVE_SINGULAR_VALUE * horizontal
        {
            let d = c.svd(false, false).singular_values;
            return Err(EvalError::Degenerate {
                singular_values: [d[0], d[1], d[2]],
            });
        }
        let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), sin.atan2(cos));
        let t = self.mean_truth - r * self.mean_est;
        Ok(Alignment::from_isometry(&Isometry3::from_parts(
            t.into(),
            r,
        )))
    }

    /// Umeyama's rotation and translation.
    fn se3_alignment(&self) -> Result<Alignment, EvalError> {
        let (mean_x, mean_y) = (self.mean_est, self.mean_truth);
        let cov = self.sum * self.inv_n;
        let svd = cov.svd(true, true);
        let d = svd.singular_values;
        let degenerate = || EvalError::Degenerate {
            singular_values: [d[0], d[1], d[2]],
        };
        // `svd` sorts the singular values in decreasing order.
        if !d.iter().all(|s| s.is_finite())
            || d[0] <= 0.0
            || d[1] <= MIN_RELATIVE_SINGULAR_VALUE * d[0]
        {
            return Err(degenerate());
        }
        let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
            return Err(degenerate());
        };
        // Eq. 43: S = diag(1, 1, −1) when det(U)·det(V) < 0.
        let mut s = Matrix3::identity();
        if u.determinant() * v_t.determinant() < 0.0 {
            s[(2, 2)] = -1.0;
        }
        // Eqs. 40–41 (c = 1).
        let r = nalgebra::Rotation3::from_matrix_unchecked(u * s * v_t);
        let t = mean_y - r * mean_x;
        Ok(Alignment::from_isometry(&Isometry3::from_parts(
            t.into(),
            UnitQuaternion::from_rotation_matrix(&r),
        )))
    }
}

#[cfg(test)]
mod tests;
