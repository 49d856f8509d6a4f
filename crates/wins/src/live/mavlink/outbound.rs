//! The pose sent to the flight controller: `ODOMETRY` ([`odometry`]) or, for older firmware,
//! `VISION_POSITION_ESTIMATE` ([`vision_position_estimate`]), built from a [`PoseEstimate`].
//!
//! ## Frames
//!
//! Our world `w` is z up with an arbitrary heading; the body `b` is the flight controller's FRD
//! frame (see [`super::inbound`]). The messages use `frame_id = MAV_FRAME_LOCAL_FRD` (a local,
//! z-down frame whose heading is arbitrary) and `child_frame_id = MAV_FRAME_BODY_FRD`. The local
//! frame `l` is `w` turned by π about x (x kept, y and z negated):
//!
//! ```text
//! p_b_in_l = R_x(π) · p_b_in_w = (x, −y, −z)
//! local_from_body = R_x(π) ∘ world_from_body          (q sent as w, x, y, z)
//! v_b_in_b = world_from_body⁻¹ · v_b_in_w              (ODOMETRY's twist is in the child frame)
//! ```
//!
//! A level body facing +x at 1 m is sent as (x, y, z) = (0, 0, −1) with the identity quaternion; a
//! yaw of +90° about our z-up axis is a yaw of −90° about the local z-down axis.
//!
//! ## Covariance
//!
//! The estimator's covariance is over `[δθ, δp]`: the attitude error on the body side
//! (`R = R̂ · Exp(δθ)`, rad) and the position in `w` (m). MAVLink's `pose_covariance` is over
//! (x, y, z, roll, pitch, yaw): the blocks are swapped to `[δp, δθ]`, the position block is turned
//! by R_x(π) (`Σ' = T Σ Tᵀ`, T = diag(R_x(π), I)), and the upper triangle is written row by row
//! (21 values). Taking δθ as the roll/pitch/yaw errors is a small-angle approximation: exact for
//! the body-axis errors, close to the Euler-angle errors while roll and pitch are small (hover and
//! gentle flight). Unknown covariance is sent as NaN in element 0, as the MAVLink spec asks.
//!
//! ## What the user sets on the flight controller
//!
//! **PX4** (EKF2, v1.14 and later):
//! - `EKF2_EV_CTRL`: which parts of the external-vision message are fused, a bitmask: bit 0
//!   horizontal position, bit 1 vertical position, bit 2 3-D velocity, bit 3 yaw (15 for all).
//! - `EKF2_HGT_REF`: the height reference: barometer (0) when the flight controller's own baro
//!   should hold the height, vision (3) to follow this estimate's z.
//! - `EKF2_EV_DELAY`: the delay, ms, from the measurement's time to its arrival at the flight
//!   controller (CSI capture + processing + link).
//! - `EKF2_EV_NOISE_MD = 0` takes the variances sent here (bounded below by `EKF2_EVP_NOISE` /
//!   `EKF2_EVA_NOISE`); `EKF2_EV_QMIN` refuses messages whose `quality` is lower.
//! - PX4 takes ODOMETRY with `frame_id` `MAV_FRAME_LOCAL_FRD` (heading arbitrary, as here) or
//!   `MAV_FRAME_LOCAL_NED` (heading aligned with north).
//!
//! **ArduPilot** (EKF3):
//! - `VISO_TYPE = 1` (MAVLink). ArduPilot's non-GPS page suggests the VOXL type (3) for sources
//!   that send `ODOMETRY` with a `reset_counter`.
//! - `EK3_SRC1_POSXY = 6`, `EK3_SRC1_VELXY = 6` (ExternalNav; or 0 to leave velocity out),
//!   `EK3_SRC1_POSZ = 1` (barometer) or 6 (ExternalNav), `EK3_SRC1_YAW = 6` (ExternalNav; or 1,
//!   compass).
//! - `VISO_POS_X`, `VISO_POS_Y`, `VISO_POS_Z`: where the estimate's body origin (the IMU) sits in
//!   the vehicle's body frame, m.
//! - Without GPS, the EKF origin has to be set before it estimates a position.

use ::mavlink::dialects::common::{
    MavEstimatorType, MavFrame, ODOMETRY_DATA, VISION_POSITION_ESTIMATE_DATA,
};
use nalgebra::{Matrix3, Matrix6, Quaternion, UnitQuaternion, Vector3};

use crate::fusion::pose::PoseEstimate;

/// Number of values in a row-major upper triangle of a 6×6 matrix.
pub const UPPER_TRIANGLE_LEN: usize = 21;
/// `quality` of a failed estimate (MAVLink: −1 = failed, 0 = unknown or bad, 100 = best).
pub const QUALITY_FAILED: i8 = -1;
/// Best `quality`.
pub const QUALITY_BEST: i8 = 100;

/// What the messages need beyond the pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OdometryExtras {
    /// Time of the estimate on the flight controller's clock, µs (the driver maps our time to it).
    pub time_usec: u64,
    /// Counts the estimate's discontinuities (restarts, resets): the flight controller resets its
    /// use of the source when it changes. Wraps at 255.
    pub reset_counter: u8,
    /// Quality, 0–100, or [`QUALITY_FAILED`] (clamped to −1..=100).
    pub quality: i8,
    /// Angular velocity of the body in the body frame, rad/s (e.g. the last bias-corrected gyro);
    /// `None` sends NaN.
    pub angular_velocity_rad_s: Option<Vector3<f64>>,
    /// Covariance of `v_b_in_w`, m²/s²; `None` sends NaN in element 0 of `velocity_covariance`.
    pub velocity_covariance_in_w: Option<Matrix3<f64>>,
}

/// Why a pose could not be sent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OutboundError {
    /// Position, velocity or attitude is NaN or infinite.
    #[error("the pose at {t_ns} ns is not finite (position, velocity or attitude): not sent")]
    NonFinitePose {
        /// Time of the estimate, ns.
        t_ns: i64,
    },
}

/// `local_from_world`: π about x (x kept, y and z negated).
pub fn local_frd_from_world() -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(0.0, 1.0, 0.0, 0.0))
}

/// The pose in the local FRD frame: position and `local_from_body` (w ≥ 0).
pub fn pose_in_local_frd(pose: &PoseEstimate) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let local_from_world = local_frd_from_world();
    let p_b_in_l = local_from_world * pose.p_b_in_w;
    let local_from_body = local_from_world * pose.world_from_body;
    let q = if local_from_body.w < 0.0 {
        UnitQuaternion::new_unchecked(-local_from_body.into_inner())
    } else {
        local_from_body
    };
    (p_b_in_l, q)
}

/// Row-major upper triangle of a 6×6 matrix.
pub fn upper_triangle(m: &Matrix6<f64>) -> [f32; UPPER_TRIANGLE_LEN] {
    let mut out = [0.0_f32; UPPER_TRIANGLE_LEN];
    let cells = (0..6).flat_map(|i| (i..6).map(move |j| (i, j)));
    for (slot, (i, j)) in out.iter_mut().zip(cells) {
        *slot = m[(i, j)] as f32;
    }
    out
}

/// An unknown covariance: NaN in element 0, zeros elsewhere.
fn unknown_covariance() -> [f32; UPPER_TRIANGLE_LEN] {
    let mut out = [0.0_f32; UPPER_TRIANGLE_LEN];
    out[0] = f32::NAN;
    out
}

/// The estimator's covariance over `[δθ, δp_w]` as MAVLink's `pose_covariance` over
/// (x, y, z, roll, pitch, yaw) in the local FRD frame (module documentation); NaN-first when
/// unknown or not finite.
pub fn pose_covariance(covariance: Option<&Matrix6<f64>>) -> [f32; UPPER_TRIANGLE_LEN] {
    let Some(sigma) = covariance.filter(|c| c.iter().all(|v| v.is_finite())) else {
        return unknown_covariance();
    };
    // T maps [δθ, δp_w] to [δp_l, δθ]: rows 0..3 take δp (columns 3..6) turned by R_x(π).
    let flip = local_frd_from_world().to_rotation_matrix().into_inner();
    let mut t = Matrix6::<f64>::zeros();
    t.fixed_view_mut::<3, 3>(0, 3).copy_from(&flip);
    t.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&Matrix3::identity());
    let symmetric = (sigma + sigma.transpose()) * 0.5;
    upper_triangle(&(t * symmetric * t.transpose()))
}

/// `velocity_covariance` over (vx, vy, vz, rollspeed, pitchspeed, yawspeed) in the body frame:
/// the linear block is `Rᵀ Σ_w R`; the angular-rate variances, unknown, are NaN. NaN-first when
/// no covariance is given.
fn velocity_covariance(
    covariance_in_w: Option<&Matrix3<f64>>,
    world_from_body: &UnitQuaternion<f64>,
) -> [f32; UPPER_TRIANGLE_LEN] {
    let Some(sigma_w) = covariance_in_w.filter(|c| c.iter().all(|v| v.is_finite())) else {
        return unknown_covariance();
    };
    let r = world_from_body.to_rotation_matrix().into_inner();
    let sigma_b = r.transpose() * ((sigma_w + sigma_w.transpose()) * 0.5) * r;
    let mut full = Matrix6::<f64>::zeros();
    full.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma_b);
    for i in 3..6 {
        full[(i, i)] = f64::NAN;
    }
    upper_triangle(&full)
}

/// Refuses a pose that is not finite.
fn check_finite(pose: &PoseEstimate) -> Result<(), OutboundError> {
    let finite = pose
        .p_b_in_w
        .iter()
        .chain(pose.v_b_in_w.iter())
        .chain(pose.world_from_body.coords.iter())
        .all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(OutboundError::NonFinitePose { t_ns: pose.t.0 })
    }
}

/// `ODOMETRY` for the pose: position and attitude in `MAV_FRAME_LOCAL_FRD`, velocity and angular
/// velocity in `MAV_FRAME_BODY_FRD`, `estimator_type = MAV_ESTIMATOR_TYPE_VIO` (the closest there
/// is: an inertial odometry from a non-GNSS sensor). Wrap it in `MavMessage::ODOMETRY` to send.
pub fn odometry(
    pose: &PoseEstimate,
    extras: &OdometryExtras,
) -> Result<ODOMETRY_DATA, OutboundError> {
    check_finite(pose)?;
    let (p, q) = pose_in_local_frd(pose);
    let v_b_in_b = pose.world_from_body.inverse() * pose.v_b_in_w;
    let omega = extras
        .angular_velocity_rad_s
        .unwrap_or_else(|| Vector3::repeat(f64::NAN));
    Ok(ODOMETRY_DATA {
        time_usec: extras.time_usec,
        x: p.x as f32,
        y: p.y as f32,
        z: p.z as f32,
        q: [q.w as f32, q.i as f32, q.j as f32, q.k as f32],
        vx: v_b_in_b.x as f32,
        vy: v_b_in_b.y as f32,
        vz: v_b_in_b.z as f32,
        rollspeed: omega.x as f32,
        pitchspeed: omega.y as f32,
        yawspeed: omega.z as f32,
        pose_covariance: pose_covariance(pose.covariance.as_ref()),
        velocity_covariance: velocity_covariance(
            extras.velocity_covariance_in_w.as_ref(),
            &pose.world_from_body,
        ),
        frame_id: MavFrame::MAV_FRAME_LOCAL_FRD,
        child_frame_id: MavFrame::MAV_FRAME_BODY_FRD,
        reset_counter: extras.reset_counter,
        estimator_type: MavEstimatorType::MAV_ESTIMATOR_TYPE_VIO,
        quality: extras.quality.clamp(QUALITY_FAILED, QUALITY_BEST),
    })
}

/// `VISION_POSITION_ESTIMATE` for the pose (older firmware): position in the local FRD frame,
/// attitude as roll, pitch, yaw of `local_from_body` (Z-Y-X Euler angles, rad), the same
/// `covariance` as [`odometry`]'s `pose_covariance`. Wrap it in
/// `MavMessage::VISION_POSITION_ESTIMATE` to send.
pub fn vision_position_estimate(
    pose: &PoseEstimate,
    extras: &OdometryExtras,
) -> Result<VISION_POSITION_ESTIMATE_DATA, OutboundError> {
    check_finite(pose)?;
    let (p, q) = pose_in_local_frd(pose);
    let (roll, pitch, yaw) = q.euler_angles();
    Ok(VISION_POSITION_ESTIMATE_DATA {
        usec: extras.time_usec,
        x: p.x as f32,
        y: p.y as f32,
        z: p.z as f32,
        roll: roll as f32,
        pitch: pitch as f32,
        yaw: yaw as f32,
        covariance: pose_covariance(pose.covariance.as_ref()),
        reset_counter: extras.reset_counter,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::Timestamp;
    use std::f64::consts::FRAC_PI_2;

    /// A level FRD body facing +x in our z-up world: `world_from_body = R_x(π)`.
    fn level_facing_x() -> UnitQuaternion<f64> {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    }

    fn pose(p: Vector3<f64>, world_from_body: UnitQuaternion<f64>) -> PoseEstimate {
        PoseEstimate {
            t: Timestamp(1_000),
            p_b_in_w: p,
            v_b_in_w: Vector3::zeros(),
            world_from_body,
            p_b_in_b0: Vector3::zeros(),
            b0_from_body: UnitQuaternion::identity(),
            converged: true,
            covariance: None,
        }
    }

    fn extras() -> OdometryExtras {
        OdometryExtras {
            time_usec: 123_456,
            reset_counter: 3,
            quality: 80,
            ..OdometryExtras::default()
        }
    }

    #[test]
    fn level_body_at_1m_is_z_minus_1_with_identity_attitude() {
        let odom = odometry(
            &pose(Vector3::new(2.0, 3.0, 1.0), level_facing_x()),
            &extras(),
        )
        .unwrap();
        assert_eq!([odom.x, odom.y, odom.z], [2.0, -3.0, -1.0]);
        let q = odom.q;
        assert!(
            (q[0] - 1.0).abs() < 1e-6
                && q[1].abs() < 1e-6
                && q[2].abs() < 1e-6
                && q[3].abs() < 1e-6,
            "{q:?}"
        );
        assert_eq!(odom.frame_id, MavFrame::MAV_FRAME_LOCAL_FRD);
        assert_eq!(odom.child_frame_id, MavFrame::MAV_FRAME_BODY_FRD);
        assert_eq!(
            odom.estimator_type,
            MavEstimatorType::MAV_ESTIMATOR_TYPE_VIO
        );
        assert_eq!(
            (odom.time_usec, odom.reset_counter, odom.quality),
            (123_456, 3, 80)
        );
        assert!(odom.pose_covariance[0].is_nan());
        assert!(odom.velocity_covariance[0].is_nan());
        assert!(odom.rollspeed.is_nan());
    }

    #[test]
    fn yaw_left_about_z_up_is_yaw_right_about_z_down() {
        let yaw_up = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
        let p = pose(Vector3::zeros(), yaw_up * level_facing_x());
        let (_, q) = pose_in_local_frd(&p);
        let expected = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -FRAC_PI_2);
        assert!(q.angle_to(&expected) < 1e-12);
        let vpe = vision_position_estimate(&p, &extras()).unwrap();
        assert!((f64::from(vpe.yaw) + FRAC_PI_2).abs() < 1e-6);
        assert!(vpe.roll.abs() < 1e-6 && vpe.pitch.abs() < 1e-6);
        assert_eq!(vpe.usec, 123_456);
        assert_eq!(vpe.reset_counter, 3);
        assert!(vpe.covariance[0].is_nan());
    }

    #[test]
    fn velocity_is_sent_in_the_body_frame() {
        // Facing +y (yaw +90° about z up), moving along +y at 2 m/s and climbing at 1 m/s:
        // forward 2, down −1 in FRD.
        let yaw_up = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2);
        let mut p = pose(Vector3::zeros(), yaw_up * level_facing_x());
        p.v_b_in_w = Vector3::new(0.0, 2.0, 1.0);
        let odom = odometry(&p, &extras()).unwrap();
        assert!(
            (odom.vx - 2.0).abs() < 1e-6 && odom.vy.abs() < 1e-6 && (odom.vz + 1.0).abs() < 1e-6
        );
        let with_rates = OdometryExtras {
            angular_velocity_rad_s: Some(Vector3::new(0.1, 0.2, 0.3)),
            velocity_covariance_in_w: Some(Matrix3::from_diagonal(&Vector3::new(1.0, 4.0, 9.0))),
            ..extras()
        };
        let odom = odometry(&p, &with_rates).unwrap();
        assert_eq!(
            [odom.rollspeed, odom.pitchspeed, odom.yawspeed],
            [0.1, 0.2, 0.3]
        );
        // Body x is world y: var(vx) = 4; body y is world x: var(vy) = 1; var(vz) = 9.
        let vc = odom.velocity_covariance;
        assert!(
            (vc[0] - 4.0).abs() < 1e-5 && (vc[6] - 1.0).abs() < 1e-5 && (vc[11] - 9.0).abs() < 1e-5
        );
        assert!(vc[15].is_nan() && vc[18].is_nan() && vc[20].is_nan());
        assert!(vc[1].abs() < 1e-6, "{}", vc[1]);
    }

    #[test]
    fn covariance_layout_puts_every_entry_in_its_place() {
        // Distinct symmetric entries over [δθ (0..3), δp_w (3..6)]: σ(i, j) = 10·(min+1) + (max+1).
        let value = |i: usize, j: usize| (10 * (i.min(j) + 1) + i.max(j) + 1) as f64;
        let sigma = Matrix6::from_fn(value);
        let cov = pose_covariance(Some(&sigma));
        // MAVLink index a ∈ (x, y, z, roll, pitch, yaw) → our index and sign.
        let source = |a: usize| {
            if a < 3 {
                (a + 3, if a == 0 { 1.0 } else { -1.0 })
            } else {
                (a - 3, 1.0)
            }
        };
        let mut k = 0;
        for a in 0..6 {
            for b in a..6 {
                let ((i, si), (j, sj)) = (source(a), source(b));
                assert_eq!(
                    f64::from(cov[k]),
                    si * sj * value(i, j),
                    "element {k} = ({a}, {b})"
                );
                k += 1;
            }
        }
        assert_eq!(k, UPPER_TRIANGLE_LEN);
        // A few by hand: var x = σ(δp_x) = 44; cov(x, y) = −45; cov(x, roll) = 14; var y = 55;
        // var roll = 11; var yaw = 33.
        assert_eq!(
            [cov[0], cov[1], cov[3], cov[6], cov[15], cov[20]],
            [44.0, -45.0, 14.0, 55.0, 11.0, 33.0]
        );
        let mut bad = sigma;
        bad[(2, 4)] = f64::NAN;
        assert!(pose_covariance(Some(&bad))[0].is_nan());
    }

    #[test]
    fn non_finite_poses_are_refused_and_quality_clamped() {
        let mut p = pose(Vector3::new(f64::NAN, 0.0, 0.0), level_facing_x());
        assert_eq!(
            odometry(&p, &extras()),
            Err(OutboundError::NonFinitePose { t_ns: 1_000 })
        );
        assert!(vision_position_estimate(&p, &extras()).is_err());
        p.p_b_in_w = Vector3::zeros();
        let odom = odometry(
            &p,
            &OdometryExtras {
                quality: -100,
                ..extras()
            },
        )
        .unwrap();
        assert_eq!(odom.quality, QUALITY_FAILED);
        let odom = odometry(
            &p,
            &OdometryExtras {
                quality: 120,
                ..extras()
            },
        )
        .unwrap();
        assert_eq!(odom.quality, QUALITY_BEST);
    }
}
