//! Drift-free attitude by rotation averaging (paper Sec. IV-A, `eqn:rotate_system`).
//!
//! The paper stacks relative constraints `R_j = R_i R̂_ij` over the frames, relaxes
//! orthonormality, solves the linear system and projects every 3×3 block to SO(3) by its SVD
//! (`U Vᵀ`, det = +1), with `R_0 = I`. Relative constraints alone cannot remove drift: the gyro's
//! relative rotations and the paper's AoA-derived relative rotations (Algorithm 1, lines 19–20:
//! yaw increments `θ_{i+1} − θ_t − θ_i`) both telescope, so the solution drifts with the sum of
//! their errors (the gyro bias, and every error of the translation part θ_t). What the bearings
//! and the accelerometer do observe is *absolute*: roll and pitch through gravity, yaw through
//! the direction to an AP whose position is estimated. So the same relaxed linear solve is given
//! absolute direction rows as well:
//!
//! ```text
//! R_k+1 − R_k ΔR_k = 0          gyro, weight 1/σ_Δ²
//! R_k ĝ_k = γ                   gravity: ĝ_k the window's unit gravity in b_k, γ the unit gravity in b0
//! R_k u_k = (c − p_k)/|c − p_k| bearing: u_k the measured direction in b_k (after convergence)
//! R_0 = R̄_0                     the oldest frame keeps its attitude (the gauge)
//! ```
//!
//! With `R a = b` written row by row (`r_iᵀ a = b_i`, `r_i` the i-th row of `R`) the three rows
//! of every `R_k` decouple into three systems with the same block-tridiagonal matrix (3×3 blocks),
//! solved together; then each block is projected to SO(3). The gyro bias follows by least
//! squares from the averaged relative rotations: `Log(ΔR_k(0)ᵀ R_kᵀ R_k+1) ≈ J_θg b_g`.
//!
//! Not in the estimator's loop: fed back with bearing rows built from the window's (then
//! biased) positions it made the attitude worse; the drift is removed instead by the window's
//! joint gyro-bias estimate ([`super::estimator`]).

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::so3::{log, project_to_rotation};

/// One frame's inputs to the averaging.
#[derive(Clone, Debug)]
pub struct AttitudeFrame {
    /// Current `R_{b_k}^{b_0}` (the prior for the oldest frame, otherwise unused).
    pub b0_from_bk: UnitQuaternion<f64>,
    /// Gyro relative rotation to the next frame `R_{b_k+1}^{b_k}` and its 1σ (rad); `None` for the
    /// newest frame.
    pub to_next: Option<(UnitQuaternion<f64>, f64)>,
    /// Absolute direction pairs `(a in b_k, b in b0, 1σ rad)` with `R_k a ≈ b`.
    pub directions: Vec<(Vector3<f64>, Vector3<f64>, f64)>,
}

/// Solves the relaxed system (module doc) and returns `R_{b_k}^{b_0}` per frame; `None` when the
/// system is singular or a block cannot be projected. `prior_sigma_rad` is the oldest frame's 1σ.
pub fn average(frames: &[AttitudeFrame], prior_sigma_rad: f64) -> Option<Vec<UnitQuaternion<f64>>> {
    let n = frames.len();
    if n == 0 {
        return Some(Vec::new());
    }
    // Block-tridiagonal normal matrix (diag D_k, lower L_k = block (k+1, k)) and three RHS.
    let mut diag = vec![Matrix3::<f64>::zeros(); n];
    let mut lower = vec![Matrix3::<f64>::zeros(); n.saturating_sub(1)];
    let mut rhs = vec![Matrix3::<f64>::zeros(); n]; // column i = RHS of row system i
    let w0 = prior_sigma_rad.max(1e-6).powi(-2);
    let r0 = frames[0].b0_from_bk.to_rotation_matrix().into_inner();
    diag[0] += Matrix3::identity() * w0;
    rhs[0] += r0.transpose() * w0; // rows of R̄_0 as columns
    for (k, f) in frames.iter().enumerate() {
        if let (Some((dr, sigma)), true) = (&f.to_next, k + 1 < n) {
            // r_k+1 − ΔRᵀ r_k = 0 for each row r of R.
            let w = sigma.max(1e-9).powi(-2);
            let a = dr.to_rotation_matrix().into_inner().transpose();
            diag[k] += a.transpose() * a * w;
            diag[k + 1] += Matrix3::identity() * w;
            lower[k] += -a * w;
        }
        // Each direction pair also fixes its cross product (true for rotations; without it the
        // relaxed block is free along the normal of the pair).
        let d = &f.directions;
        let crosses = (0..d.len()).flat_map(|i| (i + 1..d.len()).map(move |j| (i, j)));
        let extra: Vec<_> = crosses
            .filter_map(|(i, j)| {
                let a = d[i].0.cross(&d[j].0);
                let s = a.norm();
                (s > 0.1).then(|| (a / s, d[i].1.cross(&d[j].1) / s, d[i].2.max(d[j].2) / s))
            })
            .collect();
        for (a, b, sigma) in d.iter().chain(&extra) {
            let w = sigma.max(1e-9).powi(-2);
            diag[k] += a * a.transpose() * w;
            rhs[k] += a * b.transpose() * w;
        }
    }
    let rows = solve_block_tridiagonal(&diag, &lower, &rhs)?;
    rows.iter()
        .map(|x| {
            // x has the rows of R_k as columns.
            project_to_rotation(&x.transpose()).map(|r| UnitQuaternion::from_rotation_matrix(&r))
        })
        .collect()
}

/// Solves the symmetric block-tridiagonal system by block Cholesky (`None` if not PD).
fn solve_block_tridiagonal(
    diag: &[Matrix3<f64>],
    lower: &[Matrix3<f64>],
    rhs: &[Matrix3<f64>],
) -> Option<Vec<Matrix3<f64>>> {
    let n = diag.len();
    let mut l_diag = Vec::with_capacity(n);
    let mut l_low: Vec<Matrix3<f64>> = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    for k in 0..n {
        let mut d = diag[k];
        let mut r = rhs[k];
        if k > 0 {
            let lk: Matrix3<f64> = l_low[k - 1];
            d -= lk * lk.transpose();
            r -= lk * y[k - 1];
        }
        let chol = d.cholesky()?;
        let l = chol.l();
        let yk = l.solve_lower_triangular(&r)?;
        if k + 1 < n {
            let t = l.solve_lower_triangular(&lower[k].transpose())?;
            l_low.push(t.transpose());
        }
        y.push(yk);
        l_diag.push(l);
    }
    let mut x = vec![Matrix3::zeros(); n];
    for k in (0..n).rev() {
        let mut r = y[k];
        if k + 1 < n {
            r -= l_low[k].transpose() * x[k + 1];
        }
        x[k] = l_diag[k].transpose().solve_upper_triangular(&r)?;
    }
    Some(x)
}

/// Running least-squares estimate of the gyro bias from averaged relative rotations.
#[derive(Clone, Debug)]
pub struct GyroBiasEstimator {
    info: Matrix3<f64>,
    vec: Vector3<f64>,
}

impl GyroBiasEstimator {
    /// Starts from a zero-mean prior with 1σ `prior_sigma_rad_s` per axis.
    pub fn new(prior_sigma_rad_s: f64) -> Self {
        Self {
            info: Matrix3::identity() * prior_sigma_rad_s.max(1e-9).powi(-2),
            vec: Vector3::zeros(),
        }
    }

    /// Adds one interval: the raw gyro ΔR (integrated with zero bias), its bias Jacobian
    /// `J_θg`, the averaged `R_k`, `R_k+1`, and the 1σ of the averaged relative rotation.
    pub fn add(
        &mut self,
        raw_delta: &UnitQuaternion<f64>,
        j_theta_g: &Matrix3<f64>,
        r_k: &UnitQuaternion<f64>,
        r_k1: &UnitQuaternion<f64>,
        sigma_rad: f64,
    ) {
        // ΔR(b) = ΔR(0) Exp(J b) ⇒ Log(ΔR(0)ᵀ R_kᵀ R_k+1) = J b.
        let phi = log(&(raw_delta.inverse() * r_k.inverse() * r_k1));
        let w = sigma_rad.max(1e-9).powi(-2);
        self.info += j_theta_g.transpose() * j_theta_g * w;
        self.vec += j_theta_g.transpose() * phi * w;
    }

    /// The current estimate, rad/s.
    pub fn estimate(&self) -> Vector3<f64> {
        self.info
            .try_inverse()
            .map(|i| i * self.vec)
            .unwrap_or_else(Vector3::zeros)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::exp;

    /// A yawing, drifting chain: the gyro relative rotations carry a bias; gravity rows fix roll
    /// and pitch, bearing rows fix yaw; relative rows alone keep the drift.
    #[test]
    fn absolute_rows_remove_the_drift_that_relative_rows_keep() {
        let n = 30;
        let truth: Vec<_> = (0..n)
            .map(|k| {
                exp(&Vector3::new(
                    0.1 * (k as f64 * 0.3).sin(),
                    0.05,
                    0.02 * k as f64,
                ))
            })
            .collect();
        let drift = exp(&Vector3::new(0.002, -0.003, 0.004));
        let up = Vector3::new(0.1, -0.2, 1.0).normalize(); // gravity direction in b0
        let to_ap = Vector3::new(1.0, 0.5, 0.0).normalize();
        let frames = |absolute: bool| -> Vec<AttitudeFrame> {
            (0..n)
                .map(|k| AttitudeFrame {
                    b0_from_bk: truth[k],
                    to_next: (k + 1 < n).then(|| (truth[k].inverse() * truth[k + 1] * drift, 5e-3)),
                    directions: if absolute {
                        vec![
                            (truth[k].inverse() * up, up, 0.01),
                            (truth[k].inverse() * to_ap, to_ap, 0.03),
                        ]
                    } else {
                        Vec::new()
                    },
                })
                .collect()
        };
        let relative = average(&frames(false), 1e-4).unwrap();
        let absolute = average(&frames(true), 1e-4).unwrap();
        let err = |r: &[UnitQuaternion<f64>]| log(&(truth[n - 1].inverse() * r[n - 1])).norm();
        // 29 steps × |drift| 0.0054 rad accumulate with relative rows only.
        assert!(err(&relative) > 0.1, "{}", err(&relative));
        assert!(err(&absolute) < 0.04, "{}", err(&absolute));
        assert!(err(&relative) > 4.0 * err(&absolute));
        // Every block is a rotation.
        assert!(
            absolute
                .iter()
                .all(|q| (q.to_rotation_matrix().matrix().determinant() - 1.0).abs() < 1e-9)
        );
    }

    #[test]
    fn gyro_bias_is_recovered_from_averaged_rotations() {
        let bias = Vector3::new(0.01, -0.02, 0.005);
        let dt = 0.02;
        let mut est = GyroBiasEstimator::new(0.1);
        let mut r = UnitQuaternion::identity();
        for k in 0..200 {
            let true_delta = exp(&(Vector3::new(0.3, 0.1 * (k as f64).cos(), 0.5) * dt));
            // The gyro reads ω + b; integrated with zero bias ΔR(0) = true ΔR · Exp(b dt) (small).
            let raw = true_delta * exp(&(bias * dt));
            let j: Matrix3<f64> = -Matrix3::identity() * dt;
            let r1 = r * true_delta;
            est.add(&raw, &j, &r, &r1, 1e-4);
            r = r1;
        }
        assert!((est.estimate() - bias).norm() < 1e-4, "{}", est.estimate());
    }
}
