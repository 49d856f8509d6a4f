//! What every family draws the same way: the IMU, the radio, the chain calibration, the start
//! and the duration; and where a heading toward an AP looks.

use super::mission::{FlightBox, MissionLimits, draw_mission, draw_yaw};
use super::sampler::Sampler;
use crate::csi::Bandwidth;
use crate::rig::array::CHANNEL_64_HZ;
use crate::sim::Scenario;
use crate::sim::baro::BaroConfig;
use crate::sim::flight::PhasesConfig;
use crate::sim::imu::{ImuConfig, ImuModel};
use crate::sim::radio::RadioConfig;
use crate::sim::room::{ObstacleConfig, RoomConfig};
use crate::sim::scenario::ApConfig;
use crate::sim::vibration::VibrationConfig;

/// How far an AP's antenna stands off its wall, m.
pub(super) const AP_WALL_OFFSET_M: f64 = 0.05;
/// Centre of the HT40− channel on channels 60 and 64, Hz.
const CHANNEL_62_HZ: f64 = 5.31e9;
/// Share of the flights that start in the air (no rest on the ground, no take-off).
pub(super) const AIRBORNE_SHARE: f64 = 0.1;
/// Flight lengths, s.
pub(super) const DURATION_S: (f64, f64) = (30.0, 600.0);
/// RMS rotor vibration on the accelerometer, m/s².
pub(super) const VIBRATION_M_S2: (f64, f64) = (0.1, 1.0);
/// RMS rotor vibration on the gyro, rad/s, at the two ends of [`VIBRATION_M_S2`]: a frame that
/// shakes the accelerometer more shakes the gyro more, so the gyro's level follows the
/// accelerometer's linearly between these.
pub(super) const VIBRATION_GYRO_RAD_S: (f64, f64) = (0.005, 0.03);
/// Packets per second from each AP.
pub(super) const PACKET_RATE_HZ: (f64, f64) = (10.0, 100.0);
/// Packet loss probability.
pub(super) const LOSS: (f64, f64) = (0.0, 0.2);

/// The rig and the flight's frame, drawn.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Rig {
    pub(super) imu: ImuConfig,
    pub(super) radio: RadioConfig,
    pub(super) phases: Option<PhasesConfig>,
    pub(super) duration_s: f64,
}

/// The phases of a flight that starts on the ground: those of the built-in scenarios.
pub(super) fn phases() -> PhasesConfig {
    PhasesConfig::default()
}

/// A multirotor's vibration of `accel_rms_m_s2` on the accelerometer ([`VIBRATION_GYRO_RAD_S`]
/// for the gyro's).
fn vibration(accel_rms_m_s2: f64) -> VibrationConfig {
    let (a, g) = (VIBRATION_M_S2, VIBRATION_GYRO_RAD_S);
    let gyro_rms_rad_s = g.0 + (accel_rms_m_s2 - a.0) * (g.1 - g.0) / (a.1 - a.0);
    VibrationConfig::typical(accel_rms_m_s2, gyro_rms_rad_s)
}

/// Draw order: IMU model, vibration; packet rate, loss, bandwidth, calibration; start;
/// duration.
pub(super) fn draw_rig(s: &mut Sampler) -> Rig {
    let imu = ImuConfig {
        rate_hz: 200.0,
        model: match s.index(2) {
            0 => ImuModel::Microstrain3dmGx4_25,
            _ => ImuModel::ConsumerMems,
        },
        vibration_m_s2: 0.0,
        vibration: Some(vibration(s.uniform_rounded(
            VIBRATION_M_S2.0,
            VIBRATION_M_S2.1,
            100.0,
        ))),
    };
    let packet_rate_hz = s.uniform_rounded(PACKET_RATE_HZ.0, PACKET_RATE_HZ.1, 1.0);
    let loss_probability = s.uniform_rounded(LOSS.0, LOSS.1, 1000.0);
    let bandwidth = s.pick(&[Bandwidth::Ht20, Bandwidth::Ht40]);
    // Lab calibration, a NIC restart since it, none: equally likely.
    let (lab_calibration, nic_restart) = s.pick(&[(true, false), (true, true), (false, false)]);
    let radio = RadioConfig {
        center_freq_hz: match bandwidth {
            Bandwidth::Ht20 => CHANNEL_64_HZ,
            Bandwidth::Ht40 => CHANNEL_62_HZ,
        },
        bandwidth,
        packet_rate_hz,
        loss_probability,
        lab_calibration,
        nic_restart,
        ..RadioConfig::default()
    };
    let phases = (!s.chance(AIRBORNE_SHARE)).then(phases);
    let duration_s = s.uniform_rounded(DURATION_S.0, DURATION_S.1, 1.0);
    Rig {
        imu,
        radio,
        phases,
        duration_s,
    }
}

/// Where a heading toward `ap` looks: the AP itself when it is on a wall, else (an AP on the
/// ceiling or hung from it, which the flight may pass under) the point of the nearest wall
/// level with it, so the bearing never turns on the spot.
pub(super) fn toward(ap: &ApConfig, size_m: [f64; 3], wall_offset_m: f64) -> [f64; 3] {
    let [x, y, z] = ap.position_m;
    let gaps = [x, size_m[0] - x, y, size_m[1] - y];
    if gaps.iter().any(|&g| g <= wall_offset_m + 1e-9) {
        return ap.position_m;
    }
    let nearest = (0..4).fold(0, |best, k| if gaps[k] < gaps[best] { k } else { best });
    match nearest {
        0 => [wall_offset_m, y, z],
        1 => [size_m[0] - wall_offset_m, y, z],
        2 => [x, wall_offset_m, z],
        _ => [x, size_m[1] - wall_offset_m, z],
    }
}

/// An AP on wall `wall` (0: x = 0, 1: x = size, 2: y = 0, 3: y = size), `along` m along it,
/// `offset_m` off it, at height `z_m`.
pub(super) fn on_wall(
    wall: usize,
    along: f64,
    z_m: f64,
    size_m: [f64; 3],
    offset_m: f64,
) -> [f64; 3] {
    match wall {
        0 => [offset_m, along, z_m],
        1 => [size_m[0] - offset_m, along, z_m],
        2 => [along, offset_m, z_m],
        _ => [along, size_m[1] - offset_m, z_m],
    }
}

/// Length of wall `wall` (the x = const walls run along y).
pub(super) fn wall_length(wall: usize, size_m: [f64; 3]) -> f64 {
    if wall < 2 { size_m[1] } else { size_m[0] }
}

/// Where a drawn flight is flown: its family's name, the room and what stands in it, the APs,
/// and the box the flight stays inside.
pub(super) struct Place {
    pub(super) family: &'static str,
    pub(super) room: RoomConfig,
    pub(super) obstacles: Vec<ObstacleConfig>,
    pub(super) aps: Vec<ApConfig>,
    pub(super) flight_box: FlightBox,
    pub(super) limits: MissionLimits,
}

/// The flight drawn in `place` with `s` (after the place's draws: mission, heading toward the
/// first AP where it looks at one, rig), as a scenario.
pub(super) fn flight_in(s: &mut Sampler, seed: u64, place: Place) -> Scenario {
    let family = place.family;
    let mission = draw_mission(s, &place.flight_box, &place.limits);
    let target = toward(&place.aps[0], place.room.size_m, AP_WALL_OFFSET_M);
    let (yaw, _) = draw_yaw(s, mission.kind, target);
    let rig = draw_rig(s);
    Scenario {
        name: format!("{family}-{seed}"),
        description: format!(
            "a flight drawn from the {family} family with seed {seed} (wins simulate --family \
             {family} --seed {seed})"
        ),
        seed,
        duration_s: rig.duration_s,
        phases: rig.phases,
        trajectory: mission.trajectory,
        yaw,
        imu: rig.imu,
        radio: rig.radio,
        room: place.room,
        obstacle: None,
        obstacles: place.obstacles,
        baro: Some(BaroConfig::default()),
        aps: place.aps,
        ..Scenario::default()
    }
}
