//! WINS's IMU-guided per-packet AoA (paper Algorithm 1, lines 4–18): predict the next AoA from the
//! previous one and the motion since, `θ̌ = θ_i + θ_t + θ_R`, search MUSIC only over `θ̌ ± Δθ`
//! (Δθ = 20° by default), and take the lowest-ToF credible peak as the direct path. When the window
//! holds no credible peak the result says so (`peak: None`) rather than returning noise.

use nalgebra::{UnitQuaternion, Vector3};

use super::estimator::{AoaError, AoaEstimator};
use super::music::AoaWindow;
use super::peak::Peak;
use crate::csi::intel5300::CsiRecord;

/// The prediction of paper Algorithm 1, lines 4–8, in its three parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoaPrediction {
    /// The previous packet's AoA θ_i, rad.
    pub previous_aoa_rad: f64,
    /// Change due to the array's rotation, θ_R, rad.
    pub rotation_part_rad: f64,
    /// Change due to the array's translation, θ_t, rad.
    pub translation_part_rad: f64,
    /// Whether the AP is predicted in front of the array (`x_a ≥ 0`) after the motion: a turn
    /// can carry it through the array's axis to the other side, where the cone angle mirrors.
    pub in_front_after: bool,
}

impl AoaPrediction {
    /// `θ̌ = θ_i + θ_t + θ_R`, clamped to ±90°.
    pub fn predicted_aoa_rad(&self) -> f64 {
        (self.previous_aoa_rad + self.translation_part_rad + self.rotation_part_rad)
            .clamp(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2)
    }

    /// The parts from the array's motion between the two packets: `aj_from_ai` rotates vectors
    /// from the earlier array frame `a_i` into the later `a_j` (the IMU's ΔR through the
    /// extrinsic), `p_aj_in_ai` is the array's displacement in `a_i` (paper `eqn:translation`),
    /// and `range_m` the distance to the AP at `a_i` (from the estimator; a rough guess works).
    ///
    /// The paper takes `θ_t = ‖l‖ / r` (the arc length), which has no sign; here the AP is placed at
    /// `r·(±cos θ_i, sin θ_i, 0)` in `a_i` (in its plane: the linear array measures no elevation;
    /// `+` when `in_front`, the paper's ±90° range, `−` behind the array, where a turn moves the
    /// cone angle the other way) and both parts are the exact changes of the cone angle, signed.
    /// A range not above the displacement gives no translation part.
    pub fn from_motion(
        previous_aoa_rad: f64,
        in_front: bool,
        aj_from_ai: &UnitQuaternion<f64>,
        p_aj_in_ai: &Vector3<f64>,
        range_m: f64,
    ) -> Self {
        let x = if in_front { 1.0 } else { -1.0 } * previous_aoa_rad.cos();
        let toward_ap_in_ai = Vector3::new(x, previous_aoa_rad.sin(), 0.0);
        let mut from_new_origin = toward_ap_in_ai * range_m - p_aj_in_ai;
        if !(range_m.is_finite() && range_m > p_aj_in_ai.norm()) || from_new_origin.norm() == 0.0 {
            from_new_origin = toward_ap_in_ai;
        }
        let cone = |v: &Vector3<f64>| (v.y / v.norm()).clamp(-1.0, 1.0).asin();
        let after_translation = cone(&from_new_origin);
        let rotated = aj_from_ai * from_new_origin;
        let after_rotation = cone(&rotated);
        Self {
            previous_aoa_rad,
            translation_part_rad: after_translation - previous_aoa_rad,
            rotation_part_rad: after_rotation - after_translation,
            in_front_after: rotated.x >= 0.0,
        }
    }
}

/// The PAoA of one packet.
#[derive(Clone, Debug, PartialEq)]
pub struct PaoaResult {
    /// θ̌, rad.
    pub predicted_aoa_rad: f64,
    /// The AoA window searched.
    pub window: AoaWindow,
    /// The direct path: the lowest-ToF credible peak in the window, or `None` when the window
    /// holds no credible peak.
    pub peak: Option<Peak>,
    /// Credible peaks found in the window.
    pub candidates: usize,
}

impl AoaEstimator {
    /// PAoA of one packet given the prediction (paper Algorithm 1, lines 9–18).
    pub fn paoa(
        &self,
        record: &CsiRecord,
        prediction: &AoaPrediction,
    ) -> Result<PaoaResult, AoaError> {
        PaoaResult::search(prediction, self.config().paoa_half_width_deg, |w| {
            self.peaks(record, w)
        })
    }
}

impl PaoaResult {
    /// The window around `prediction`, `half_width_deg` to each side, searched with `peaks`
    /// (its credible peaks there, lowest ToF first): the direct path is the first.
    pub(crate) fn search(
        prediction: &AoaPrediction,
        half_width_deg: f64,
        peaks: impl FnOnce(AoaWindow) -> Result<Vec<Peak>, AoaError>,
    ) -> Result<Self, AoaError> {
        let predicted = prediction.predicted_aoa_rad();
        let window = AoaWindow::around(predicted, half_width_deg.to_radians());
        let peaks = peaks(window)?;
        Ok(Self {
            predicted_aoa_rad: predicted,
            window,
            peak: peaks.first().copied(),
            candidates: peaks.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_motion_predicts_the_previous_angle() {
        let p = AoaPrediction::from_motion(
            0.3,
            true,
            &UnitQuaternion::identity(),
            &Vector3::zeros(),
            5.0,
        );
        assert!(p.predicted_aoa_rad() - 0.3 < 1e-12);
        assert_eq!(p.rotation_part_rad, 0.0);
    }

    #[test]
    fn yawing_the_array_shifts_the_angle_by_the_yaw() {
        // Rotating the array by +10° about a_z turns the AP by −10° in the new frame.
        let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, 10f64.to_radians());
        let aj_from_ai = yaw.inverse();
        let p = AoaPrediction::from_motion(0.2, true, &aj_from_ai, &Vector3::zeros(), 5.0);
        assert!((p.rotation_part_rad + 10f64.to_radians()).abs() < 1e-12);
        assert!((p.predicted_aoa_rad() - (0.2 - 10f64.to_radians())).abs() < 1e-12);
        // Behind the array the same turn moves the cone angle the other way (the AP at azimuth
        // 180° − 0.2 rad goes to 180° − 0.2 rad − 10°, whose cone angle is 0.2 rad + 10°).
        let back = AoaPrediction::from_motion(0.2, false, &aj_from_ai, &Vector3::zeros(), 5.0);
        assert!((back.rotation_part_rad - 10f64.to_radians()).abs() < 1e-12);
        assert!(p.in_front_after && !back.in_front_after);
        // A turn through the array's axis: at 85° in front, turning by −10° about a_z carries the
        // AP behind the array at a cone angle of 85° again (azimuth 95°).
        let through =
            AoaPrediction::from_motion(85f64.to_radians(), true, &yaw, &Vector3::zeros(), 5.0);
        assert!(!through.in_front_after);
        assert!((through.predicted_aoa_rad() - 85f64.to_radians()).abs() < 1e-9);
    }

    #[test]
    fn sideways_translation_changes_the_angle_by_the_arc_over_the_range() {
        // AP straight ahead at 10 m; moving 0.1 m toward +a_y puts it at −atan(0.1/10).
        let p = AoaPrediction::from_motion(
            0.0,
            true,
            &UnitQuaternion::identity(),
            &Vector3::new(0.0, 0.1, 0.0),
            10.0,
        );
        assert!((p.translation_part_rad + (0.1f64 / 10.0).atan()).abs() < 1e-12);
        // Range unknown / too small: no translation part, never NaN.
        let q = AoaPrediction::from_motion(
            0.0,
            true,
            &UnitQuaternion::identity(),
            &Vector3::new(0.0, 1.0, 0.0),
            0.5,
        );
        assert_eq!(q.translation_part_rad, 0.0);
    }
}
