//! The `hall` family: warehouses and factory halls with rows of racks.
//!
//! The racks stand along the long walls and the far end wall (one to three rows, each box as
//! tall as 3–8 m of shelving, 10–20 dB through); the flight keeps 1.2 m from them and 1.5 m from
//! the walls, 1–3 m up, in the open floor between them: long legs, wide circles, 1–5 m/s. The
//! APs are 3–10 m up, on the walls (behind the racks, often) or hung from the roof at least 1 m
//! above the flight.
//!
//! Draw order (part of the reproducibility contract): the hall's size and reflection
//! coefficients; the racks (which rows, depth, height, attenuation, where the long rows start);
//! the AP count, then each AP; the mission; the heading; the rig.

use super::mission::{FlightBox, MissionLimits};
use super::rig::{self, on_wall, wall_length};
use super::sampler::{Sampler, round_to};
use crate::sim::Scenario;
use crate::sim::room::{ObstacleConfig, RoomConfig};
use crate::sim::scenario::ApConfig;

/// Inner size ranges (x: length, y: width, z: height), m.
pub(super) const SIZE_M: [(f64, f64); 3] = [(20.0, 60.0), (10.0, 30.0), (6.0, 12.0)];
/// APs per flight.
pub(super) const APS: (usize, usize) = (1, 3);
/// AP heights, m (also at most 0.3 m under the roof).
pub(super) const AP_Z_M: (f64, f64) = (3.0, 10.0);
/// Share of the APs hung from the roof (the others on one of the four walls).
const HUNG_AP_SHARE: f64 = 0.25;
/// Racks stand this far from the walls, m.
const RACK_WALL_GAP_M: f64 = 0.3;
/// Depth of a row of racks, m.
const RACK_DEPTH_M: (f64, f64) = (1.0, 2.0);
/// The flight keeps this far from the racks, m.
const FLIGHT_RACK_MARGIN_M: f64 = 1.2;
/// The flight keeps this far from the walls, m.
const FLIGHT_WALL_MARGIN_M: f64 = 1.5;
/// The flight's height band, m.
const FLIGHT_Z_M: (f64, f64) = (1.0, 3.0);

/// What a hall allows a mission.
pub(super) const LIMITS: MissionLimits = MissionLimits {
    speed_m_s: (1.0, 5.0),
    accel_m_s2: 4.0,
    radius_m: (1.0, 10.0),
    loop_length_share: 0.6,
    corner_s: 3.0,
};

/// The flight of `seed` (not yet validated).
pub(super) fn draw(seed: u64) -> Scenario {
    let mut s = Sampler::new(seed, "hall");
    let size_m = SIZE_M.map(|(lo, hi)| s.uniform_rounded(lo, hi, 10.0));
    let [l, w, h] = size_m;
    let room = RoomConfig {
        size_m,
        wall_reflection: s.uniform_rounded(0.3, 0.6, 100.0),
        floor_reflection: s.uniform_rounded(0.4, 0.6, 100.0),
        ceiling_reflection: s.uniform_rounded(0.2, 0.4, 100.0),
        max_order: 1,
    };
    // Rows: bit 0 along y = 0, bit 1 along y = W, bit 2 across the far end; never none.
    let rows = s.int(1, 7);
    let depth = s.uniform_rounded(RACK_DEPTH_M.0, RACK_DEPTH_M.1, 10.0);
    let rack_h = s.uniform_rounded(3.0, 8.0_f64.min(h - 1.0), 10.0);
    let attenuation_db = s.uniform_rounded(10.0, 20.0, 10.0);
    let x0 = s.uniform_rounded(RACK_WALL_GAP_M, 0.5 * l, 10.0);
    let (near, far) = (RACK_WALL_GAP_M, RACK_WALL_GAP_M + depth);
    let rack = |min_m: [f64; 3], max_m: [f64; 3]| ObstacleConfig {
        min_m: min_m.map(|v| round_to(v, 1000.0)),
        max_m: max_m.map(|v| round_to(v, 1000.0)),
        attenuation_db,
    };
    let mut racks = Vec::with_capacity(3);
    if rows & 1 != 0 {
        racks.push(rack([x0, near, 0.0], [l - near, far, rack_h]));
    }
    if rows & 2 != 0 {
        racks.push(rack([x0, w - far, 0.0], [l - near, w - near, rack_h]));
    }
    if rows & 4 != 0 {
        racks.push(rack([l - far, near, 0.0], [l - near, w - near, rack_h]));
    }
    let aps: Vec<ApConfig> = (0..s.int(APS.0, APS.1))
        .map(|i| ApConfig {
            name: format!("ap{i}"),
            position_m: draw_ap(&mut s, size_m),
            tx_power_dbm: None,
            packet_rate_hz: None,
        })
        .collect();
    let clear = far + FLIGHT_RACK_MARGIN_M;
    let flight_box = FlightBox {
        min_m: [
            FLIGHT_WALL_MARGIN_M,
            if rows & 1 != 0 {
                clear
            } else {
                FLIGHT_WALL_MARGIN_M
            },
            FLIGHT_Z_M.0,
        ],
        max_m: [
            l - if rows & 4 != 0 {
                clear
            } else {
                FLIGHT_WALL_MARGIN_M
            },
            w - if rows & 2 != 0 {
                clear
            } else {
                FLIGHT_WALL_MARGIN_M
            },
            FLIGHT_Z_M.1,
        ],
    };
    let place = rig::Place {
        family: "hall",
        room,
        obstacles: racks,
        aps,
        flight_box,
        limits: LIMITS,
    };
    rig::flight_in(&mut s, seed, place)
}

/// An AP 3–10 m up (and at most 0.3 m under the roof): on a wall, anywhere along it but its
/// last metre, or hung from the roof over the floor at least 1 m above the flight.
fn draw_ap(s: &mut Sampler, size_m: [f64; 3]) -> [f64; 3] {
    let top = AP_Z_M.1.min(size_m[2] - 0.3);
    if s.chance(HUNG_AP_SHARE) {
        return [
            s.uniform_rounded(2.0, size_m[0] - 2.0, 100.0),
            s.uniform_rounded(2.0, size_m[1] - 2.0, 100.0),
            s.uniform_rounded(FLIGHT_Z_M.1 + 1.0, top, 100.0),
        ];
    }
    let wall = s.index(4);
    let along = s.uniform_rounded(1.0, wall_length(wall, size_m) - 1.0, 100.0);
    let z = s.uniform_rounded(AP_Z_M.0, top, 100.0);
    on_wall(wall, along, z, size_m, rig::AP_WALL_OFFSET_M)
}
