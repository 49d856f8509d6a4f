//! A closed loop through waypoints, flown at a cruise speed with smooth corners.
//!
//! The straight polyline `W₀ → W₁ → … → W_{n−1} → W₀ → …` flown at speed `c` reaches waypoint
//! `k` at time `s_k` (cumulative leg lengths over `c`). Its velocity `c·u_k` (`u_k` the unit
//! direction of leg `k`) steps at every waypoint; the path here blends each step over the corner
//! time `w` with the septic smooth step `S` of the flight's joins, centred on `s_k`:
//!
//! ```text
//! v(s) = c·u₀ + Σ_k c·(u_k − u_{k−1})·S((s − s_k)/w + 1/2)
//! p(s) = W₀ + c·u₀·s + Σ_k c·(u_k − u_{k−1})·w·∫S((s − s_k)/w + 1/2)
//! ```
//!
//! `S` is symmetric (`S(x) + S(1 − x) = 1`), so after each corner the path rejoins the
//! polyline exactly: the corner is cut by a smooth curve inside the angle, the speed dips in
//! the turn, and velocity, acceleration, jerk and snap are continuous. Legs must be at least `c·w`
//! long so that corners do not overlap.

use nalgebra::Vector3;

use super::ConfigError;
use super::kinematics::Translation;
use super::kinematics::smooth_step;

/// The built loop, its corners listed up to a horizon.
#[derive(Clone, Debug)]
pub struct WaypointPath {
    start_m: Vector3<f64>,
    v0_m_s: Vector3<f64>,
    corner_s: f64,
    /// (time of the corner `s_k`, velocity step `c·(u_k − u_{k−1})`), in time order.
    corners: Vec<(f64, Vector3<f64>)>,
}

/// Checks a waypoint loop: ≥ 3 finite points, consecutive ones (and the last and first) apart,
/// speed and corner time > 0, every leg at least `speed·corner_s` long.
pub fn validate(
    field: &str,
    points_m: &[[f64; 3]],
    speed_m_s: f64,
    corner_s: f64,
) -> Result<(), ConfigError> {
    if points_m.len() < 3 {
        return Err(ConfigError::new(
            format!("{field}.points_m"),
            format!("a loop needs at least 3 waypoints, got {}", points_m.len()),
        ));
    }
    if let Some(p) = points_m.iter().find(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(ConfigError::new(
            format!("{field}.points_m"),
            format!("must be finite, got {p:?}"),
        ));
    }
    for (name, v) in [("speed_m_s", speed_m_s), ("corner_s", corner_s)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(ConfigError::new(
                format!("{field}.{name}"),
                format!("must be finite and > 0, got {v}"),
            ));
        }
    }
    let min_leg_m = speed_m_s * corner_s;
    for (k, a) in points_m.iter().enumerate() {
        let b = &points_m[(k + 1) % points_m.len()];
        let leg_m = (Vector3::from(*b) - Vector3::from(*a)).norm();
        if leg_m < min_leg_m {
            return Err(ConfigError::new(
                format!("{field}.points_m"),
                format!(
                    "the leg from waypoint {k} {a:?} to {b:?} is {leg_m:.3} m, shorter than \
                     speed × corner time = {min_leg_m:.3} m (corners would overlap)"
                ),
            ));
        }
    }
    Ok(())
}

impl WaypointPath {
    /// The loop through `points_m` (validated) at `speed_m_s`, corners of `corner_s`, with every
    /// corner up to mission time `horizon_s` (beyond it the path goes straight on).
    pub fn new(points_m: &[[f64; 3]], speed_m_s: f64, corner_s: f64, horizon_s: f64) -> Self {
        let n = points_m.len();
        let unit = |k: usize| {
            let a = Vector3::from(points_m[k % n]);
            let b = Vector3::from(points_m[(k + 1) % n]);
            let d = b - a;
            (d.normalize(), d.norm() / speed_m_s)
        };
        let (u0, mut leg_s) = unit(0);
        let mut corners = Vec::new();
        let mut s_k = 0.0;
        let mut previous = u0;
        let mut k = 1;
        // Each leg lasts ≥ corner_s > 0, so this ends; NaN inputs end it at once.
        while n > 0 && (s_k + leg_s) < horizon_s + corner_s && corners.len() < 1_000_000 {
            s_k += leg_s;
            let (u, next_leg_s) = unit(k);
            corners.push((s_k, (u - previous) * speed_m_s));
            previous = u;
            leg_s = next_leg_s;
            k += 1;
            if leg_s.is_nan() || leg_s <= 0.0 {
                break;
            }
        }
        Self {
            start_m: points_m
                .first()
                .map_or(Vector3::zeros(), |p| Vector3::from(*p)),
            v0_m_s: u0 * speed_m_s,
            corner_s,
            corners,
        }
    }

    /// Position, velocity, acceleration and jerk at mission time `s` (≥ 0), exact.
    pub fn at(&self, s: f64) -> Translation {
        let w = self.corner_s;
        let mut tr = Translation {
            p_b_in_w: self.start_m + self.v0_m_s * s,
            v_b_in_w: self.v0_m_s,
            a_b_in_w: Vector3::zeros(),
            j_b_in_w: Vector3::zeros(),
        };
        for (s_k, dv) in &self.corners {
            let x = (s - s_k) / w + 0.5;
            if x <= 0.0 {
                break;
            }
            let [integral, step, rate, curvature] = smooth_step(x);
            tr.p_b_in_w += dv * (w * integral);
            tr.v_b_in_w += dv * step;
            tr.a_b_in_w += dv * (rate / w);
            tr.j_b_in_w += dv * (curvature / (w * w));
        }
        tr
    }

    /// Largest speed over the loop, m/s (the cruise speed: corners only slow down).
    pub fn speed_bound_m_s(&self) -> f64 {
        self.v0_m_s.norm()
    }

    /// Largest acceleration, m/s²: `max_k |Δv_k|·max S' / w` with `max S' = S'(1/2) = 35/16`.
    pub fn acceleration_bound_m_s2(&self) -> f64 {
        self.corners
            .iter()
            .map(|(_, dv)| dv.norm() * 2.1875 / self.corner_s)
            .fold(0.0, f64::max)
    }
}

/// A loop for tests: four waypoints at 1.2–2.0 m over 9 × 6 m, 1.5 m/s, 2 s corners.
#[cfg(test)]
pub(crate) fn example_loop() -> super::trajectory::TrajectoryConfig {
    super::trajectory::TrajectoryConfig::Waypoints {
        points_m: vec![
            [2.0, 2.0, 1.5],
            [9.0, 2.0, 2.0],
            [9.0, 6.0, 1.5],
            [3.0, 6.0, 1.2],
        ],
        speed_m_s: 1.5,
        corner_s: 2.0,
    }
}
