//! The range anchor: what a window lost to a hole knew of an AP's range, as a factor on the
//! next window's first keyframe and that AP (`recovery::anchor`).
//!
//! The bridge (`recovery::bridge`) puts the new window's first keyframe, at `p₀` with velocity
//! `v₀`, at `p_b + (v_b + v₀) T/2 + (a_b − a₀) T²/10 + (j_b + j₀) T³/120` after the lost
//! window's last state `p_b` (its motion `v_b, a_b, j_b`; `T` the hole), each motion in its own
//! window's frame. The two frames differ by an unknown turn about the vertical and a shift, but
//! horizontal distances do not: with the lost window's AP at `c_b`,
//!
//! ```text
//! D = c_b − p_b − v_b T/2 − a_b T²/10 − j_b T³/120          (lost window, fixed)
//! L = c − p₀ + v₀ T/2 − a₀ T²/10 + j₀ T³/120                (new window)
//! r = (‖L_xy‖ − ‖D_xy‖) / σ
//! ```
//!
//! with `a₀, j₀` fixed at the anchor's creation (the new window's first motion then; their
//! errors are in the bridge's σ). `∂r/∂c = u/σ`, `∂r/∂δp₀ = −u/σ`, `∂r/∂δv₀ = (T/2) u/σ` with
//! `u = (L_x, L_y, 0)/‖L_xy‖` (position and velocity errors are additive in `w`). The anchor
//! gives a new window the AP's range, the one thing its first seconds of bearings lack, and no
//! heading: the turn between the windows is found afterwards ([`crate::fusion::nonlinear::recovery`]).

use nalgebra::Vector3;

use crate::fusion::nonlinear::state::{NavState, POS, Row15, VEL};
use crate::time::Timestamp;

/// A range anchor (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeAnchor {
    /// The keyframe it ties (a window's first).
    pub t: Timestamp,
    /// The AP.
    pub l: usize,
    /// `T/2`, s.
    pub half_span_s: f64,
    /// `−a₀ T²/10 + j₀ T³/120`, m (new window's frame).
    pub offset_m: Vector3<f64>,
    /// `‖D_xy‖`, m.
    pub range_m: f64,
    /// 1σ, m.
    pub sigma_m: f64,
}

impl RangeAnchor {
    /// `L` of the module doc at keyframe `x` and AP `c`.
    fn lever(&self, x: &NavState, c: &Vector3<f64>) -> Vector3<f64> {
        c - x.p_b_in_w + x.v_b_in_w * self.half_span_s + self.offset_m
    }

    /// The whitened residual `r` at keyframe `x` and AP `c`.
    pub fn residual(&self, x: &NavState, c: &Vector3<f64>) -> f64 {
        (self.lever(x, c).xy().norm() - self.range_m) / self.sigma_m
    }

    /// `(∂r/∂δx, ∂r/∂c)` at `x` and `c`: zero where `L_xy` vanishes (no direction).
    pub fn jacobian(&self, x: &NavState, c: &Vector3<f64>) -> (Row15, Vector3<f64>) {
        let l = self.lever(x, c);
        let n = l.xy().norm();
        let mut jx = Row15::zeros();
        if n.is_nan() || n <= 1e-9 {
            return (jx, Vector3::zeros());
        }
        let u = Vector3::new(l.x / n, l.y / n, 0.0) / self.sigma_m;
        for i in 0..3 {
            jx[POS + i] = -u[i];
            jx[VEL + i] = u[i] * self.half_span_s;
        }
        (jx, u)
    }
}

#[cfg(test)]
pub(in crate::fusion::nonlinear) mod tests {
    use nalgebra::UnitQuaternion;

    use nalgebra::Vector1;

    use super::*;
    use crate::fusion::nonlinear::state::testing::{
        assert_close, central_difference, central_difference_n,
    };

    /// A moving, turned state (for the tests of the anchors in a window too).
    pub(in crate::fusion::nonlinear) fn state() -> NavState {
        NavState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 0.7),
            p_b_in_w: Vector3::new(0.3, -0.4, 1.2),
            v_b_in_w: Vector3::new(1.1, 0.4, -0.1),
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        }
    }

    /// An anchor on AP 0 at that state's time.
    pub(in crate::fusion::nonlinear) fn anchor() -> RangeAnchor {
        RangeAnchor {
            t: Timestamp(0),
            l: 0,
            half_span_s: 2.5,
            offset_m: Vector3::new(0.2, -0.3, 0.1),
            range_m: 4.0,
            sigma_m: 0.4,
        }
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let (a, x, c) = (anchor(), state(), Vector3::new(3.0, 2.0, 2.5));
        let (jx, jc) = a.jacobian(&x, &c);
        let fd_x = central_difference(|d| Vector1::new(a.residual(&x.boxplus(d), &c)));
        assert_close(&fd_x, &jx, "∂r/∂δx");
        let fd_c = central_difference_n(|d: &Vector3<f64>| Vector1::new(a.residual(&x, &(c + d))));
        assert_close(&fd_c, &jc.transpose(), "∂r/∂c");
    }

    #[test]
    fn the_residual_ignores_a_turn_of_the_ap_about_the_lever_and_weighs_the_range() {
        let (a, x) = (anchor(), state());
        // An AP at range 4 m from the lever's origin, in two directions: both fit.
        let origin = x.p_b_in_w - x.v_b_in_w * a.half_span_s - a.offset_m;
        for angle in [0.0_f64, 2.0] {
            let c = origin + Vector3::new(4.0 * angle.cos(), 4.0 * angle.sin(), 0.7);
            assert!(a.residual(&x, &c).abs() < 1e-12);
        }
        // 0.4 m farther: one σ.
        let c = origin + Vector3::new(4.4, 0.0, 0.0);
        assert!((a.residual(&x, &c) - 1.0).abs() < 1e-12);
    }
}
