//! IMU gaps: a stretch without samples is a hole in the state's information, not a straight
//! line.
//!
//! Between two samples further apart than [`ImuGap::max_s`] the preintegration still takes the
//! signal as linear (the best guess there is), but the motion inside the gap was not measured:
//! the specific force and the angular rate may have left that line by an unknown amount. That
//! amount is modelled as constant over the gap, of standard deviation `σ_f`
//! ([`ImuGap::accel_sigma_m_s2`]) and `σ_ω` ([`ImuGap::gyro_sigma_rad_s`]), isotropic, so that
//! a gap of length `h` adds to the covariance of `[δα, δβ, δθ]` (module doc of
//! [`super::preintegration`])
//!
//! ```text
//! Σ_αα += σ_f² h⁴/4 I    Σ_αβ += σ_f² h³/2 I    Σ_ββ += σ_f² h² I    Σ_θθ += σ_ω² h² I
//! ```
//!
//! (`δβ = δf h`, `δα = δf h²/2`, `δθ = δω h`; an isotropic covariance is the same in every
//! frame). The estimators also drop the frames that fall inside a gap: no pose is given for a
//! time the IMU did not see.

use serde::{Deserialize, Serialize};

use super::preintegration::Covariance9;
use crate::check::Problems;

/// How the preintegration treats a gap between two IMU samples (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuGap {
    /// Consecutive samples further apart than this are a gap, s (10 periods of a 200 Hz IMU:
    /// a few lost samples are not one).
    pub max_s: f64,
    /// How far the specific force may have left the straight line across a gap (1σ, constant
    /// over the gap), m/s².
    pub accel_sigma_m_s2: f64,
    /// How far the angular rate may have left the straight line across a gap (1σ, constant
    /// over the gap), rad/s.
    pub gyro_sigma_rad_s: f64,
}

impl Default for ImuGap {
    fn default() -> Self {
        Self {
            max_s: 0.05,
            accel_sigma_m_s2: 2.0,
            gyro_sigma_rad_s: 0.5,
        }
    }
}

impl ImuGap {
    /// Whether samples `dt_s` apart have a gap between them.
    pub fn is_gap(&self, dt_s: f64) -> bool {
        dt_s > self.max_s
    }

    /// The covariance a gap of `h_s` seconds adds to `[δα, δβ, δθ]` (module doc).
    pub fn covariance(&self, h_s: f64) -> Covariance9 {
        let vf = self.accel_sigma_m_s2.powi(2);
        let vw = self.gyro_sigma_rad_s.powi(2);
        let h2 = h_s * h_s;
        let mut c = Covariance9::zeros();
        for i in 0..3 {
            c[(i, i)] = vf * h2 * h2 / 4.0;
            c[(i, 3 + i)] = vf * h2 * h_s / 2.0;
            c[(3 + i, i)] = vf * h2 * h_s / 2.0;
            c[(3 + i, 3 + i)] = vf * h2;
            c[(6 + i, 6 + i)] = vw * h2;
        }
        c
    }

    /// Every setting out of its range, keys prefixed with `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.in_range(prefix, "max_s", self.max_s, 1e-4, 10.0);
        p.in_range(
            prefix,
            "accel_sigma_m_s2",
            self.accel_sigma_m_s2,
            0.0,
            100.0,
        );
        p.in_range(prefix, "gyro_sigma_rad_s", self.gyro_sigma_rad_s, 0.0, 50.0);
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_added_covariance_is_that_of_a_constant_unknown_force_and_rate() {
        let gap = ImuGap {
            max_s: 0.05,
            accel_sigma_m_s2: 2.0,
            gyro_sigma_rad_s: 0.5,
        };
        let h = 2.0;
        let c = gap.covariance(h);
        // δβ = δf h, δα = δf h²/2: perfectly correlated.
        assert!((c[(3, 3)] - 16.0).abs() < 1e-12);
        assert!((c[(0, 0)] - 16.0).abs() < 1e-12);
        assert!((c[(0, 3)] - 16.0).abs() < 1e-12);
        assert!((c[(6, 6)] - 1.0).abs() < 1e-12);
        assert_eq!(c[(0, 1)], 0.0);
        assert_eq!(c[(0, 6)], 0.0);
        // Positive semi-definite: the αβ block is rank one per axis.
        let eig = c.symmetric_eigenvalues();
        assert!(eig.iter().all(|e| *e > -1e-9), "{eig}");
    }

    #[test]
    fn short_spacings_are_not_gaps_and_settings_out_of_range_are_named() {
        let gap = ImuGap::default();
        assert!(!gap.is_gap(0.005));
        assert!(!gap.is_gap(0.05));
        assert!(gap.is_gap(0.051));
        let bad = ImuGap {
            max_s: 0.0,
            ..ImuGap::default()
        };
        let text = format!("{:?}", bad.problems("imu_gap"));
        assert!(text.contains("max_s"), "{text}");
        assert!(ImuGap::default().problems("imu_gap").0.is_empty());
    }
}
