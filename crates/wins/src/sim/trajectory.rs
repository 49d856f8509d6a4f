//! Mission paths with exact analytic derivatives (the part of a flight between take-off and
//! landing, see [`super::flight`]).
//!
//! The circle, the figure-eight, the smooth random flight and the hover are an offset plus a sum
//! of sinusoids with vector amplitudes,
//!
//! ```text
//! p(t) = c + Σ_k A_k sin(ω_k t + φ_k)
//! v(t) =     Σ_k A_k ω_k  cos(ω_k t + φ_k)
//! a(t) =    −Σ_k A_k ω_k² sin(ω_k t + φ_k)
//! j(t) =    −Σ_k A_k ω_k³ cos(ω_k t + φ_k)
//! ```
//!
//! so position, velocity, acceleration and jerk are exact to rounding at any time, with no
//! numerical differentiation. The quadrotor attitude ([`super::motion`]) needs all four. The
//! waypoint loop ([`super::waypoints`]) is a polyline with blended corners, exact likewise.

mod harmonics;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, TAU};

pub use super::kinematics::Translation;
use super::waypoints::WaypointPath;
use super::{ConfigError, check_finite};
use harmonics::{Harmonic, Harmonics, random_smooth};

/// Largest `num_harmonics` of [`TrajectoryConfig::RandomSmooth`].
pub const MAX_HARMONICS: usize = 16;

/// The flight path of a scenario, in the world frame `w` (z up).
///
/// In TOML the variant is chosen by `kind`, e.g.
/// `kind = "circle"`, `kind = "figure-eight"`, `kind = "random-smooth"`, `kind = "hover"`.
/// Unknown fields are rejected.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TrajectoryConfig {
    /// Horizontal circle at constant speed (the paper's flight: radius ~2.5 m, height 1.5 m,
    /// 1.27 m/s).
    ///
    /// θ(t) = θ₀ + s·(v/r)·t with s = −1 when clockwise (seen from above), +1 otherwise;
    /// p(t) = c + r (cos θ, sin θ, 0).
    Circle {
        /// Centre of the circle, m; its z is the flight height.
        center_m: [f64; 3],
        /// Radius, m (> 0).
        radius_m: f64,
        /// Constant speed along the circle, m/s (> 0).
        speed_m_s: f64,
        /// Angle θ₀ of the start point, measured from world +x toward +y, degrees.
        start_angle_deg: f64,
        /// Fly clockwise when seen from above (+z).
        clockwise: bool,
    },
    /// Figure-eight (lemniscate of Gerono) at constant height, with ω = 2π/T:
    /// x = c_x + L sin(ωt), y = c_y + W sin(2ωt), z = c_z.
    ///
    /// It starts at the crossing point `c`, heading along +x (and +y); the speed never vanishes.
    FigureEight {
        /// Centre (crossing point) of the eight, m; its z is the flight height.
        center_m: [f64; 3],
        /// Half the extent along world x, `L`, m (> 0).
        half_length_m: f64,
        /// Half the extent along world y, `W`, m (> 0).
        half_width_m: f64,
        /// Time for one full eight, `T`, s (> 0).
        period_s: f64,
    },
    /// Smooth random flight drawn from the seed given to [`TrajectoryConfig::build`].
    ///
    /// Per axis, `num_harmonics` sinusoids with periods uniform in
    /// `[min_period_s, max_period_s]`, phases uniform in `[0, 2π)` and random weights, around the
    /// centre of the box. The amplitudes of an axis sum to the box's half-width on that axis, so
    /// `bounds_min_m ≤ p(t) ≤ bounds_max_m` for all time; then all amplitudes are scaled down,
    /// if needed, so the speed bound `|(Σ_k |A_xk| ω_k, Σ_k |A_yk| ω_k, Σ_k |A_zk| ω_k)|` is at
    /// most `max_speed_m_s`, which makes `|v(t)| ≤ max_speed_m_s` for all time. An axis with
    /// `min == max` stays constant (planar flight).
    RandomSmooth {
        /// Lower corner of the box the flight stays in, m.
        bounds_min_m: [f64; 3],
        /// Upper corner of the box the flight stays in, m (≥ `bounds_min_m` per axis, > on some).
        bounds_max_m: [f64; 3],
        /// Upper bound on the speed, m/s (> 0).
        max_speed_m_s: f64,
        /// Sinusoids per axis, 1 to [`MAX_HARMONICS`].
        num_harmonics: usize,
        /// Shortest period of a sinusoid, s (> 0).
        min_period_s: f64,
        /// Longest period of a sinusoid, s (≥ `min_period_s`).
        max_period_s: f64,
    },
    /// Hover at a fixed point.
    Hover {
        /// Where to hover, m.
        position_m: [f64; 3],
    },
    /// A closed loop through waypoints at a cruise speed, corners blended over `corner_s`
    /// (see [`super::waypoints`]): after the last waypoint it flies back to the first and
    /// around again. It starts at the first waypoint heading for the second.
    Waypoints {
        /// The waypoints in the world frame, m (≥ 3).
        points_m: Vec<[f64; 3]>,
        /// Cruise speed, m/s (> 0).
        speed_m_s: f64,
        /// Time over which each corner's change of direction is blended, s (> 0); every leg
        /// must be at least `speed_m_s · corner_s` long.
        corner_s: f64,
    },
}

impl Default for TrajectoryConfig {
    /// The paper's flight: counter-clockwise circle of radius 2.5 m at 1.5 m height, 1.27 m/s,
    /// centred at (6, 4, 1.5) m. Wrong for any room it does not fit in.
    fn default() -> Self {
        Self::Circle {
            center_m: [6.0, 4.0, 1.5],
            radius_m: 2.5,
            speed_m_s: 1.27,
            start_angle_deg: 0.0,
            clockwise: false,
        }
    }
}

/// Error unless `value` is finite and > 0.
fn check_positive(field: &str, name: &str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            format!("{field}.{name}"),
            format!("must be finite and > 0, got {value}"),
        ))
    }
}

impl TrajectoryConfig {
    /// Checks that the trajectory can be built: finite numbers, positive radius, speed, sizes
    /// and periods, `min ≤ max` for bounds and periods, `num_harmonics` in `1..=16`.
    ///
    /// `field` is the dotted prefix used in error messages, e.g. `"trajectory"`.
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        match self {
            Self::Circle {
                center_m,
                radius_m,
                speed_m_s,
                start_angle_deg,
                clockwise: _,
            } => {
                check_finite(field, "center_m", center_m)?;
                check_positive(field, "radius_m", *radius_m)?;
                check_positive(field, "speed_m_s", *speed_m_s)?;
                check_finite(field, "start_angle_deg", &[*start_angle_deg])
            }
            Self::FigureEight {
                center_m,
                half_length_m,
                half_width_m,
                period_s,
            } => {
                check_finite(field, "center_m", center_m)?;
                check_positive(field, "half_length_m", *half_length_m)?;
                check_positive(field, "half_width_m", *half_width_m)?;
                check_positive(field, "period_s", *period_s)
            }
            Self::RandomSmooth {
                bounds_min_m,
                bounds_max_m,
                max_speed_m_s,
                num_harmonics,
                min_period_s,
                max_period_s,
            } => {
                check_finite(field, "bounds_min_m", bounds_min_m)?;
                check_finite(field, "bounds_max_m", bounds_max_m)?;
                let ordered = bounds_min_m
                    .iter()
                    .zip(bounds_max_m)
                    .all(|(lo, hi)| lo <= hi);
                let some_room = bounds_min_m
                    .iter()
                    .zip(bounds_max_m)
                    .any(|(lo, hi)| lo < hi);
                if !ordered || !some_room {
                    return Err(ConfigError::new(
                        format!("{field}.bounds_max_m"),
                        format!(
                            "must be >= bounds_min_m on every axis and > on at least one, \
                             got min {bounds_min_m:?}, max {bounds_max_m:?}"
                        ),
                    ));
                }
                check_positive(field, "max_speed_m_s", *max_speed_m_s)?;
                if !(1..=MAX_HARMONICS).contains(num_harmonics) {
                    return Err(ConfigError::new(
                        format!("{field}.num_harmonics"),
                        format!("must be in 1..={MAX_HARMONICS}, got {num_harmonics}"),
                    ));
                }
                check_positive(field, "min_period_s", *min_period_s)?;
                check_positive(field, "max_period_s", *max_period_s)?;
                if min_period_s > max_period_s {
                    return Err(ConfigError::new(
                        format!("{field}.max_period_s"),
                        format!("must be >= min_period_s ({min_period_s}), got {max_period_s}"),
                    ));
                }
                Ok(())
            }
            Self::Hover { position_m } => check_finite(field, "position_m", position_m),
            Self::Waypoints {
                points_m,
                speed_m_s,
                corner_s,
            } => super::waypoints::validate(field, points_m, *speed_m_s, *corner_s),
        }
    }

    /// Builds the trajectory. `seed` is used only by [`TrajectoryConfig::RandomSmooth`]
    /// (`ChaCha8Rng::seed_from_u64(seed)`); the same seed gives the same flight. `horizon_s` is
    /// the longest mission time it will be evaluated at (the waypoint loop lists its corners up
    /// to it; the other kinds ignore it).
    ///
    /// Call [`TrajectoryConfig::validate`] first: an invalid config builds a trajectory that
    /// may return non-finite values (it never panics).
    pub fn build(&self, seed: u64, horizon_s: f64) -> Trajectory {
        Trajectory(match self {
            Self::Waypoints {
                points_m,
                speed_m_s,
                corner_s,
            } => Shape::Waypoints(WaypointPath::new(
                points_m, *speed_m_s, *corner_s, horizon_s,
            )),
            other => Shape::Harmonics(other.build_harmonics(seed)),
        })
    }

    fn build_harmonics(&self, seed: u64) -> Harmonics {
        match self {
            Self::Circle {
                center_m,
                radius_m,
                speed_m_s,
                start_angle_deg,
                clockwise,
            } => {
                let sign = if *clockwise { -1.0 } else { 1.0 };
                let omega_rad_s = sign * speed_m_s / radius_m;
                let theta0_rad = start_angle_deg.to_radians();
                // r cos θ = r sin(θ + π/2).
                Harmonics {
                    center_m: Vector3::from(*center_m),
                    harmonics: vec![
                        Harmonic {
                            amplitude_m: Vector3::new(*radius_m, 0.0, 0.0),
                            omega_rad_s,
                            phase_rad: theta0_rad + FRAC_PI_2,
                        },
                        Harmonic {
                            amplitude_m: Vector3::new(0.0, *radius_m, 0.0),
                            omega_rad_s,
                            phase_rad: theta0_rad,
                        },
                    ],
                }
            }
            Self::FigureEight {
                center_m,
                half_length_m,
                half_width_m,
                period_s,
            } => {
                let omega_rad_s = TAU / period_s;
                Harmonics {
                    center_m: Vector3::from(*center_m),
                    harmonics: vec![
                        Harmonic {
                            amplitude_m: Vector3::new(*half_length_m, 0.0, 0.0),
                            omega_rad_s,
                            phase_rad: 0.0,
                        },
                        Harmonic {
                            amplitude_m: Vector3::new(0.0, *half_width_m, 0.0),
                            omega_rad_s: 2.0 * omega_rad_s,
                            phase_rad: 0.0,
                        },
                    ],
                }
            }
            Self::RandomSmooth {
                bounds_min_m,
                bounds_max_m,
                max_speed_m_s,
                num_harmonics,
                min_period_s,
                max_period_s,
            } => random_smooth(
                Vector3::from(*bounds_min_m),
                Vector3::from(*bounds_max_m),
                *max_speed_m_s,
                *num_harmonics,
                (*min_period_s, *max_period_s),
                seed,
            ),
            Self::Hover { position_m } => Harmonics {
                center_m: Vector3::from(*position_m),
                harmonics: Vec::new(),
            },
            Self::Waypoints { .. } => Harmonics {
                center_m: Vector3::zeros(),
                harmonics: Vec::new(),
            },
        }
    }
}

/// A built trajectory (mission path), evaluated at any time.
#[derive(Clone, Debug)]
pub struct Trajectory(Shape);

#[derive(Clone, Debug)]
enum Shape {
    Harmonics(Harmonics),
    Waypoints(WaypointPath),
}

impl Trajectory {
    /// Position, velocity, acceleration and jerk at `t_s` (seconds from the start), exact.
    pub fn at(&self, t_s: f64) -> Translation {
        match &self.0 {
            Shape::Harmonics(h) => h.at(t_s),
            Shape::Waypoints(w) => w.at(t_s),
        }
    }

    /// An upper bound on the speed `|v(t)|` over all time, m/s (exact for a hover and a
    /// waypoint loop, √2× the true speed for a circle).
    pub fn speed_bound_m_s(&self) -> f64 {
        match &self.0 {
            Shape::Harmonics(h) => h.speed_bound_m_s(),
            Shape::Waypoints(w) => w.speed_bound_m_s(),
        }
    }

    /// An upper bound on `|a(t)|` over all time, m/s² (the waypoint loop's up to its horizon).
    pub fn acceleration_bound_m_s2(&self) -> f64 {
        match &self.0 {
            Shape::Harmonics(h) => h.derivative_bound(2),
            Shape::Waypoints(w) => w.acceleration_bound_m_s2(),
        }
    }
}

#[cfg(test)]
mod tests;
