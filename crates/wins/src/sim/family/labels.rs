//! What was drawn, as a small record: the labels a sweep writes beside each run and breaks its
//! results down by. They are read off the scenario as flown, so an override (a shorter flight,
//! an airborne start) shows in them.

use std::f64::consts::TAU;

use serde::{Deserialize, Serialize};

use super::Family;
use crate::csi::Bandwidth;
use crate::sim::imu::ImuModel;
use crate::sim::scenario::Scenario;
use crate::sim::trajectory::TrajectoryConfig;
use crate::sim::yaw::YawMode;

/// The IMU's class.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImuClass {
    /// The paper's MicroStrain 3DM-GX4-25.
    Tactical,
    /// A consumer MEMS part (BMI088 class).
    Consumer,
    /// Another model (ideal or custom; never drawn).
    Other,
}

/// How the flight starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Start {
    /// On the ground: rest, take-off, mission, landing, rest (`[phases]`).
    Ground,
    /// In the air, no rest (no `[phases]`): the initialization-free case.
    Air,
}

/// The receive chains' calibration the dataset ships.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Calibration {
    /// The lab calibration, still valid (`radio.lab_calibration`).
    Lab,
    /// The lab calibration, but the NIC restarted since (`radio.nic_restart`): off by π steps.
    Restart,
    /// None (`radio.lab_calibration = false`).
    None,
}

/// The mission's kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrajectoryKind {
    /// A horizontal circle.
    Circle,
    /// A figure-eight.
    FigureEight,
    /// A smooth random flight.
    RandomSmooth,
    /// A closed waypoint loop.
    Waypoints,
    /// A hover (never drawn).
    Hover,
}

impl TrajectoryKind {
    /// The kinds a family draws, each equally likely.
    pub const DRAWN: [Self; 4] = [
        Self::Circle,
        Self::FigureEight,
        Self::RandomSmooth,
        Self::Waypoints,
    ];
}

/// The heading's base mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum YawKind {
    /// A fixed heading.
    Fixed,
    /// Toward a point (an AP).
    TowardPoint,
    /// Along the flight.
    Tangent,
}

/// What was drawn: the labels of one flight of a family.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrawnFlight {
    /// The family.
    pub family: Family,
    /// The seed it was drawn with.
    pub seed: u64,
    /// Access points.
    pub aps: usize,
    /// The IMU's class.
    pub imu: ImuClass,
    /// Packets per second from each AP.
    pub packet_rate_hz: f64,
    /// Probability that a packet is lost.
    pub loss_probability: f64,
    /// Channel width.
    pub bandwidth: Bandwidth,
    /// On the ground or in the air at t = 0.
    pub start: Start,
    /// The chain calibration shipped.
    pub calibration: Calibration,
    /// The mission's kind.
    pub trajectory: TrajectoryKind,
    /// The heading's mode.
    pub yaw: YawKind,
    /// The mission's speed, m/s: a circle's, a loop's cruise, an eight's peak, a random
    /// flight's bound.
    pub speed_m_s: f64,
    /// Flight length, s.
    pub duration_s: f64,
    /// Obstacle boxes (boards, racks).
    pub obstacles: usize,
    /// RMS rotor vibration on each accelerometer axis, m/s².
    pub vibration_m_s2: f64,
}

impl DrawnFlight {
    /// The labels of `scenario`, drawn from `family` with `seed`.
    pub fn of(family: Family, seed: u64, scenario: &Scenario) -> Self {
        let radio = &scenario.radio;
        let (trajectory, speed_m_s) = match &scenario.trajectory {
            TrajectoryConfig::Circle { speed_m_s, .. } => (TrajectoryKind::Circle, *speed_m_s),
            TrajectoryConfig::FigureEight {
                half_length_m,
                half_width_m,
                period_s,
                ..
            } => (
                TrajectoryKind::FigureEight,
                TAU / period_s
                    * (half_length_m * half_length_m + 4.0 * half_width_m * half_width_m).sqrt(),
            ),
            TrajectoryConfig::RandomSmooth { max_speed_m_s, .. } => {
                (TrajectoryKind::RandomSmooth, *max_speed_m_s)
            }
            TrajectoryConfig::Waypoints { speed_m_s, .. } => {
                (TrajectoryKind::Waypoints, *speed_m_s)
            }
            TrajectoryConfig::Hover { .. } => (TrajectoryKind::Hover, 0.0),
        };
        Self {
            family,
            seed,
            aps: scenario.aps.len(),
            imu: match scenario.imu.model {
                ImuModel::Microstrain3dmGx4_25 => ImuClass::Tactical,
                ImuModel::ConsumerMems => ImuClass::Consumer,
                _ => ImuClass::Other,
            },
            packet_rate_hz: radio.packet_rate_hz,
            loss_probability: radio.loss_probability,
            bandwidth: radio.bandwidth,
            start: if scenario.phases.is_some() {
                Start::Ground
            } else {
                Start::Air
            },
            calibration: match (radio.lab_calibration, radio.nic_restart) {
                (false, _) => Calibration::None,
                (true, true) => Calibration::Restart,
                (true, false) => Calibration::Lab,
            },
            trajectory,
            yaw: match scenario.yaw.mode {
                YawMode::Fixed { .. } => YawKind::Fixed,
                YawMode::TowardPoint { .. } => YawKind::TowardPoint,
                YawMode::Tangent => YawKind::Tangent,
            },
            speed_m_s,
            duration_s: scenario.duration_s,
            obstacles: scenario.all_obstacles().len(),
            vibration_m_s2: scenario
                .imu
                .vibration_model()
                .map_or(0.0, |v| v.accel_rms_m_s2),
        }
    }

    /// `(name, value)` of every label, in the record's order, values as `drawn.toml` writes them
    /// (numbers as the shortest text that reads back to the same `f64`).
    pub fn labels(&self) -> Vec<(&'static str, String)> {
        vec![
            ("family", self.family.name().to_string()),
            ("seed", self.seed.to_string()),
            ("aps", self.aps.to_string()),
            ("imu", serialized_name(&self.imu)),
            ("packet_rate_hz", self.packet_rate_hz.to_string()),
            ("loss_probability", self.loss_probability.to_string()),
            ("bandwidth", serialized_name(&self.bandwidth)),
            ("start", serialized_name(&self.start)),
            ("calibration", serialized_name(&self.calibration)),
            ("trajectory", serialized_name(&self.trajectory)),
            ("yaw", serialized_name(&self.yaw)),
            ("speed_m_s", self.speed_m_s.to_string()),
            ("duration_s", self.duration_s.to_string()),
            ("obstacles", self.obstacles.to_string()),
            ("vibration_m_s2", self.vibration_m_s2.to_string()),
        ]
    }

    /// The labels but the family and the seed, in words: `aps 2, imu consumer, …`.
    pub fn describe(&self) -> String {
        let labels: Vec<String> = self
            .labels()
            .into_iter()
            .skip(2)
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        labels.join(", ")
    }
}

/// A unit enum's serialized name (`tactical`, `ht40`, `figure-eight`).
fn serialized_name<T: Serialize>(value: &T) -> String {
    // A unit variant serializes to a string; nothing here can fail.
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

/// A label a sweep's summary breaks a family's runs down by: each value its own group, or,
/// with `bins`, one group per interval `[bins[k], bins[k+1])` (the last one closed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelBreakdown {
    /// The label's name (a key of [`DrawnFlight::labels`]).
    pub label: &'static str,
    /// Bin edges, increasing; empty: each value is a group.
    pub bins: &'static [f64],
}

/// The breakdowns of a family's runs, in the order the tables show them.
pub const BREAKDOWNS: &[LabelBreakdown] = &[
    LabelBreakdown {
        label: "aps",
        bins: &[],
    },
    LabelBreakdown {
        label: "imu",
        bins: &[],
    },
    LabelBreakdown {
        label: "packet_rate_hz",
        bins: &[10.0, 25.0, 50.0, 100.0],
    },
    LabelBreakdown {
        label: "start",
        bins: &[],
    },
    LabelBreakdown {
        label: "calibration",
        bins: &[],
    },
    LabelBreakdown {
        label: "trajectory",
        bins: &[],
    },
    LabelBreakdown {
        label: "bandwidth",
        bins: &[],
    },
];

impl LabelBreakdown {
    /// The group of a label's value (`None`: an empty cell, or a number outside the bins); a
    /// bin is named `low–high`.
    pub fn group(&self, value: &str) -> Option<(usize, String)> {
        if value.is_empty() {
            return None;
        }
        if self.bins.is_empty() {
            return Some((0, value.to_string()));
        }
        let x: f64 = value.parse().ok()?;
        let last = self.bins.len().checked_sub(2)?;
        (0..=last)
            .find(|&k| {
                x >= self.bins[k] && (x < self.bins[k + 1] || (k == last && x <= self.bins[k + 1]))
            })
            .map(|k| (k, format!("{}–{}", self.bins[k], self.bins[k + 1])))
    }
}
