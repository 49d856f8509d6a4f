//! Exact kinematics: the translational state with its derivatives, and the septic polynomial
//! behind every smooth join of a flight (take-off and landing moves and the mission's speed
//! ramps in [`super::flight`], the waypoint corners in [`super::waypoints`]).

use nalgebra::Vector3;

/// Translational state at one instant, world frame `w` (z up), exact derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Translation {
    /// Position of the body origin in `w`, m.
    pub p_b_in_w: Vector3<f64>,
    /// Velocity of the body origin in `w`, m/s.
    pub v_b_in_w: Vector3<f64>,
    /// Acceleration of the body origin in `w`, m/s².
    pub a_b_in_w: Vector3<f64>,
    /// Jerk (time derivative of the acceleration) in `w`, m/s³.
    pub j_b_in_w: Vector3<f64>,
}

/// `P(x) = 35x⁴ − 84x⁵ + 70x⁶ − 20x⁷` and its first three derivatives.
pub(crate) fn septic(x: f64) -> [f64; 4] {
    let q = x * (1.0 - x);
    [
        x.powi(4) * (35.0 - 84.0 * x + 70.0 * x * x - 20.0 * x.powi(3)),
        140.0 * q.powi(3),
        420.0 * q * q * (1.0 - 2.0 * x),
        840.0 * q * (1.0 - 5.0 * x + 5.0 * x * x),
    ]
}

/// The smooth step `S = P` (the septic of [`septic`]) on [0, 1], extended by 0 below and 1
/// above: its integral from 0 (`7x⁵ − 14x⁶ + 10x⁷ − 5x⁸/2` inside, `x − 1/2` above), itself,
/// `S'` and `S''`. `S'`, `S''` and `S'''` vanish at 0 and 1, so a path whose velocity or speed
/// steps by `S` is continuous to its snap. `S(x) + S(1 − x) = 1`.
pub(crate) fn smooth_step(x: f64) -> [f64; 4] {
    if x <= 0.0 {
        return [0.0; 4];
    }
    if x >= 1.0 {
        return [x - 0.5, 1.0, 0.0, 0.0];
    }
    let [p, dp, ddp, _] = septic(x);
    [
        x.powi(5) * (7.0 - 14.0 * x + 10.0 * x * x - 2.5 * x.powi(3)),
        p,
        dp,
        ddp,
    ]
}
