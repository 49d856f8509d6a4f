//! A scenario: everything the simulator needs, as one TOML document.
//!
//! Built-in scenarios live in `configs/scenarios/*.toml` and are compiled in;
//! `wins simulate --print-scenario NAME` prints one to edit and `--scenario-file` runs the edit.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::baro::BaroConfig;
use super::flight::{Flight, PhasesConfig};
use super::imu::ImuConfig;
use super::motion::STANDARD_GRAVITY_M_S2;
use super::radio::RadioConfig;
use super::radio::card_chains;
use super::room::{ObstacleConfig, RoomConfig};
use super::trajectory::TrajectoryConfig;
use super::yaw::YawConfig;
use crate::csi::format::CaptureFormat;
use crate::rig::ArrayGeometry;

mod built_in;
mod validate;
pub use built_in::{BUILT_IN, built_in_toml, printable_toml};
pub use validate::{MAX_SIM_IMU_SAMPLES, MAX_SIM_PACKETS};

/// How the antenna array sits on the body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Extrinsic {
    /// Position of the array centre in the body (IMU) frame, m.
    pub translation_m: [f64; 3],
    /// Orientation of the array frame in the body frame as roll, pitch, yaw in degrees
    /// (`body_from_array = Rz(yaw)·Ry(pitch)·Rx(roll)`). Zero: normal along body x, antennas
    /// along body y.
    pub rotation_rpy_deg: [f64; 3],
}

impl Default for Extrinsic {
    /// The array 8 cm above the IMU, normal along the body's x axis.
    fn default() -> Self {
        Self {
            translation_m: [0.0, 0.0, 0.08],
            rotation_rpy_deg: [0.0; 3],
        }
    }
}

impl Extrinsic {
    /// `body_from_array` as an isometry.
    pub fn body_from_array(&self) -> Isometry3<f64> {
        let [r, p, y] = self.rotation_rpy_deg.map(f64::to_radians);
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation_m)),
            UnitQuaternion::from_euler_angles(r, p, y),
        )
    }
}

/// The receive array: geometry and mounting.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArrayConfig {
    /// Antenna count and spacing.
    pub geometry: ArrayGeometry,
    /// Mounting on the body.
    pub body_from_array: Extrinsic,
}

/// One access point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ApConfig {
    /// Name: letters, digits, `-` and `_` (it names the `.dat` file).
    pub name: String,
    /// Antenna position in the world frame, m.
    pub position_m: [f64; 3],
    /// Transmit power, dBm (default: `radio.tx_power_dbm`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tx_power_dbm: Option<f64>,
    /// Packet rate, Hz (default: `radio.packet_rate_hz`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub packet_rate_hz: Option<f64>,
}

/// A whole simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Short name.
    pub name: String,
    /// One line on what it exercises.
    pub description: String,
    /// Master seed; every random stream derives its own seed from it (see `sim::rng`).
    pub seed: u64,
    /// Length of the flight, s (phases included).
    pub duration_s: f64,
    /// Gravity magnitude, m/s².
    pub gravity_m_s2: f64,
    /// On the ground, take-off, landing around the mission; absent: the mission alone,
    /// airborne from t = 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phases: Option<PhasesConfig>,
    /// The mission's path.
    pub trajectory: TrajectoryConfig,
    /// The heading profile (on mission time, see [`super::flight`]).
    pub yaw: YawConfig,
    /// The IMU.
    pub imu: ImuConfig,
    /// The antenna array.
    pub array: ArrayConfig,
    /// Channel, link budget, NIC impairments, packet timing.
    pub radio: RadioConfig,
    /// The room.
    pub room: RoomConfig,
    /// A box that attenuates the paths crossing it (one; `obstacles` takes any number).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub obstacle: Option<ObstacleConfig>,
    /// Boxes (shelving, boards) that attenuate the paths crossing them, each with its own
    /// attenuation (TOML `[[obstacles]]`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<ObstacleConfig>,
    /// The flight controller's barometer; absent: no `baro.csv`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baro: Option<BaroConfig>,
    /// The access points.
    pub aps: Vec<ApConfig>,
}

impl Default for Scenario {
    /// One AP at the short wall, a hover in the middle of the default room.
    fn default() -> Self {
        Self {
            name: "default".into(),
            description: String::new(),
            seed: 1,
            duration_s: 60.0,
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            phases: None,
            trajectory: TrajectoryConfig::Hover {
                position_m: [6.0, 4.0, 1.5],
            },
            yaw: YawConfig::default(),
            imu: ImuConfig::default(),
            array: ArrayConfig::default(),
            radio: RadioConfig::default(),
            room: RoomConfig::default(),
            obstacle: None,
            obstacles: Vec::new(),
            baro: None,
            aps: vec![ApConfig {
                name: "ap0".into(),
                position_m: [1.0, 4.0, 1.5],
                tx_power_dbm: None,
                packet_rate_hz: None,
            }],
        }
    }
}

/// Failure to obtain a scenario.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// No built-in scenario has this name.
    #[error("no built-in scenario {name:?} (built in: {known})")]
    Unknown {
        /// The name asked for.
        name: String,
        /// The names there are, comma separated.
        known: String,
    },
    /// A scenario file that cannot be read.
    #[error("cannot read scenario file {path}: {source}")]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The TOML does not parse into a scenario.
    #[error("scenario {origin}: {source}")]
    Parse {
        /// Where the text came from.
        origin: String,
        /// The parser's message (line and column included).
        source: toml::de::Error,
    },
    /// The scenario cannot be written as TOML.
    #[error("cannot write the scenario as TOML: {0}")]
    Serialize(#[from] toml::ser::Error),
    /// It parses but cannot be simulated.
    #[error("scenario {origin}: {source}")]
    Invalid {
        /// Where the text came from.
        origin: String,
        /// What is wrong.
        source: ConfigError,
    },
}

impl Scenario {
    /// The same flight started in the air: the phases (rest, take-off, landing) removed, so the
    /// mission is flown from t = 0 at its own speed, as every flight was before phases existed.
    pub fn airborne(mut self) -> Self {
        self.phases = None;
        self
    }

    /// The same flight received by `card` ([`super::radio::RadioConfig::card`]; checked by
    /// [`Self::validate`]: the simulator writes the cards of [`super::radio::SIM_CARDS`]).
    /// The Intel AX210 has two chains: its rig keeps the first two antennas (and their chain
    /// offsets, when the scenario gives them).
    pub fn with_card(mut self, card: CaptureFormat) -> Self {
        self.radio.card = card;
        if let Some(n) = card_chains(card).filter(|&n| self.array.geometry.num_antennas > n) {
            self.array.geometry.num_antennas = n;
            self.radio.chain_phase_offsets_deg.truncate(n);
        }
        self
    }

    /// The same flight without rotor vibration on its IMU (`[imu.vibration]` and the deprecated
    /// `vibration_m_s2` dropped): the IMU's own noise alone, for checks of one component.
    pub fn without_vibration(mut self) -> Self {
        self.imu.vibration = None;
        self.imu.vibration_m_s2 = 0.0;
        self
    }

    /// The scenario with a user's overrides: its master `seed` and `duration_s` when given, and
    /// started in the air ([`Scenario::airborne`]) when `airborne`.
    pub fn with_overrides(
        mut self,
        seed: Option<u64>,
        duration_s: Option<f64>,
        airborne: bool,
    ) -> Self {
        if let Some(seed) = seed {
            self.seed = seed;
        }
        if let Some(d) = duration_s {
            self.duration_s = d;
        }
        if airborne { self.airborne() } else { self }
    }

    /// The built-in scenario `name`, parsed and validated.
    pub fn built_in(name: &str) -> Result<Self, ScenarioError> {
        let text = built_in_toml(name)?;
        Self::from_toml(text, &format!("built-in {name}"))
    }

    /// Reads, parses and validates a scenario file (what `wins simulate --scenario-file` and
    /// `wins sweep` read); errors name the file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// Parses and validates a scenario; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ScenarioError> {
        let scenario: Self = toml::from_str(text).map_err(|source| ScenarioError::Parse {
            origin: origin.to_string(),
            source,
        })?;
        scenario
            .validate()
            .map_err(|source| ScenarioError::Invalid {
                origin: origin.to_string(),
                source,
            })?;
        Ok(scenario)
    }

    /// The scenario as TOML, every field spelt out (defaults included).
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(self)
    }

    /// The array frame relative to the body.
    pub fn body_from_array(&self) -> Isometry3<f64> {
        self.array.body_from_array.body_from_array()
    }

    /// Flight length in integer nanoseconds.
    pub fn duration_ns(&self) -> i64 {
        (self.duration_s * 1e9).round() as i64
    }

    /// Every obstacle: `obstacle` then `obstacles`.
    pub fn all_obstacles(&self) -> Vec<ObstacleConfig> {
        self.obstacle
            .iter()
            .chain(&self.obstacles)
            .cloned()
            .collect()
    }

    /// The flight: the mission path (built with the trajectory stream's seed, which only the
    /// random flight uses) inside the phases, if any.
    pub fn build_flight(&self) -> Flight {
        let seed = super::rng::stream_seed(self.seed, super::rng::TRAJECTORY_STREAM);
        match &self.phases {
            Some(phases) => Flight::with_phases(
                self.trajectory
                    .build(seed, phases.mission_s(self.duration_s)),
                phases,
                self.duration_s,
            ),
            None => self.trajectory.build(seed, self.duration_s).into(),
        }
    }
}
