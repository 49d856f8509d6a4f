//! A whole flight in phases: on the ground, vertical take-off, the mission, landing, on the
//! ground again.
//!
//! ```text
//!  t:   0 ── rest ──┬── take-off ──┬──────────── mission ────────────┬── landing ──┬── rest ──
//!  z:   ground      │  climb to    │ ramp up │ cruise │ ramp down    │ descend to  │ ground
//!                   │  m(0).z      │ along the mission path m(s)     │ the floor   │
//! ```
//!
//! The mission is a path `m(s)` in *mission time* `s` (the circle, the eight, the random
//! flight, the hover, the waypoint loop of [`super::trajectory`]). The flight reaches it by a
//! time warp `s(τ)` over the mission phase (τ from its start, length `D`, ramp `R`):
//!
//! ```text
//! ṡ(τ) = S(τ/R) for τ < R,   1 in between,   S((D − τ)/R) for τ > D − R
//! S(x) = P(x) = 35x⁴ − 84x⁵ + 70x⁶ − 20x⁷   (S', S'' and S''' vanish at 0 and 1)
//! p = m(s),  v = m′ṡ,  a = m″ṡ² + m′s̈,  j = m‴ṡ³ + 3m″ṡs̈ + m′s⃛
//! ```
//!
//! so the mission starts and ends at rest with zero acceleration and jerk, and is flown at its
//! own speed in between. Take-off and landing are vertical rest-to-rest moves
//! `p = p₀ + Δ·P(x)`, `x = τ/T`, with the same septic `P`. Every join is therefore
//! continuous in position, velocity, acceleration, jerk and snap: the IMU has no steps and no
//! kinks.
//!
//! The yaw profile ([`super::yaw`]) is a function of the mission: it is evaluated at mission
//! time `s` on the un-warped path `m(s)` and its rate multiplied by `ṡ` (chain rule). On the
//! ground and during take-off the heading is the mission's first; during landing and after, its
//! last.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::kinematics::{septic, smooth_step};
use super::trajectory::{Trajectory, Translation};

/// Shortest climb from the ground to the mission, m.
pub const MIN_CLIMB_M: f64 = 0.2;

/// The phases around the mission (TOML `[phases]`). Without this table the flight is the
/// mission alone, airborne from t = 0 (mission time = flight time).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhasesConfig {
    /// Height of the body (IMU) origin above the floor while standing on the ground, m.
    pub ground_height_m: f64,
    /// Time on the ground before take-off, s (≥ 0).
    pub rest_s: f64,
    /// Duration of the vertical climb to the mission's first point, s (> 0).
    pub takeoff_s: f64,
    /// Duration of the speed ramp at each end of the mission, s (> 0).
    pub ramp_s: f64,
    /// Duration of the vertical descent from the mission's last point, s (> 0).
    pub landing_s: f64,
    /// Time on the ground after landing, s (≥ 0).
    pub final_rest_s: f64,
}

impl Default for PhasesConfig {
    /// 3 s on the ground (body origin 0.1 m above the floor), a 4 s take-off, 3 s ramps, a 4 s
    /// landing, 2 s on the ground.
    fn default() -> Self {
        Self {
            ground_height_m: 0.1,
            rest_s: 3.0,
            takeoff_s: 4.0,
            ramp_s: 3.0,
            landing_s: 4.0,
            final_rest_s: 2.0,
        }
    }
}

impl PhasesConfig {
    /// Time left for the mission in a flight of `duration_s`, s.
    pub fn mission_s(&self, duration_s: f64) -> f64 {
        duration_s - self.rest_s - self.takeoff_s - self.landing_s - self.final_rest_s
    }

    /// Checks the values for a flight of `duration_s`; `field` is the dotted prefix (`phases`).
    pub fn validate(&self, field: &str, duration_s: f64) -> Result<(), ConfigError> {
        let named = [
            ("ground_height_m", self.ground_height_m, false),
            ("rest_s", self.rest_s, false),
            ("takeoff_s", self.takeoff_s, true),
            ("ramp_s", self.ramp_s, true),
            ("landing_s", self.landing_s, true),
            ("final_rest_s", self.final_rest_s, false),
        ];
        for (name, value, strictly) in named {
            let ok = value.is_finite() && if strictly { value > 0.0 } else { value >= 0.0 };
            if !ok {
                let bound = if strictly { "> 0" } else { "≥ 0" };
                return Err(ConfigError::new(
                    format!("{field}.{name}"),
                    format!("must be finite and {bound}, got {value}"),
                ));
            }
        }
        let mission_s = self.mission_s(duration_s);
        if mission_s < 2.0 * self.ramp_s {
            return Err(ConfigError::new(
                format!("{field}.ramp_s"),
                format!(
                    "the mission gets {mission_s:.3} s of the {duration_s} s flight (after rest, \
                     take-off, landing and final rest), less than its two ramps of {} s",
                    self.ramp_s
                ),
            ));
        }
        Ok(())
    }
}

/// Where the flight is at one instant: its translation and the mission time behind the yaw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlightPoint {
    /// The body's translational state (exact derivatives).
    pub translation: Translation,
    /// Mission time `s`, s.
    pub mission_s: f64,
    /// `ds/dt` (1 during the cruise, 0 outside the mission).
    pub mission_rate: f64,
    /// The un-warped mission path at `s` (what the yaw profile looks at).
    pub mission_translation: Translation,
}

/// The phase timeline of a flight with phases.
#[derive(Clone, Debug)]
struct Timeline {
    ground_z_m: f64,
    takeoff_start_s: f64,
    takeoff_s: f64,
    mission_start_s: f64,
    mission_s: f64,
    ramp_s: f64,
    landing_s: f64,
    /// The mission path at its start and at its end (mission time `mission_s − ramp_s`), where
    /// the take-off ends and the landing starts.
    first: Translation,
    last: Translation,
}

/// A flight: the mission path and, optionally, the phases around it.
#[derive(Clone, Debug)]
pub struct Flight {
    mission: Trajectory,
    timeline: Option<Timeline>,
}

impl From<Trajectory> for Flight {
    /// The mission alone, airborne from t = 0.
    fn from(mission: Trajectory) -> Self {
        Self {
            mission,
            timeline: None,
        }
    }
}

impl Flight {
    /// `mission` flown inside `phases` over a flight of `duration_s` (validate the phases first:
    /// invalid ones give a flight that may return non-finite values, never a panic).
    pub fn with_phases(mission: Trajectory, phases: &PhasesConfig, duration_s: f64) -> Self {
        let mission_s = phases.mission_s(duration_s);
        let (first, last) = (mission.at(0.0), mission.at(mission_s - phases.ramp_s));
        Self {
            mission,
            timeline: Some(Timeline {
                ground_z_m: phases.ground_height_m,
                takeoff_start_s: phases.rest_s,
                takeoff_s: phases.takeoff_s,
                mission_start_s: phases.rest_s + phases.takeoff_s,
                mission_s,
                ramp_s: phases.ramp_s,
                landing_s: phases.landing_s,
                first,
                last,
            }),
        }
    }

    /// Mission time at the end of the mission phase (the flight's duration without phases is
    /// not known here, so `None`).
    pub fn mission_end_s(&self) -> Option<f64> {
        self.timeline.as_ref().map(|tl| tl.mission_s - tl.ramp_s)
    }

    /// Height of the body origin on the ground, m (`None` without phases).
    pub fn ground_height_m(&self) -> Option<f64> {
        self.timeline.as_ref().map(|tl| tl.ground_z_m)
    }

    /// The flight at `t_s` (seconds from the start), exact to rounding.
    pub fn at(&self, t_s: f64) -> FlightPoint {
        let Some(tl) = &self.timeline else {
            let tr = self.mission.at(t_s);
            return FlightPoint {
                translation: tr,
                mission_s: t_s,
                mission_rate: 1.0,
                mission_translation: tr,
            };
        };
        let s_end = tl.mission_s - tl.ramp_s;
        let (first, last) = (tl.first, tl.last);
        let held = |s: f64, m: Translation, tr: Translation| FlightPoint {
            translation: tr,
            mission_s: s,
            mission_rate: 0.0,
            mission_translation: m,
        };
        let on_ground = |m: &Translation| {
            let mut p = m.p_b_in_w;
            p.z = tl.ground_z_m;
            at_rest(p)
        };
        let tau = t_s - tl.mission_start_s;
        if t_s < tl.takeoff_start_s {
            held(0.0, first, on_ground(&first))
        } else if tau < 0.0 {
            let from = on_ground(&first).p_b_in_w;
            let x = (t_s - tl.takeoff_start_s) / tl.takeoff_s;
            held(
                0.0,
                first,
                septic_move(from, first.p_b_in_w, tl.takeoff_s, x),
            )
        } else if tau <= tl.mission_s {
            let warp = time_warp(tau, tl.mission_s, tl.ramp_s);
            let m = self.mission.at(warp.s);
            FlightPoint {
                translation: warp.compose(&m),
                mission_s: warp.s,
                mission_rate: warp.rate,
                mission_translation: m,
            }
        } else {
            let to = on_ground(&last).p_b_in_w;
            let x = ((tau - tl.mission_s) / tl.landing_s).min(1.0);
            held(s_end, last, septic_move(last.p_b_in_w, to, tl.landing_s, x))
        }
    }
}

/// At rest at `p`.
fn at_rest(p: Vector3<f64>) -> Translation {
    Translation {
        p_b_in_w: p,
        v_b_in_w: Vector3::zeros(),
        a_b_in_w: Vector3::zeros(),
        j_b_in_w: Vector3::zeros(),
    }
}

/// The septic rest-to-rest move from `from` to `to` in `duration_s`, at `x = τ/T` (clamped to
/// [0, 1]).
fn septic_move(from: Vector3<f64>, to: Vector3<f64>, duration_s: f64, x: f64) -> Translation {
    let [p, dp, ddp, dddp] = septic(x.clamp(0.0, 1.0));
    let delta = to - from;
    Translation {
        p_b_in_w: from + delta * p,
        v_b_in_w: delta * (dp / duration_s),
        a_b_in_w: delta * (ddp / duration_s.powi(2)),
        j_b_in_w: delta * (dddp / duration_s.powi(3)),
    }
}

/// Mission time and its first three derivatives at phase time `tau`.
struct Warp {
    s: f64,
    rate: f64,
    accel: f64,
    jerk: f64,
}

impl Warp {
    /// The flight's translation on the mission path `m` (evaluated at `self.s`), chain rule.
    fn compose(&self, m: &Translation) -> Translation {
        let (r, r2) = (self.rate, self.rate * self.rate);
        Translation {
            p_b_in_w: m.p_b_in_w,
            v_b_in_w: m.v_b_in_w * r,
            a_b_in_w: m.a_b_in_w * r2 + m.v_b_in_w * self.accel,
            j_b_in_w: m.j_b_in_w * (r2 * r)
                + m.a_b_in_w * (3.0 * r * self.accel)
                + m.v_b_in_w * self.jerk,
        }
    }
}

/// The mission's time warp (module doc) at `tau` ∈ [0, `length_s`].
fn time_warp(tau: f64, length_s: f64, ramp_s: f64) -> Warp {
    let s_end = length_s - ramp_s;
    if tau < ramp_s {
        let [i, s, ds, dds] = smooth_step(tau / ramp_s);
        Warp {
            s: ramp_s * i,
            rate: s,
            accel: ds / ramp_s,
            jerk: dds / (ramp_s * ramp_s),
        }
    } else if tau > length_s - ramp_s {
        let [i, s, ds, dds] = smooth_step((length_s - tau) / ramp_s);
        Warp {
            s: s_end - ramp_s * i,
            rate: s,
            accel: -ds / ramp_s,
            jerk: dds / (ramp_s * ramp_s),
        }
    } else {
        Warp {
            s: tau - ramp_s / 2.0,
            rate: 1.0,
            accel: 0.0,
            jerk: 0.0,
        }
    }
}

#[cfg(test)]
mod tests;
