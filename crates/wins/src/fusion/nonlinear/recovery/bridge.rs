//! The bridge across a hole in the information ([`crate::fusion::nonlinear::recovery`]): where the drone is after
//! it, from the lost window's last state and the new window's first motion alone.
//!
//! A drone's path is smooth: its velocity across a hole of `T` s is well described by the
//! two-point Hermite interpolation of its velocity, acceleration and jerk at the hole's two
//! ends, whose integral is the position after the hole ([`Before::bridged`]). On a circle of
//! 2.5 m flown at 1.3 m/s this errs by 2 cm after 5 s, where the trapezoid errs by 3.4 m and
//! the IMU's straight line by more. The ends' motions come from the windows' keyframe
//! velocities ([`end_motion`]).

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::fusion::nonlinear::state::NavState;
use crate::time::Timestamp;

/// The lost window's last state before a hole, in the output frame.
#[derive(Clone, Copy, Debug)]
pub(in crate::fusion::nonlinear) struct Before {
    /// Its time.
    pub(in crate::fusion::nonlinear) t: Timestamp,
    /// The body's position, m.
    pub(in crate::fusion::nonlinear) p: Vector3<f64>,
    /// The path's velocity and its next two derivatives there.
    pub(in crate::fusion::nonlinear) motion: EndMotion,
}

/// The seventh derivative a drone's path may have across a hole, m/s⁷ (a circle of 2.5 m
/// flown at 1.3 m/s has 0.026): the bridge's error over `T` s is about `c T⁷ / 100800`.
const BRIDGE_SMOOTHNESS_M_S7: f64 = 0.05;
/// 1σ of the velocities at the hole's two ends, m/s …
const BRIDGE_VELOCITY_SIGMA_M_S: f64 = 0.05;
/// … of their accelerations, m/s² …
const BRIDGE_ACCELERATION_SIGMA_M_S2: f64 = 0.05;
/// … and of their jerks, m/s³.
const BRIDGE_JERK_SIGMA_M_S3: f64 = 0.2;
/// A window's end motion is fitted to its keyframes' velocities over this span, s …
const END_FIT_S: f64 = 1.0;
/// … when it has at least this many there (else the last two give the acceleration alone).
const END_FIT_MIN_STATES: usize = 5;

/// 1σ of the bridge across a hole of `span_s` s, m: its truncation
/// ([`BRIDGE_SMOOTHNESS_M_S7`]) and the errors of its ends' motions.
pub(in crate::fusion::nonlinear) fn bridge_sigma_m(span_s: f64) -> f64 {
    let t = span_s.max(0.0);
    let truncation = BRIDGE_SMOOTHNESS_M_S7 * t.powi(7) / 100_800.0;
    let ends = (BRIDGE_VELOCITY_SIGMA_M_S * t / 2.0)
        .hypot(BRIDGE_ACCELERATION_SIGMA_M_S2 * t.powi(2) / 10.0)
        .hypot(BRIDGE_JERK_SIGMA_M_S3 * t.powi(3) / 120.0);
    MIN_BRIDGE_SIGMA_M + truncation.hypot(ends)
}

/// A path's velocity and its next two derivatives at one end of a window, m/s, m/s², m/s³.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::fusion::nonlinear) struct EndMotion {
    pub(in crate::fusion::nonlinear) v: Vector3<f64>,
    pub(in crate::fusion::nonlinear) a: Vector3<f64>,
    pub(in crate::fusion::nonlinear) j: Vector3<f64>,
}

impl EndMotion {
    /// The same motion in a frame turned by `rotation`.
    pub(in crate::fusion::nonlinear) fn turned(&self, rotation: &UnitQuaternion<f64>) -> Self {
        Self {
            v: rotation * self.v,
            a: rotation * self.a,
            j: rotation * self.j,
        }
    }
}

/// The motion at the first of `states` (a window's keyframes from the end inward): its own
/// velocity, and the acceleration and jerk of the quadratic `v + a τ + j τ²/2` fitted by
/// least squares to the velocities within [`END_FIT_S`] of it; with fewer than
/// [`END_FIT_MIN_STATES`] there, the acceleration between the first two alone.
pub(in crate::fusion::nonlinear) fn end_motion<'a>(
    mut states: impl Iterator<Item = &'a NavState>,
) -> EndMotion {
    let Some(end) = states.next() else {
        return EndMotion::default();
    };
    let near: Vec<(f64, Vector3<f64>)> = std::iter::once(end)
        .chain(states)
        .map(|s| (s.t.secs_since(end.t), s.v_b_in_w))
        .take_while(|(tau, _)| tau.abs() <= END_FIT_S)
        .collect();
    let mut motion = EndMotion {
        v: end.v_b_in_w,
        ..EndMotion::default()
    };
    if near.len() >= END_FIT_MIN_STATES {
        let mut normal = Matrix3::zeros();
        let mut rhs = Matrix3::zeros();
        for (tau, v) in &near {
            let row = Vector3::new(1.0, *tau, 0.5 * tau * tau);
            normal += row * row.transpose();
            rhs += row * v.transpose();
        }
        if let Some(c) = normal.cholesky().map(|ch| ch.solve(&rhs)) {
            motion.a = c.row(1).transpose();
            motion.j = c.row(2).transpose();
            return motion;
        }
    }
    if let [(_, v0), (tau, v1), ..] = near.as_slice()
        && tau.abs() > 1e-6
    {
        motion.a = (v1 - v0) / *tau;
    }
    motion
}

impl Before {
    /// Where the drone is at `t`, having left this state and having there the motion
    /// `after` (output frame): the integral of the velocity's two-point Hermite
    /// interpolation, `p + (v + v′) T/2 + (a − a′) T²/10 + (j + j′) T³/120`, exact for a
    /// path of degree six and off by about `T⁷/100800` times its seventh derivative
    /// otherwise.
    pub(in crate::fusion::nonlinear) fn bridged(
        &self,
        t: Timestamp,
        after: &EndMotion,
    ) -> Vector3<f64> {
        let span_s = t.secs_since(self.t).max(0.0);
        let m = &self.motion;
        self.p
            + (m.v + after.v) * (span_s / 2.0)
            + (m.a - after.a) * (span_s.powi(2) / 10.0)
            + (m.j + after.j) * (span_s.powi(3) / 120.0)
    }
}

/// Floor of the bridge's σ, m.
const MIN_BRIDGE_SIGMA_M: f64 = 0.1;

#[cfg(test)]
mod tests {
    use super::*;

    const NS: f64 = 1e9;

    /// A path of degree six, `Σ c_k t^k` per axis, and its derivatives.
    struct Poly([Vector3<f64>; 7]);

    impl Poly {
        fn derivative(&self, order: usize, t: f64) -> Vector3<f64> {
            (order..7)
                .map(|k| {
                    let falling: f64 = (k + 1 - order..=k).map(|f| f as f64).product();
                    self.0[k] * falling * t.powi((k - order) as i32)
                })
                .sum()
        }

        fn motion(&self, t: f64) -> EndMotion {
            EndMotion {
                v: self.derivative(1, t),
                a: self.derivative(2, t),
                j: self.derivative(3, t),
            }
        }
    }

    fn timestamp(t_s: f64) -> Timestamp {
        Timestamp((t_s * NS).round() as i64)
    }

    fn before_at(t_s: f64, p: Vector3<f64>, motion: EndMotion) -> Before {
        Before {
            t: timestamp(t_s),
            p,
            motion,
        }
    }

    #[test]
    fn the_bridge_is_exact_for_a_path_of_degree_six() {
        let path = Poly([
            Vector3::new(1.0, 2.0, 1.5),
            Vector3::new(1.2, -0.3, 0.1),
            Vector3::new(-0.3, 0.2, 0.0),
            Vector3::new(0.05, -0.04, 0.01),
            Vector3::new(-0.01, 0.008, 0.0),
            Vector3::new(0.002, -0.001, 0.0005),
            Vector3::new(-1e-4, 2e-4, 0.0),
        ]);
        let (t0, t1) = (0.0, 5.0);
        let before = before_at(t0, path.derivative(0, t0), path.motion(t0));
        let p = before.bridged(timestamp(t1), &path.motion(t1));
        assert!((p - path.derivative(0, t1)).norm() < 1e-9, "{p:?}");
        // Before its start: no motion.
        let p0 = before.bridged(timestamp(-1.0), &path.motion(t1));
        assert!((p0 - before.p).norm() < 1e-12);
    }

    /// The paper's circle (2.5 m at 1.3 m/s) across a 5 s hole: the bridge is off by 2 cm,
    /// inside its σ, where the trapezoid (the velocities alone) is off by metres.
    #[test]
    fn across_five_seconds_of_a_circle_the_bridge_errs_by_centimetres() {
        let (r, w) = (2.5, 1.3 / 2.5);
        let at = |t: f64, order: i32| {
            let phase = w * t + f64::from(order) * std::f64::consts::FRAC_PI_2;
            Vector3::new(phase.cos(), phase.sin(), 0.0) * r * w.powi(order)
        };
        let motion = |t: f64| EndMotion {
            v: at(t, 1),
            a: at(t, 2),
            j: at(t, 3),
        };
        let (t0, t1) = (30.0, 35.0);
        let before = before_at(t0, at(t0, 0), motion(t0));
        let err = (before.bridged(timestamp(t1), &motion(t1)) - at(t1, 0)).norm();
        assert!(err < 0.03, "{err}");
        assert!(err < bridge_sigma_m(t1 - t0));
        let velocity_only = |m: EndMotion| EndMotion {
            v: m.v,
            ..EndMotion::default()
        };
        let before = before_at(t0, at(t0, 0), velocity_only(motion(t0)));
        let trapezoid = before.bridged(timestamp(t1), &velocity_only(motion(t1)));
        let err = (trapezoid - at(t1, 0)).norm();
        assert!(err > 1.0, "{err}");
    }

    fn state(t_s: f64, v: Vector3<f64>) -> NavState {
        NavState {
            t: timestamp(t_s),
            world_from_body: UnitQuaternion::identity(),
            p_b_in_w: Vector3::zeros(),
            v_b_in_w: v,
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        }
    }

    /// Keyframes every 0.1 s of a velocity quadratic in time: the fit at either end gives
    /// its acceleration and jerk there; two keyframes give the acceleration alone.
    #[test]
    fn the_end_motion_is_fitted_to_the_keyframes_velocities() {
        let (v0, a0, j) = (
            Vector3::new(1.0, -0.5, 0.0),
            Vector3::new(0.3, 0.6, -0.1),
            Vector3::new(-0.2, 0.1, 0.05),
        );
        let v = |t: f64| v0 + a0 * t + j * (t * t / 2.0);
        let states: Vec<_> = (0..20)
            .map(|k| state(f64::from(k) * 0.1, v(f64::from(k) * 0.1)))
            .collect();
        let newest = end_motion(states.iter().rev());
        let t_end = 1.9;
        assert!((newest.v - v(t_end)).norm() < 1e-12);
        assert!((newest.a - (a0 + j * t_end)).norm() < 1e-9, "{newest:?}");
        assert!((newest.j - j).norm() < 1e-8, "{newest:?}");
        let oldest = end_motion(states.iter());
        assert!((oldest.a - a0).norm() < 1e-9 && (oldest.j - j).norm() < 1e-8);
        let two = end_motion(states[..2].iter().rev());
        assert!((two.a - (v(0.1) - v(0.0)) / 0.1).norm() < 1e-9);
        assert_eq!(two.j, Vector3::zeros());
        assert_eq!(end_motion(std::iter::empty()), EndMotion::default());
    }

    #[test]
    fn the_bridge_loosens_with_the_hole() {
        let sigmas: Vec<_> = [0.0, 1.0, 2.0, 5.0, 10.0].map(bridge_sigma_m).to_vec();
        assert!(sigmas.windows(2).all(|w| w[0] < w[1]), "{sigmas:?}");
        assert!((sigmas[0] - MIN_BRIDGE_SIGMA_M).abs() < 1e-12);
        assert!(sigmas[2] < 0.2 && sigmas[3] < 0.6, "{sigmas:?}");
    }
}
