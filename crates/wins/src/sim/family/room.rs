//! The `room` family: offices and labs.
//!
//! Draw order (part of the reproducibility contract): the room's size and reflection
//! coefficients; the AP count, then each AP (ceiling or which wall, where); the board count,
//! then each board; the mission ([`super::mission::draw_mission`]); the heading; the rig
//! ([`super::rig::draw_rig`]).

use super::mission::{FlightBox, MissionLimits};
use super::rig::{self, on_wall, wall_length};
use super::sampler::{Sampler, round_to};
use crate::sim::Scenario;
use crate::sim::room::{ObstacleConfig, RoomConfig};
use crate::sim::scenario::ApConfig;

/// Inner size ranges (x, y, z), m.
pub(super) const SIZE_M: [(f64, f64); 3] = [(5.0, 15.0), (4.0, 12.0), (2.5, 4.0)];
/// APs per flight.
pub(super) const APS: (usize, usize) = (1, 3);
/// Share of the APs on the ceiling (the others on one of the four walls, each equally likely).
const CEILING_AP_SHARE: f64 = 1.0 / 3.0;
/// An AP on the ceiling hangs this far below it, m.
pub(super) const CEILING_AP_DROP_M: (f64, f64) = (0.05, 0.3);
/// Wall APs are at least this high, m, and this far under the ceiling.
const WALL_AP_Z_M: (f64, f64) = (0.5, 0.1);
/// Boards per flight.
pub(super) const BOARDS: (usize, usize) = (0, 2);
/// The flight keeps this far from the walls, m.
const FLIGHT_WALL_MARGIN_M: f64 = 0.6;
/// The flight keeps at least this high, m.
const FLIGHT_FLOOR_M: f64 = 0.6;
/// The flight keeps this far under the ceiling, m (an AP hangs up to 0.3 m under it).
const FLIGHT_CEILING_MARGIN_M: f64 = 0.8;

/// What the room allows a mission.
pub(super) const LIMITS: MissionLimits = MissionLimits {
    speed_m_s: (0.4, 2.5),
    accel_m_s2: 3.0,
    radius_m: (0.5, 6.0),
    loop_length_share: 0.5,
    corner_s: 2.0,
};

/// The flight of `seed` (not yet validated).
pub(super) fn draw(seed: u64) -> Scenario {
    let mut s = Sampler::new(seed, "room");
    let size_m = SIZE_M.map(|(lo, hi)| s.uniform_rounded(lo, hi, 10.0));
    let room = RoomConfig {
        size_m,
        wall_reflection: s.uniform_rounded(0.3, 0.6, 100.0),
        floor_reflection: s.uniform_rounded(0.4, 0.6, 100.0),
        ceiling_reflection: s.uniform_rounded(0.3, 0.5, 100.0),
        max_order: 1,
    };
    let aps: Vec<ApConfig> = (0..s.int(APS.0, APS.1))
        .map(|i| ApConfig {
            name: format!("ap{i}"),
            position_m: draw_ap(&mut s, size_m),
            tx_power_dbm: None,
            packet_rate_hz: None,
        })
        .collect();
    let boards: Vec<ObstacleConfig> = (0..s.int(BOARDS.0, BOARDS.1))
        .map(|_| {
            let ap = &aps[s.index(aps.len())];
            board(&mut s, ap.position_m, size_m)
        })
        .collect();
    let flight_box = FlightBox {
        min_m: [FLIGHT_WALL_MARGIN_M, FLIGHT_WALL_MARGIN_M, FLIGHT_FLOOR_M],
        max_m: [
            size_m[0] - FLIGHT_WALL_MARGIN_M,
            size_m[1] - FLIGHT_WALL_MARGIN_M,
            size_m[2] - FLIGHT_CEILING_MARGIN_M,
        ],
    };
    let place = rig::Place {
        family: "room",
        room,
        obstacles: boards,
        aps,
        flight_box,
        limits: LIMITS,
    };
    rig::flight_in(&mut s, seed, place)
}

/// An AP on the ceiling (hung 0.05–0.3 m under it) or on a wall (0.5 m up to 0.1 m under the
/// ceiling), anywhere along it but its last 0.3 m.
fn draw_ap(s: &mut Sampler, size_m: [f64; 3]) -> [f64; 3] {
    let h = size_m[2];
    if s.chance(CEILING_AP_SHARE) {
        return [
            s.uniform_rounded(0.3, size_m[0] - 0.3, 100.0),
            s.uniform_rounded(0.3, size_m[1] - 0.3, 100.0),
            s.uniform_rounded(h - CEILING_AP_DROP_M.1, h - CEILING_AP_DROP_M.0, 100.0),
        ];
    }
    let wall = s.index(4);
    let along = s.uniform_rounded(0.3, wall_length(wall, size_m) - 0.3, 100.0);
    let z = s.uniform_rounded(WALL_AP_Z_M.0, h - WALL_AP_Z_M.1, 100.0);
    on_wall(wall, along, z, size_m, rig::AP_WALL_OFFSET_M)
}

/// A board in front of the AP at `ap_m`: for a wall AP, upright and parallel to its wall,
/// 0.2–0.45 m off it (between the AP and the flight), 0.8–2 m wide and high around the AP; for a
/// ceiling AP, level 0.15 m under it, 0.8–2 m square. 5–15 dB per crossing.
fn board(s: &mut Sampler, ap_m: [f64; 3], size_m: [f64; 3]) -> ObstacleConfig {
    const THICKNESS_M: f64 = 0.03;
    let half_w = s.uniform_rounded(0.4, 1.0, 100.0);
    let half_h = s.uniform_rounded(0.4, 1.0, 100.0);
    let gap_m = s.uniform_rounded(0.2, 0.45, 100.0);
    let attenuation_db = s.uniform_rounded(5.0, 15.0, 10.0);
    let [x, y, z] = ap_m;
    let span = |c: f64, half: f64, axis: usize| ((c - half).max(0.0), (c + half).min(size_m[axis]));
    let gaps = [x, size_m[0] - x, y, size_m[1] - y];
    let wall = (0..4).find(|&k| gaps[k] <= rig::AP_WALL_OFFSET_M + 1e-9);
    let (min_m, max_m) = match wall {
        Some(w) => {
            let axis = w / 2;
            let plane = if w % 2 == 0 {
                gap_m
            } else {
                size_m[axis] - gap_m - THICKNESS_M
            };
            let (a0, a1) = span(if axis == 0 { y } else { x }, half_w, 1 - axis);
            let (z0, z1) = span(z, half_h, 2);
            let mut lo = [0.0, 0.0, z0];
            let mut hi = [0.0, 0.0, z1];
            lo[axis] = plane;
            hi[axis] = plane + THICKNESS_M;
            lo[1 - axis] = a0;
            hi[1 - axis] = a1;
            (lo, hi)
        }
        None => {
            let (x0, x1) = span(x, half_w, 0);
            let (y0, y1) = span(y, half_h, 1);
            ([x0, y0, z - 0.15 - THICKNESS_M], [x1, y1, z - 0.15])
        }
    };
    ObstacleConfig {
        min_m: min_m.map(|v| round_to(v, 1000.0)),
        max_m: max_m.map(|v| round_to(v, 1000.0)),
        attenuation_db,
    }
}
