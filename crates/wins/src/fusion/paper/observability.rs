//! Observability of the feasibility-study model (paper Sec. III, `eqn:nullspace`).
//!
//! For the error state `[δθ, δv, δp, δc_1, …, δc_m]` of [`crate::fusion::paper::ekf`] (body-side
//! attitude error, `R = R̂·Exp(δθ)`), the observability matrix along linearization points
//! `x*_1 … x*_k` is
//!
//! ```text
//! O(x*) = [H_1; H_2·Φ_{2,1}; …; H_k·Φ_{k,1}],     Φ_{k,1} = Φ_{k,k−1} ⋯ Φ_{2,1}
//! ```
//!
//! built here from the EKF's own `F` ([`ImuStep::jacobian`]) and `H` ([`predict_bearing`]), so
//! the analysis tests the filter's real Jacobians. At the true states (consistent with the
//! discrete propagation) its right nullspace is `N = [N_t | N_r]`:
//!
//! ```text
//! N_t = [0; 0; I; I; …; I]                        global translation (n × 3)
//! N_r = [R_w_bᵀ·e_z; −[v]×·e_z; −[p]×·e_z; −[c_1]×·e_z; …]   global rotation about gravity
//! ```
//!
//! (the paper's `N_r` with `R(q_w^{b_1}) = R_w_bᵀ` and `g^w` scaled to the unit vertical `e_z`;
//! the sign of the attitude block follows from the body-side perturbation: a global rotation
//! `Exp(ε·e_z)·R = R·Exp(ε·R_w_bᵀ·e_z)`). `N_t` stays in the nullspace at any linearization
//! point (`H_p = −H_c` and `Φ` is the identity on `p`, `c`); `N_r` does not once `Φ` and `H` are
//! evaluated at estimates that are not one consistent trajectory, and the estimator gains spurious
//! information about yaw.

use nalgebra::{DMatrix, DVector, SVD, Vector3};

use super::ekf::state::{ATTITUDE, CORE_DIM, POSITION, VELOCITY, ap_offset, error_dim};
use super::ekf::{EkfConfig, EkfState, ImuStep, PredictionError, predict_bearing};
use crate::imu::ImuSample;

/// Why an observability matrix cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ObservabilityError {
    /// No linearization point, or no bearing at any.
    #[error("no bearings: the observability matrix would be empty")]
    Empty,
    /// Two points carry different numbers of APs.
    #[error("point {index} has {num_aps} APs, the first has {expected}")]
    ApCountChanges {
        /// The point.
        index: usize,
        /// Its APs.
        num_aps: usize,
        /// APs of the first point.
        expected: usize,
    },
    /// IMU times do not increase strictly.
    #[error("IMU sample {index} is not after the previous one")]
    TimeNotIncreasing {
        /// The sample.
        index: usize,
    },
    /// The initial state is not at the first IMU sample's time.
    #[error("the initial state is not at the first IMU sample's time")]
    InitialTime,
    /// A bearing cannot be linearized at its point.
    #[error("point {index}: {source}")]
    Bearing {
        /// The point.
        index: usize,
        /// What is wrong with the geometry.
        source: PredictionError,
    },
    /// The matrix holds non-finite numbers, or its SVD did not converge.
    #[error("the SVD failed (non-finite entries or no convergence)")]
    Svd,
}

/// Where the Jacobians of one time step are evaluated, and what is measured there.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearizationPoint {
    /// IMU sample at this instant; with the next point's sample it defines `Φ_{k+1,k}`.
    pub imu: ImuSample,
    /// State at which `Φ_{k+1,k}` is evaluated (an EKF: the posterior `x̂_{k|k}`).
    pub propagate_at: EkfState,
    /// State at which `H_k` is evaluated (an EKF: the prior `x̂_{k|k−1}`).
    pub measure_at: EkfState,
    /// APs with a bearing at this instant (one row of `O` each).
    pub observed_aps: Vec<usize>,
}

impl LinearizationPoint {
    /// Both Jacobians evaluated at the same `state` (the true state, in the ideal analysis).
    pub fn at(state: EkfState, imu: ImuSample, observed_aps: Vec<usize>) -> Self {
        Self {
            imu,
            propagate_at: state.clone(),
            measure_at: state,
            observed_aps,
        }
    }
}

/// The states `x_i` at every `imu[i].t` obtained from `initial` (at `imu[0].t`) by the EKF's own
/// discrete propagation: the "true" states for which `Φ` is consistent, `x_{i+1} = f(x_i, u_i,
/// u_{i+1})`, so `Φ_{i+1,i}·N(x_i) = N(x_{i+1})` holds to rounding.
pub fn propagate_states(
    config: &EkfConfig,
    initial: &EkfState,
    imu: &[ImuSample],
) -> Result<Vec<EkfState>, ObservabilityError> {
    if imu.first().is_some_and(|u| u.t != initial.t) {
        return Err(ObservabilityError::InitialTime);
    }
    let mut states = Vec::with_capacity(imu.len());
    let mut x = initial.clone();
    for (index, pair) in imu.windows(2).enumerate() {
        states.push(x.clone());
        let step = ImuStep::new(&pair[0], &pair[1], pair[0].t)
            .ok_or(ObservabilityError::TimeNotIncreasing { index: index + 1 })?;
        x = step.propagate(&x, config.gravity_m_s2);
    }
    if !imu.is_empty() {
        states.push(x);
    }
    Ok(states)
}

/// `O = [H_1; H_2·Φ_{2,1}; …]` (module doc): one row per observed AP per point, `9 + 3·m`
/// columns, with `Φ` from [`ImuStep::jacobian`] at `propagate_at` and `H` from
/// [`predict_bearing`] at `measure_at` (mounting `config.body_from_array`). Rows are not
/// weighted by the bearing noise.
pub fn observability_matrix(
    config: &EkfConfig,
    points: &[LinearizationPoint],
) -> Result<DMatrix<f64>, ObservabilityError> {
    let first = points.first().ok_or(ObservabilityError::Empty)?;
    let num_aps = first.measure_at.num_aps();
    let n = error_dim(num_aps);
    for (index, p) in points.iter().enumerate() {
        for s in [&p.propagate_at, &p.measure_at] {
            if s.num_aps() != num_aps {
                return Err(ObservabilityError::ApCountChanges {
                    index,
                    num_aps: s.num_aps(),
                    expected: num_aps,
                });
            }
        }
    }
    let num_rows: usize = points.iter().map(|p| p.observed_aps.len()).sum();
    if num_rows == 0 {
        return Err(ObservabilityError::Empty);
    }
    let mut o = DMatrix::zeros(num_rows, n);
    let mut row = 0;
    let mut phi = DMatrix::<f64>::identity(n, n);
    for (index, p) in points.iter().enumerate() {
        for &ap in &p.observed_aps {
            let h = predict_bearing(&p.measure_at, ap, &config.body_from_array)
                .map_err(|source| ObservabilityError::Bearing { index, source })?
                .jacobian;
            o.row_mut(row).copy_from(&(h * &phi));
            row += 1;
        }
        if let Some(next) = points.get(index + 1) {
            let step = ImuStep::new(&p.imu, &next.imu, p.imu.t)
                .ok_or(ObservabilityError::TimeNotIncreasing { index: index + 1 })?;
            // Φ_{k+1,1} = diag(F, I)·Φ_{k,1}: only the vehicle rows change.
            let rows = step.jacobian(&p.propagate_at) * phi.fixed_rows::<CORE_DIM>(0);
            phi.fixed_rows_mut::<CORE_DIM>(0).copy_from(&rows);
        }
    }
    Ok(o)
}

/// `N_t`: global translation of the vehicle and every AP, `n × 3` (module doc).
pub fn translation_nullspace(num_aps: usize) -> DMatrix<f64> {
    let mut n = DMatrix::zeros(error_dim(num_aps), 3);
    n.fixed_view_mut::<3, 3>(POSITION, 0).fill_with_identity();
    for l in 0..num_aps {
        n.fixed_view_mut::<3, 3>(ap_offset(l), 0)
            .fill_with_identity();
    }
    n
}

/// `N_r` at `state`: the error-state direction of a global rotation about gravity by a unit
/// angle, `[R_w_bᵀ·e_z; −[v]×·e_z; −[p]×·e_z; −[c_l]×·e_z]` (module doc).
pub fn gravity_rotation_nullspace(state: &EkfState) -> DVector<f64> {
    let e_z = Vector3::z();
    let mut n = DVector::zeros(state.error_dim());
    n.fixed_rows_mut::<3>(ATTITUDE)
        .copy_from(&state.world_from_body.inverse_transform_vector(&e_z));
    n.fixed_rows_mut::<3>(VELOCITY)
        .copy_from(&e_z.cross(&state.v_b_in_w));
    n.fixed_rows_mut::<3>(POSITION)
        .copy_from(&e_z.cross(&state.p_b_in_w));
    for (l, c) in state.c_in_w.iter().enumerate() {
        n.fixed_rows_mut::<3>(ap_offset(l)).copy_from(&e_z.cross(c));
    }
    n
}

/// `N = [N_t | N_r]` at `state`, `n × 4` (paper `eqn:nullspace`).
pub fn nullspace(state: &EkfState) -> DMatrix<f64> {
    let n_t = translation_nullspace(state.num_aps());
    let n_r = gravity_rotation_nullspace(state);
    let mut n = DMatrix::zeros(state.error_dim(), 4);
    n.columns_mut(0, 3).copy_from(&n_t);
    n.column_mut(3).copy_from(&n_r);
    n
}

/// `‖O·N‖_F / (‖O‖_F·‖N‖_F)`: 0 when `N` is in the right nullspace of `O`, scale-free.
pub fn nullspace_residual(o: &DMatrix<f64>, n: &DMatrix<f64>) -> f64 {
    let scale = o.norm() * n.norm();
    if o.ncols() != n.nrows() || scale == 0.0 {
        return f64::NAN;
    }
    (o * n).norm() / scale
}

/// Singular values of `O`, largest first, with the matching right singular vectors.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// Singular values σ_1 ≥ σ_2 ≥ … (as many as `O` has columns, or rows if fewer).
    pub singular_values: DVector<f64>,
    /// Right singular vectors as columns, in the same order (the last ones span the
    /// numerically unobservable directions).
    pub right_singular_vectors: DMatrix<f64>,
}

impl Spectrum {
    /// The SVD of `o`.
    pub fn of(o: &DMatrix<f64>) -> Result<Self, ObservabilityError> {
        if o.is_empty() {
            return Err(ObservabilityError::Empty);
        }
        if !o.iter().all(|x| x.is_finite()) {
            return Err(ObservabilityError::Svd);
        }
        let svd = SVD::try_new_unordered(o.clone(), false, true, f64::EPSILON, 0)
            .ok_or(ObservabilityError::Svd)?;
        let v_t = svd.v_t.ok_or(ObservabilityError::Svd)?;
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
        let singular_values =
            DVector::from_iterator(order.len(), order.iter().map(|&i| svd.singular_values[i]));
        let mut right_singular_vectors = DMatrix::zeros(v_t.ncols(), order.len());
        for (k, &i) in order.iter().enumerate() {
            right_singular_vectors
                .column_mut(k)
                .copy_from(&v_t.row(i).transpose());
        }
        Ok(Self {
            singular_values,
            right_singular_vectors,
        })
    }

    /// Number of singular values above `relative_tolerance·σ_1`.
    pub fn rank(&self, relative_tolerance: f64) -> usize {
        let largest = self.singular_values.max();
        self.singular_values
            .iter()
            .filter(|&&s| s > relative_tolerance * largest)
            .count()
    }

    /// `σ_k / σ_1` for the `k`-th largest singular value (1-based), NaN if there is none.
    pub fn relative(&self, k: usize) -> f64 {
        match k.checked_sub(1).and_then(|i| self.singular_values.get(i)) {
            Some(s) => s / self.singular_values.max(),
            None => f64::NAN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    use crate::time::Timestamp;

    fn state() -> EkfState {
        EkfState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(0.2, -0.1, 1.3),
            v_b_in_w: Vector3::new(1.0, -0.7, 0.2),
            p_b_in_w: Vector3::new(4.0, 3.0, 1.2),
            c_in_w: vec![Vector3::new(1.0, 4.0, 1.5), Vector3::new(9.0, -2.0, 2.5)],
        }
    }

    /// Applies a global rotation `Exp(angle·e_z)` and translation `t` to the whole state.
    fn transformed(x: &EkfState, angle: f64, t: Vector3<f64>) -> EkfState {
        let q = UnitQuaternion::from_scaled_axis(Vector3::z() * angle);
        EkfState {
            t: x.t,
            world_from_body: q * x.world_from_body,
            v_b_in_w: q * x.v_b_in_w,
            p_b_in_w: q * x.p_b_in_w + t,
            c_in_w: x.c_in_w.iter().map(|c| q * c + t).collect(),
        }
    }

    #[test]
    fn nullspace_is_the_derivative_of_global_yaw_and_translation() {
        let x = state();
        let eps = 1e-6;
        let d_rot = (transformed(&x, eps, Vector3::zeros()).boxminus(&x)
            - transformed(&x, -eps, Vector3::zeros()).boxminus(&x))
            / (2.0 * eps);
        let n_r = gravity_rotation_nullspace(&x);
        assert!((d_rot - &n_r).norm() < 1e-8, "{n_r}");
        let n_t = translation_nullspace(x.num_aps());
        for axis in 0..3 {
            let t = Vector3::ith(axis, eps);
            let d = transformed(&x, 0.0, t).boxminus(&x) / eps;
            assert!((d - n_t.column(axis)).norm() < 1e-8);
        }
        assert_eq!(nullspace(&x).shape(), (15, 4));
    }

    #[test]
    fn errors_instead_of_panics() {
        let config = EkfConfig::default();
        assert_eq!(
            observability_matrix(&config, &[]),
            Err(ObservabilityError::Empty)
        );
        let imu = ImuSample {
            t: Timestamp(0),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::new(0.0, 0.0, 9.8),
        };
        let points = vec![
            LinearizationPoint::at(state(), imu, vec![0]),
            LinearizationPoint::at(state(), imu, vec![1]),
        ];
        assert_eq!(
            observability_matrix(&config, &points),
            Err(ObservabilityError::TimeNotIncreasing { index: 1 })
        );
        let mut bad = state();
        bad.c_in_w[0] = bad.p_b_in_w;
        let points = vec![LinearizationPoint::at(bad, imu, vec![0])];
        assert!(matches!(
            observability_matrix(&config, &points),
            Err(ObservabilityError::Bearing { index: 0, .. })
        ));
        assert_eq!(
            Spectrum::of(&DMatrix::from_element(2, 2, f64::NAN)),
            Err(ObservabilityError::Svd)
        );
        assert_eq!(
            propagate_states(&config, &state(), &[imu, imu]),
            Err(ObservabilityError::TimeNotIncreasing { index: 1 })
        );
    }

    #[test]
    fn spectrum_is_sorted_and_ranks() {
        let o = DMatrix::from_row_slice(3, 3, &[0.0, 0.0, 1e-14, 0.0, 5.0, 0.0, 2.0, 0.0, 0.0]);
        let s = Spectrum::of(&o).expect("finite");
        assert!((s.singular_values[0] - 5.0).abs() < 1e-12);
        assert!((s.singular_values[1] - 2.0).abs() < 1e-12);
        assert_eq!(s.rank(1e-10), 2);
        assert!((s.relative(2) - 0.4).abs() < 1e-12);
        // The smallest direction is e_z.
        assert!((s.right_singular_vectors[(2, 2)].abs() - 1.0).abs() < 1e-12);
    }
}
