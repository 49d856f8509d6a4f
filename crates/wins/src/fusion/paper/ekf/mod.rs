//! The error-state EKF of the paper's feasibility study (Sec. III): IMU propagation, AoA updates.
//!
//! State: attitude `world_from_body` (Hamilton), velocity `v_b_in_w`, position `p_b_in_w` and one
//! position `c_in_w` per AP; error state `[δθ, δv, δp, δc_1, …, δc_m]`, `9 + 3·m` entries
//! ([`state`]). **Perturbation side: body-side, `R = R̂·Exp(δθ)`**, used by every Jacobian here
//! and in [`crate::fusion::paper::observability`]. World `w` is z up with gravity `−g·e_z`; IMU biases are
//! not estimated (the paper's Sec. III model, and its observability analysis, have none).
//!
//! - [`propagation`]: mid-point IMU integration, its Jacobian `F` and noise `Q`.
//! - [`measurement`]: the cone angle `h(x)` and its Jacobian `H`.
//! - [`Ekf`]: the filter. It needs an initial state and covariance, which is the paper's
//!   argument against it: with WiFi bearings alone there is no metric initial guess, and a wrong
//!   one with a confident covariance is not recovered from (see `tests/it/fusion_ekf.rs`).
//!
//! Bearings are applied at the filter's current time: propagate to the bearing's time first.

pub mod measurement;
pub mod propagation;
pub mod state;

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

pub use measurement::{BearingPrediction, PredictionError, predict_bearing};
pub use propagation::ImuStep;
pub use state::{CORE_DIM, EkfState};

use crate::fusion::bearing::Bearing;
use crate::imu::ImuSample;
use crate::imu::STANDARD_GRAVITY_M_S2;

/// Relative asymmetry tolerated in an initial covariance, `|P_ij − P_ji| ≤ tol·√(P_ii·P_jj)`.
const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// Noise, gravity and mounting for the EKF.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EkfConfig {
    /// Gyro white noise density, rad/s/√Hz. Default: the MicroStrain 3DM-GX4-25 datasheet
    /// (0.005 °/s/√Hz); wrong for any other IMU.
    pub gyro_noise_density_rad_s_sqrt_hz: f64,
    /// Accelerometer white noise density, m/s²/√Hz. Default: the MicroStrain 3DM-GX4-25
    /// datasheet (100 µg/√Hz); wrong for any other IMU.
    pub accel_noise_density_m_s2_sqrt_hz: f64,
    /// Gravity magnitude, m/s² (gravity is `−g·e_z` in `w`). Default: standard gravity.
    pub gravity_m_s2: f64,
    /// Pose of the antenna array in the body (IMU) frame. Default: identity, the array at the
    /// IMU (the paper's Sec. III assumption); wrong for any real mounting.
    pub body_from_array: Isometry3<f64>,
    /// Mahalanobis gate on a bearing's innovation, `r²/S` (χ², 1 degree of freedom): larger ones
    /// are rejected and counted. Default `None`: every bearing is used, as in the paper.
    pub mahalanobis_gate: Option<f64>,
}

impl Default for EkfConfig {
    fn default() -> Self {
        Self {
            gyro_noise_density_rad_s_sqrt_hz: 0.005_f64.to_radians(),
            accel_noise_density_m_s2_sqrt_hz: 100e-6 * STANDARD_GRAVITY_M_S2,
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            body_from_array: Isometry3::identity(),
            mahalanobis_gate: None,
        }
    }
}

impl EkfConfig {
    /// Checks that every number is finite and in range.
    pub fn validate(&self) -> Result<(), EkfError> {
        let bad = |field: &'static str, value: f64| Err(EkfError::InvalidConfig { field, value });
        let g = self.gyro_noise_density_rad_s_sqrt_hz;
        if !(g.is_finite() && g >= 0.0) {
            return bad("gyro_noise_density_rad_s_sqrt_hz", g);
        }
        let a = self.accel_noise_density_m_s2_sqrt_hz;
        if !(a.is_finite() && a >= 0.0) {
            return bad("accel_noise_density_m_s2_sqrt_hz", a);
        }
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 > 0.0) {
            return bad("gravity_m_s2", self.gravity_m_s2);
        }
        let e = &self.body_from_array;
        if let Some(v) = e
            .translation
            .vector
            .iter()
            .chain(e.rotation.coords.iter())
            .find(|v| !v.is_finite())
        {
            return bad("body_from_array", *v);
        }
        if let Some(gate) = self
            .mahalanobis_gate
            .filter(|g| !(g.is_finite() && *g > 0.0))
        {
            return bad("mahalanobis_gate", gate);
        }
        Ok(())
    }
}

/// Input the EKF refuses.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EkfError {
    /// A configuration value is out of range.
    #[error("EKF config: {field} = {value} is not valid")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// Its value (for the extrinsic, the first non-finite entry).
        value: f64,
    },
    /// The initial state (or a new AP) holds non-finite numbers.
    #[error("the initial state is not finite")]
    NonFiniteState,
    /// The covariance does not match the error-state dimension.
    #[error("covariance is {rows}×{cols}, expected {expected}×{expected}")]
    CovarianceShape {
        /// `9 + 3·m`.
        expected: usize,
        /// Rows given.
        rows: usize,
        /// Columns given.
        cols: usize,
    },
    /// A covariance entry is not finite.
    #[error("covariance entry ({row}, {col}) is not finite")]
    CovarianceNotFinite {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
    },
    /// The covariance is not symmetric.
    #[error("covariance is not symmetric at ({row}, {col}): {upper} vs {lower}")]
    CovarianceNotSymmetric {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
        /// `P[row, col]`.
        upper: f64,
        /// `P[col, row]`.
        lower: f64,
    },
    /// The covariance is not positive definite (its Cholesky factorization fails).
    #[error("covariance is not positive definite")]
    CovarianceNotPositiveDefinite,
}

/// Why an IMU sample was not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuSkip {
    /// A reading is not finite.
    NonFinite,
    /// Its time is before the filter's time (or equal to the previous sample's).
    OutOfOrder,
}

/// What [`Ekf::propagate`] did with a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuOutcome {
    /// The state moved to the sample's time.
    Propagated,
    /// The sample is at the filter's time: held as the start of the next interval.
    Held,
    /// Not used (counted in [`EkfReport`]).
    Skipped(ImuSkip),
}

/// Why a bearing was not used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BearingRejection {
    /// Non-finite angle, |θ| > 90° or σ ≤ 0.
    Invalid,
    /// The predicted geometry is degenerate (AP at the array, on its axis, unknown AP).
    Degenerate(PredictionError),
    /// The bearing says the AP is on the other side of the array than the state predicts.
    SideMismatch,
    /// The normalized innovation `r²/S` exceeded the gate.
    Gated {
        /// `r²/S`.
        mahalanobis_sq: f64,
    },
    /// The update produced non-finite numbers (left unapplied).
    Numerical,
}

/// What [`Ekf::update`] did with a bearing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BearingOutcome {
    /// Applied.
    Applied {
        /// Innovation `z − h(x̂)`, rad.
        residual_rad: f64,
        /// `r²/S`.
        mahalanobis_sq: f64,
    },
    /// Not applied (counted in [`EkfReport`]).
    Rejected(BearingRejection),
}

/// Counts of what the filter used and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EkfReport {
    /// IMU intervals integrated.
    pub imu_propagated: usize,
    /// IMU samples with non-finite readings.
    pub imu_non_finite: usize,
    /// IMU samples out of time order.
    pub imu_out_of_order: usize,
    /// Bearings applied.
    pub bearings_applied: usize,
    /// Bearings with invalid numbers.
    pub bearings_invalid: usize,
    /// Bearings skipped for degenerate geometry or an unknown AP.
    pub bearings_degenerate: usize,
    /// Bearings whose side disagreed with the prediction.
    pub bearings_side_mismatch: usize,
    /// Bearings rejected by the Mahalanobis gate.
    pub bearings_gated: usize,
    /// Updates that would have produced non-finite numbers.
    pub bearings_numerical: usize,
}

/// The error-state EKF (module doc).
#[derive(Clone, Debug)]
pub struct Ekf {
    config: EkfConfig,
    state: EkfState,
    covariance: DMatrix<f64>,
    last_imu: Option<ImuSample>,
    report: EkfReport,
}

impl Ekf {
    /// A filter at `initial_state` with error-state covariance `initial_covariance`
    /// (`9 + 3·m` square, symmetric, positive definite; order as in [`state`]).
    pub fn new(
        config: EkfConfig,
        initial_state: EkfState,
        initial_covariance: DMatrix<f64>,
    ) -> Result<Self, EkfError> {
        config.validate()?;
        if !initial_state.is_finite() {
            return Err(EkfError::NonFiniteState);
        }
        let covariance = checked_covariance(initial_covariance, initial_state.error_dim())?;
        Ok(Self {
            config,
            state: initial_state,
            covariance,
            last_imu: None,
            report: EkfReport::default(),
        })
    }

    /// Adds an AP at `c_in_w` with covariance `covariance` (uncorrelated with the rest) and
    /// returns its index.
    pub fn add_ap(
        &mut self,
        c_in_w: Vector3<f64>,
        covariance: Matrix3<f64>,
    ) -> Result<usize, EkfError> {
        if !c_in_w.iter().all(|x| x.is_finite()) {
            return Err(EkfError::NonFiniteState);
        }
        let block = checked_covariance(DMatrix::from_column_slice(3, 3, covariance.as_slice()), 3)?;
        let n = self.covariance.nrows();
        let mut p = DMatrix::zeros(n + 3, n + 3);
        p.view_mut((0, 0), (n, n)).copy_from(&self.covariance);
        p.view_mut((n, n), (3, 3)).copy_from(&block);
        self.covariance = p;
        self.state.c_in_w.push(c_in_w);
        Ok(self.state.num_aps() - 1)
    }

    /// The configuration.
    pub fn config(&self) -> &EkfConfig {
        &self.config
    }

    /// The current nominal state.
    pub fn state(&self) -> &EkfState {
        &self.state
    }

    /// The current error-state covariance (`9 + 3·m` square).
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.covariance
    }

    /// What was used and skipped so far.
    pub fn report(&self) -> &EkfReport {
        &self.report
    }

    /// Propagates the state and covariance to `imu.t` ([`propagation`]); the previous sample
    /// (or, for the first one, this sample held since the state's time) starts the interval.
    pub fn propagate(&mut self, imu: &ImuSample) -> ImuOutcome {
        let finite = imu
            .gyro_rad_s
            .iter()
            .chain(&imu.accel_m_s2)
            .all(|x| x.is_finite());
        if !finite {
            self.report.imu_non_finite += 1;
            return ImuOutcome::Skipped(ImuSkip::NonFinite);
        }
        let from = self.last_imu.unwrap_or(*imu);
        if imu.t < self.state.t || self.last_imu.is_some_and(|l| imu.t <= l.t) {
            self.report.imu_out_of_order += 1;
            return ImuOutcome::Skipped(ImuSkip::OutOfOrder);
        }
        self.last_imu = Some(*imu);
        let Some(step) = ImuStep::new(&from, imu, self.state.t) else {
            return ImuOutcome::Held;
        };
        let f = step.jacobian(&self.state);
        let q = step.process_noise(
            self.config.gyro_noise_density_rad_s_sqrt_hz,
            self.config.accel_noise_density_m_s2_sqrt_hz,
        );
        self.state = step.propagate(&self.state, self.config.gravity_m_s2);
        // P ← Φ P Φᵀ + Q with Φ = diag(F, I): only the vehicle rows and columns change.
        let p = &mut self.covariance;
        let rows = f * p.fixed_rows::<CORE_DIM>(0);
        p.fixed_rows_mut::<CORE_DIM>(0).copy_from(&rows);
        let cols = p.fixed_columns::<CORE_DIM>(0) * f.transpose();
        p.fixed_columns_mut::<CORE_DIM>(0).copy_from(&cols);
        let mut core = p.fixed_view_mut::<CORE_DIM, CORE_DIM>(0, 0);
        core += q;
        symmetrize(p);
        self.report.imu_propagated += 1;
        ImuOutcome::Propagated
    }

    /// Updates with `bearing`, taken at the filter's current time: residual `z − h(x̂)`, Kalman
    /// gain, body-side injection `R̂·Exp(δθ)`, Joseph-form covariance.
    pub fn update(&mut self, bearing: &Bearing) -> BearingOutcome {
        match self.try_update(bearing) {
            Ok(applied) => {
                self.report.bearings_applied += 1;
                applied
            }
            Err(why) => {
                let r = &mut self.report;
                match why {
                    BearingRejection::Invalid => r.bearings_invalid += 1,
                    BearingRejection::Degenerate(_) => r.bearings_degenerate += 1,
                    BearingRejection::SideMismatch => r.bearings_side_mismatch += 1,
                    BearingRejection::Gated { .. } => r.bearings_gated += 1,
                    BearingRejection::Numerical => r.bearings_numerical += 1,
                }
                BearingOutcome::Rejected(why)
            }
        }
    }

    fn try_update(&mut self, bearing: &Bearing) -> Result<BearingOutcome, BearingRejection> {
        if !bearing.is_valid() {
            return Err(BearingRejection::Invalid);
        }
        let pred = predict_bearing(&self.state, bearing.ap, &self.config.body_from_array)
            .map_err(BearingRejection::Degenerate)?;
        if pred.side != bearing.side {
            return Err(BearingRejection::SideMismatch);
        }
        let residual_rad = bearing.aoa_rad - pred.aoa_rad;
        let h = &pred.jacobian;
        let var_z = bearing.sigma_rad * bearing.sigma_rad;
        let p_ht: DVector<f64> = &self.covariance * h.transpose();
        let s = (h * &p_ht)[(0, 0)] + var_z;
        if !(s.is_finite() && s > 0.0) {
            return Err(BearingRejection::Numerical);
        }
        let mahalanobis_sq = residual_rad * residual_rad / s;
        if self
            .config
            .mahalanobis_gate
            .is_some_and(|g| mahalanobis_sq > g)
        {
            return Err(BearingRejection::Gated { mahalanobis_sq });
        }
        let k = p_ht / s;
        let state = self.state.boxplus(&(&k * residual_rad));
        // Joseph form: (I − K H) P (I − K H)ᵀ + K σ² Kᵀ.
        let n = self.covariance.nrows();
        let i_kh = DMatrix::identity(n, n) - &k * h;
        let mut p = &i_kh * &self.covariance * i_kh.transpose() + &k * k.transpose() * var_z;
        symmetrize(&mut p);
        if !(state.is_finite() && p.iter().all(|x| x.is_finite())) {
            return Err(BearingRejection::Numerical);
        }
        self.state = state;
        self.covariance = p;
        Ok(BearingOutcome::Applied {
            residual_rad,
            mahalanobis_sq,
        })
    }
}

/// `(P + Pᵀ)/2` in place.
fn symmetrize(p: &mut DMatrix<f64>) {
    let t = p.transpose();
    *p += t;
    *p *= 0.5;
}

/// `p` if it is `n × n`, finite, symmetric and positive definite; symmetrized.
fn checked_covariance(mut p: DMatrix<f64>, n: usize) -> Result<DMatrix<f64>, EkfError> {
    if p.nrows() != n || p.ncols() != n {
        return Err(EkfError::CovarianceShape {
            expected: n,
            rows: p.nrows(),
            cols: p.ncols(),
        });
    }
    for col in 0..n {
        for row in 0..n {
            if !p[(row, col)].is_finite() {
                return Err(EkfError::CovarianceNotFinite { row, col });
            }
        }
    }
    for col in 0..n {
        for row in 0..col {
            let (upper, lower) = (p[(row, col)], p[(col, row)]);
            let scale = (p[(row, row)] * p[(col, col)]).abs().sqrt();
            if (upper - lower).abs() > SYMMETRY_TOLERANCE * scale.max(f64::MIN_POSITIVE) {
                return Err(EkfError::CovarianceNotSymmetric {
                    row,
                    col,
                    upper,
                    lower,
                });
            }
        }
    }
    symmetrize(&mut p);
    if p.clone().cholesky().is_none() {
        return Err(EkfError::CovarianceNotPositiveDefinite);
    }
    Ok(p)
}

#[cfg(test)]
mod tests;
