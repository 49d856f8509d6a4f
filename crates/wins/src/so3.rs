//! Small SO(3) toolkit shared by preintegration, attitude and the estimators (`[v]×` is
//! nalgebra's `Vector3::cross_matrix`).
//!
//! Perturbations are on the right (body side) everywhere they are used: `R = R̂ · Exp(δθ)`.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// `Exp(φ)` as a unit quaternion (rotation by `|φ|` about `φ/|φ|`).
pub fn exp(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_scaled_axis(*phi)
}

/// `Log(q)`, the rotation vector in (−π, π].
pub fn log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    q.scaled_axis()
}

/// Right Jacobian of SO(3): `Exp(φ + δ) ≈ Exp(φ) Exp(J_r(φ) δ)` (Forster et al. 2015, eq. 8).
pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta2 = phi.norm_squared();
    let k = phi.cross_matrix();
    if theta2 < 1e-10 {
        return Matrix3::identity() - 0.5 * k + (k * k) / 6.0;
    }
    let theta = theta2.sqrt();
    Matrix3::identity() - (1.0 - theta.cos()) / theta2 * k
        + (theta - theta.sin()) / (theta2 * theta) * (k * k)
}

/// Inverse of [`right_jacobian`]: `Log(Exp(φ) Exp(δ)) ≈ φ + J_r⁻¹(φ) δ`.
pub fn right_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta2 = phi.norm_squared();
    let k = phi.cross_matrix();
    if theta2 < 1e-10 {
        return Matrix3::identity() + 0.5 * k + (k * k) / 12.0;
    }
    let theta = theta2.sqrt();
    Matrix3::identity()
        + 0.5 * k
        + (1.0 / theta2 - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())) * (k * k)
}

/// The rotation nearest (Frobenius) to an arbitrary 3×3 matrix: `U Vᵀ` from its SVD with the
/// sign of the last singular direction flipped if needed so that det = +1 (Martinec & Pajdla
/// 2007; paper Sec. IV-A). `None` when the SVD fails or the matrix has no usable rank.
pub fn project_to_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    if !m.iter().all(|x| x.is_finite()) {
        return None;
    }
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    if svd.singular_values[0] <= 0.0 {
        return None;
    }
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        let mut u2 = u;
        // Singular values are sorted in decreasing order: flip the weakest direction.
        let c = -u2.column(2);
        u2.set_column(2, &c);
        r = u2 * v_t;
    }
    Some(Rotation3::from_matrix_unchecked(r))
}

/// The rotation about z with the heading of `r` (its x axis projected on the horizontal plane);
/// identity when that axis is vertical.
pub fn heading(r: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let x = r * Vector3::x();
    if x.xy().norm() < 1e-6 {
        return UnitQuaternion::identity();
    }
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), x.y.atan2(x.x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn right_jacobian_matches_finite_differences() {
        for phi in [
            Vector3::new(0.3, -0.2, 0.5),
            Vector3::new(1e-7, 0.0, 2e-7),
            Vector3::new(-2.0, 1.0, 0.5),
        ] {
            let jr = right_jacobian(&phi);
            let jri = right_jacobian_inverse(&phi);
            assert!((jr * jri - Matrix3::identity()).norm() < 1e-9);
            let h = 1e-6;
            for i in 0..3 {
                let mut d = Vector3::zeros();
                d[i] = h;
                // Exp(φ)ᵀ Exp(φ + δ) = Exp(J_r δ)
                let fd = log(&(exp(&phi).inverse() * exp(&(phi + d)))) / h;
                assert!(
                    (fd - jr.column(i)).norm() < 1e-5,
                    "{fd} vs {}",
                    jr.column(i)
                );
            }
        }
    }

    #[test]
    fn projection_recovers_rotations_and_fixes_reflections() {
        let r = exp(&Vector3::new(0.4, -0.1, 1.2)).to_rotation_matrix();
        let noisy = r.matrix() * 2.5 + Matrix3::from_element(1e-3);
        let p = project_to_rotation(&noisy).unwrap();
        assert!((p.matrix() - r.matrix()).norm() < 2e-3);
        let reflected = -r.matrix();
        let p = project_to_rotation(&reflected).unwrap();
        assert!((p.matrix().determinant() - 1.0).abs() < 1e-12);
        assert!(project_to_rotation(&Matrix3::from_element(f64::NAN)).is_none());
        assert!(project_to_rotation(&Matrix3::zeros()).is_none());
    }
}
