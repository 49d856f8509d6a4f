//! The mission of a drawn flight: a circle, a figure-eight, a smooth random flight or a
//! waypoint loop inside the family's flight box, at a drawn speed that its size allows, and the
//! heading profile.
//!
//! Every kind stays in the box by construction: the circle's and the eight's centres are drawn
//! at least their half-extents from its faces, the random flight's bounds are a part of it, a
//! waypoint loop's corners are cut inside the polyline through waypoints in it. Each kind's
//! acceleration stays under the family's cap: a circle's `v²/r`, an eight's
//! `ω²·√(L² + 16W²)`, a random flight's `Σ|A|ω² ≤ ω_max·v`, a loop corner's
//! `|Δv|·(35/16)/corner_s`; the speed is lowered to what the size allows when the drawn one is
//! too fast for it.

use std::f64::consts::TAU;

use nalgebra::Vector3;

use super::sampler::{Sampler, ceil_to, floor_to, round_to};
use super::{TrajectoryKind, YawKind};
use crate::sim::trajectory::TrajectoryConfig;
use crate::sim::yaw::{YawConfig, YawMode};

/// Peak of the septic smooth step's rate, `S'(1/2) = 35/16` (a loop corner's peak acceleration
/// is `|Δv|·35/16 / corner_s`).
const SMOOTH_STEP_PEAK_RATE: f64 = 2.1875;
/// A loop's legs are at least this many times `speed · corner_s` (the validator's minimum is 1).
const LEG_SLACK: f64 = 0.9;

/// Where the body may fly: an axis-aligned box in the world frame, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FlightBox {
    /// Lower corner.
    pub(super) min_m: [f64; 3],
    /// Upper corner.
    pub(super) max_m: [f64; 3],
}

impl FlightBox {
    fn extent(&self, axis: usize) -> f64 {
        self.max_m[axis] - self.min_m[axis]
    }

    /// A centre drawn for a path reaching `half_x`, `half_y` from it: inside the box by those in
    /// x and y, anywhere in z (x, then y, then z drawn).
    fn centre(&self, s: &mut Sampler, half_x: f64, half_y: f64) -> [f64; 3] {
        [
            s.uniform_rounded(self.min_m[0] + half_x, self.max_m[0] - half_x, 100.0),
            s.uniform_rounded(self.min_m[1] + half_y, self.max_m[1] - half_y, 100.0),
            s.uniform_rounded(self.min_m[2], self.max_m[2], 100.0),
        ]
    }
}

/// What a family allows a mission.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct MissionLimits {
    /// Speeds drawn, m/s.
    pub(super) speed_m_s: (f64, f64),
    /// Largest acceleration the path may ask, m/s² (the validator's limit is 0.9 g, and the
    /// take-off's speed ramp adds to it).
    pub(super) accel_m_s2: f64,
    /// Circle radii, m (the upper end also bounded by the box).
    pub(super) radius_m: (f64, f64),
    /// Share of the box's length (x) a waypoint loop spans at least.
    pub(super) loop_length_share: f64,
    /// Corner blend of a waypoint loop when its legs and turns allow it, s.
    pub(super) corner_s: f64,
}

/// A drawn mission.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Mission {
    pub(super) trajectory: TrajectoryConfig,
    pub(super) kind: TrajectoryKind,
}

/// Draws the kind (each equally likely), then its size, place and speed.
pub(super) fn draw_mission(s: &mut Sampler, b: &FlightBox, lim: &MissionLimits) -> Mission {
    let kind = s.pick(&TrajectoryKind::DRAWN);
    let speed = s.uniform(lim.speed_m_s.0, lim.speed_m_s.1);
    let trajectory = match kind {
        TrajectoryKind::FigureEight => figure_eight(s, b, lim, speed),
        TrajectoryKind::RandomSmooth => random_smooth(s, b, lim, speed),
        TrajectoryKind::Waypoints => waypoint_loop(s, b, lim, speed),
        _ => circle(s, b, lim, speed),
    };
    Mission { trajectory, kind }
}

/// A circle: radius from what the speed needs (`v²/a ≤ r`) to what the box holds.
fn circle(s: &mut Sampler, b: &FlightBox, lim: &MissionLimits, speed: f64) -> TrajectoryConfig {
    let r_fit = floor_to(
        (b.extent(0).min(b.extent(1)) / 2.0).min(lim.radius_m.1),
        100.0,
    );
    let mut speed = floor_to(speed, 100.0);
    if speed * speed / lim.accel_m_s2 > r_fit {
        speed = floor_to((lim.accel_m_s2 * r_fit).sqrt(), 100.0);
    }
    let r_need = ceil_to(speed * speed / lim.accel_m_s2, 100.0);
    let radius_m = s.uniform_rounded(r_need.max(lim.radius_m.0), r_fit, 100.0);
    TrajectoryConfig::Circle {
        center_m: b.centre(s, radius_m, radius_m),
        radius_m,
        speed_m_s: speed,
        start_angle_deg: s.uniform_rounded(0.0, 359.0, 1.0),
        clockwise: s.chance(0.5),
    }
}

/// A figure-eight: half-length `L` along x (at least twice the smallest radius), half-width `W`
/// in [0.3, 0.6]·L; its period from the drawn peak speed `ω·√(L² + 4W²)`, lowered when
/// `ω²·√(L² + 16W²)` would pass the cap.
fn figure_eight(
    s: &mut Sampler,
    b: &FlightBox,
    lim: &MissionLimits,
    speed: f64,
) -> TrajectoryConfig {
    let (hx, hy) = (b.extent(0) / 2.0, b.extent(1) / 2.0);
    let l_max = floor_to(hx.min(hy / 0.3).min(lim.radius_m.1 * 2.0), 100.0);
    let half_length_m = s.uniform_rounded((2.0 * lim.radius_m.0).min(l_max), l_max, 100.0);
    let w_max = floor_to((0.6 * half_length_m).min(hy), 100.0);
    let half_width_m = s.uniform_rounded(ceil_to(0.3 * half_length_m, 100.0), w_max, 100.0);
    let (l2, w2) = (half_length_m * half_length_m, half_width_m * half_width_m);
    let path_scale = (l2 + 4.0 * w2).sqrt();
    let speed_cap = (lim.accel_m_s2 * (l2 + 4.0 * w2) / (l2 + 16.0 * w2).sqrt()).sqrt();
    let speed = speed.min(speed_cap);
    TrajectoryConfig::FigureEight {
        center_m: b.centre(s, half_length_m, half_width_m),
        half_length_m,
        half_width_m,
        // Rounded up: the flown speed is at most the drawn one.
        period_s: ceil_to(TAU * path_scale / speed, 100.0),
    }
}

/// A smooth random flight in a part of the box (at least half of it across, a fifth of it in
/// height); the shortest period keeps `ω_max·v` under the cap.
fn random_smooth(
    s: &mut Sampler,
    b: &FlightBox,
    lim: &MissionLimits,
    speed: f64,
) -> TrajectoryConfig {
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for axis in 0..3 {
        let share = if axis == 2 { 0.2 } else { 0.5 };
        let e = b.extent(axis);
        let width = floor_to(s.uniform(share * e, e), 100.0);
        lo[axis] = s.uniform_rounded(b.min_m[axis], b.max_m[axis] - width, 100.0);
        hi[axis] = round_to(lo[axis] + width, 100.0).min(b.max_m[axis]);
    }
    let max_speed_m_s = floor_to(speed, 100.0);
    let shortest_s = ceil_to((TAU * max_speed_m_s / lim.accel_m_s2).max(6.0), 10.0);
    let min_period_s = s.uniform_rounded(shortest_s, shortest_s + 6.0, 10.0);
    TrajectoryConfig::RandomSmooth {
        bounds_min_m: lo,
        bounds_max_m: hi,
        max_speed_m_s,
        num_harmonics: s.int(2, 5),
        min_period_s,
        max_period_s: s.uniform_rounded(min_period_s + 10.0, min_period_s + 30.0, 10.0),
    }
}

/// A closed loop through 3 to 6 waypoints: the corners of a rectangle in the box, each moved
/// inward by up to a fifth of the side, with the middles of the long sides added for 5 and 6,
/// flown either way round from any of them. Heights vary by ±0.5 m about a drawn one.
fn waypoint_loop(
    s: &mut Sampler,
    b: &FlightBox,
    lim: &MissionLimits,
    speed: f64,
) -> TrajectoryConfig {
    let (ex, ey) = (b.extent(0), b.extent(1));
    let wx = s.uniform(lim.loop_length_share * ex, ex);
    let wy = s.uniform(0.4 * ey, ey);
    let x0 = s.uniform(b.min_m[0], b.max_m[0] - wx);
    let y0 = s.uniform(b.min_m[1], b.max_m[1] - wy);
    let z_mid = s.uniform(b.min_m[2], b.max_m[2]);
    let n = s.int(3, 6);
    // Counter-clockwise: the rectangle's corners, the middle of a long side between them.
    let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
    let mut unit: Vec<(f64, f64)> = Vec::with_capacity(6);
    let dropped = if n == 3 { s.index(4) } else { usize::MAX };
    let long_x = wx >= wy;
    for (k, &(cx, cy)) in corners.iter().enumerate() {
        if k == dropped {
            continue;
        }
        // Inward: toward the rectangle's centre.
        let jx = s.uniform(0.0, 0.2);
        let jy = s.uniform(0.0, 0.2);
        unit.push((
            if cx > 0.5 { cx - jx } else { cx + jx },
            if cy > 0.5 { cy - jy } else { cy + jy },
        ));
        let middle_after = match (long_x, k) {
            (true, 0) => n >= 5,
            (true, 2) => n == 6,
            (false, 1) => n >= 5,
            (false, 3) => n == 6,
            _ => false,
        };
        if middle_after {
            let j = s.uniform(-0.1, 0.1);
            unit.push(match k {
                0 => (0.5, j.abs()),
                1 => (1.0 - j.abs(), 0.5),
                2 => (0.5, 1.0 - j.abs()),
                _ => (j.abs(), 0.5),
            });
        }
    }
    let mut points: Vec<[f64; 3]> = unit
        .iter()
        .map(|&(u, v)| {
            let z = (z_mid + s.uniform(-0.5, 0.5)).clamp(b.min_m[2], b.max_m[2]);
            [
                round_to(x0 + u * wx, 100.0).clamp(b.min_m[0], b.max_m[0]),
                round_to(y0 + v * wy, 100.0).clamp(b.min_m[1], b.max_m[1]),
                round_to(z, 100.0),
            ]
        })
        .collect();
    if s.chance(0.5) {
        points.reverse();
    }
    let start = s.index(points.len());
    points.rotate_left(start);
    let (speed_m_s, corner_s) = loop_timing(&points, speed, lim);
    TrajectoryConfig::Waypoints {
        points_m: points,
        speed_m_s,
        corner_s,
    }
}

/// Cruise speed and corner time of a loop: the corner time as long as the shortest leg allows
/// (`v·w ≤ 0.9·leg`), the family's when it can, and at least what the sharpest turn needs
/// (`|Δu|·v·(35/16)/w ≤ a`); the speed lowered when no corner time satisfies both.
fn loop_timing(points: &[[f64; 3]], speed: f64, lim: &MissionLimits) -> (f64, f64) {
    let n = points.len();
    let leg = |k: usize| Vector3::from(points[(k + 1) % n]) - Vector3::from(points[k]);
    let min_leg_m = (0..n).map(|k| leg(k).norm()).fold(f64::INFINITY, f64::min);
    let max_turn = (0..n)
        .map(|k| (leg(k).normalize() - leg((k + n - 1) % n).normalize()).norm())
        .fold(0.0, f64::max);
    let fastest =
        (lim.accel_m_s2 * LEG_SLACK * min_leg_m / (SMOOTH_STEP_PEAK_RATE * max_turn)).sqrt();
    let speed_m_s = floor_to(speed.min(fastest), 100.0);
    let longest = LEG_SLACK * min_leg_m / speed_m_s;
    let shortest = max_turn * speed_m_s * SMOOTH_STEP_PEAK_RATE / lim.accel_m_s2;
    let corner_s = floor_to(longest.min(shortest.max(lim.corner_s)), 100.0);
    (speed_m_s, corner_s)
}

/// The heading: fixed, toward `target_m` (horizontally), or along the flight (not for the random
/// flight, which may stop and turn anywhere), each allowed mode equally likely; plus an
/// oscillation of 0–60° with a 4–12 s period.
pub(super) fn draw_yaw(
    s: &mut Sampler,
    kind: TrajectoryKind,
    target_m: [f64; 3],
) -> (YawConfig, YawKind) {
    let modes: &[YawKind] = if kind == TrajectoryKind::RandomSmooth {
        &[YawKind::Fixed, YawKind::TowardPoint]
    } else {
        &[YawKind::Fixed, YawKind::TowardPoint, YawKind::Tangent]
    };
    let yaw_kind = s.pick(modes);
    let (mode, offset_deg) = match yaw_kind {
        YawKind::Fixed => (
            YawMode::Fixed {
                yaw_deg: s.uniform_rounded(-180.0, 179.0, 1.0),
            },
            0.0,
        ),
        YawKind::TowardPoint => (YawMode::TowardPoint { point_m: target_m }, 0.0),
        YawKind::Tangent => (YawMode::Tangent, s.uniform_rounded(-180.0, 179.0, 1.0)),
    };
    let yaw = YawConfig {
        mode,
        offset_deg,
        oscillation_amplitude_deg: s.uniform_rounded(0.0, 60.0, 1.0),
        oscillation_period_s: s.uniform_rounded(4.0, 12.0, 10.0),
    };
    (yaw, yaw_kind)
}
