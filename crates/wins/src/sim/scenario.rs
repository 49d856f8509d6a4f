//! A scenario: everything the simulator needs, as one TOML document.
//!
//! Built-in scenarios live in `configs/scenarios/*.toml` and are compiled in;
//! `wins simulate --print-scenario NAME` prints one to edit and `--scenario-file` runs the edit.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::baro::BaroConfig;
use super::flight::{Flight, MIN_CLIMB_M, PhasesConfig};
use super::imu::ImuConfig;
use super::motion::{STANDARD_GRAVITY_M_S2, sample};
use super::radio::RadioConfig;
use super::room::{ObstacleConfig, RoomConfig};
use super::trajectory::TrajectoryConfig;
use super::yaw::YawConfig;
use crate::check::num;
use crate::rig::ArrayGeometry;

mod built_in;
pub use built_in::{BUILT_IN, built_in_toml, printable_toml};

/// Sampling step of the checks that the flight stays in the room and flyable.
const VALIDATION_STEP_S: f64 = 0.05;
/// Closest the array may come to a wall, floor or ceiling, m.
const WALL_MARGIN_M: f64 = 0.1;
/// Closest the array may come to an AP, m (the far-field model needs a few wavelengths).
const MIN_AP_DISTANCE_M: f64 = 0.3;

/// Most IMU samples one simulation holds (the simulator keeps the whole flight in memory, about
/// 300 bytes per sample with its truth): 1 h at 400 Hz.
pub const MAX_SIM_IMU_SAMPLES: f64 = 1_440_000.0;
/// Most packet slots, every AP's together, one simulation holds (about 1 kB each with the CSI and
/// its truth): 1 h at 200 packets/s.
pub const MAX_SIM_PACKETS: f64 = 720_000.0;

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

    /// Checks every field, then that the flight stays in the room, is flyable (|a| < g) and keeps
    /// clear of the APs.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.duration_s.is_finite() && self.duration_s > 0.0 && self.duration_s <= 3600.0) {
            return Err(ConfigError::new(
                "duration_s",
                format!("{} is not in (0, 3600] s", self.duration_s),
            ));
        }
        if !(self.gravity_m_s2.is_finite() && (1.0..=30.0).contains(&self.gravity_m_s2)) {
            return Err(ConfigError::new(
                "gravity_m_s2",
                format!("{} is not in [1, 30]", self.gravity_m_s2),
            ));
        }
        if let Some(phases) = &self.phases {
            phases.validate("phases", self.duration_s)?;
        }
        self.trajectory.validate("trajectory")?;
        self.yaw.validate("yaw")?;
        self.imu.validate("imu")?;
        let g = &self.array.geometry;
        if let Err(e) = g.validate(self.radio.center_freq_hz) {
            return Err(ConfigError::new("array.geometry", e.to_string()));
        }
        let e = &self.array.body_from_array;
        if e.translation_m
            .iter()
            .chain(&e.rotation_rpy_deg)
            .any(|v| !v.is_finite())
        {
            return Err(ConfigError::new("array.body_from_array", "not all finite"));
        }
        self.radio.validate("radio", g.num_antennas)?;
        self.room.validate("room")?;
        if let Some(o) = &self.obstacle {
            o.validate("obstacle")?;
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            o.validate(&format!("obstacles[{i}]"))?;
        }
        if let Some(b) = &self.baro {
            b.validate("baro")?;
        }
        self.validate_aps()?;
        self.validate_size()?;
        self.validate_flight()
    }

    /// The flight's IMU samples and packet slots within what the simulator may hold.
    fn validate_size(&self) -> Result<(), ConfigError> {
        let imu = self.duration_s * self.imu.rate_hz;
        if imu > MAX_SIM_IMU_SAMPLES {
            return Err(ConfigError::new(
                "imu.rate_hz",
                format!(
                    "duration_s {} at imu.rate_hz {} gives {} IMU samples; at most {} (the \
                     simulator holds the whole flight in memory): shorten the flight or lower \
                     the rate",
                    num(self.duration_s),
                    num(self.imu.rate_hz),
                    num(imu.ceil()),
                    num(MAX_SIM_IMU_SAMPLES)
                ),
            ));
        }
        let packets: f64 = self
            .aps
            .iter()
            .map(|ap| self.duration_s * ap.packet_rate_hz.unwrap_or(self.radio.packet_rate_hz))
            .sum();
        if packets > MAX_SIM_PACKETS {
            return Err(ConfigError::new(
                "radio.packet_rate_hz",
                format!(
                    "duration_s {} at the APs' packet rates gives {} packet slots; at most {} \
                     (the simulator holds the whole flight in memory): shorten the flight, \
                     lower the rates or use fewer APs",
                    num(self.duration_s),
                    num(packets.ceil()),
                    num(MAX_SIM_PACKETS)
                ),
            ));
        }
        Ok(())
    }

    fn validate_aps(&self) -> Result<(), ConfigError> {
        if self.aps.is_empty() {
            return Err(ConfigError::new("aps", "no access point"));
        }
        for (i, ap) in self.aps.iter().enumerate() {
            let field = format!("aps[{i}]");
            let name_ok = !ap.name.is_empty()
                && ap.name.len() <= 64
                && ap
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
            if !name_ok {
                return Err(ConfigError::new(
                    format!("{field}.name"),
                    format!("{:?}: use 1–64 letters, digits, '-' or '_'", ap.name),
                ));
            }
            if self.aps[..i].iter().any(|o| o.name == ap.name) {
                return Err(ConfigError::new(
                    format!("{field}.name"),
                    format!("{:?} twice", ap.name),
                ));
            }
            let p = Vector3::from(ap.position_m);
            if !self.room.contains(&p) {
                return Err(ConfigError::new(
                    format!("{field}.position_m"),
                    format!(
                        "{:?} is not inside the room {:?}",
                        ap.position_m, self.room.size_m
                    ),
                ));
            }
            if let Some(v) = ap
                .tx_power_dbm
                .filter(|v| !(v.is_finite() && v.abs() <= 100.0))
            {
                return Err(ConfigError::new(
                    format!("{field}.tx_power_dbm"),
                    format!("{v}"),
                ));
            }
            if let Some(v) = ap
                .packet_rate_hz
                .filter(|v| !(v.is_finite() && (0.1..=2000.0).contains(v)))
            {
                return Err(ConfigError::new(
                    format!("{field}.packet_rate_hz"),
                    format!("{v} is not in [0.1, 2000] Hz"),
                ));
            }
        }
        Ok(())
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

    fn validate_flight(&self) -> Result<(), ConfigError> {
        let traj = self.build_flight();
        if let (Some(phases), Some(ground_m)) = (&self.phases, traj.ground_height_m()) {
            let start_m = traj
                .at(phases.rest_s + phases.takeoff_s)
                .translation
                .p_b_in_w
                .z;
            let end_m = traj
                .at(self.duration_s - phases.final_rest_s - phases.landing_s)
                .translation
                .p_b_in_w
                .z;
            if start_m.min(end_m) < ground_m + MIN_CLIMB_M {
                return Err(ConfigError::new(
                    "phases.ground_height_m",
                    format!(
                        "the mission starts at {start_m:.2} m and ends at {end_m:.2} m, not \
                         {MIN_CLIMB_M} m above the ground ({ground_m} m)"
                    ),
                ));
            }
        }
        let body_from_array = self.body_from_array();
        let steps = (self.duration_s / VALIDATION_STEP_S).ceil() as usize;
        for i in 0..=steps {
            let t_s = (i as f64 * VALIDATION_STEP_S).min(self.duration_s);
            let s = sample(&traj, &self.yaw, self.gravity_m_s2, t_s);
            if s.a_b_in_w.norm() >= 0.9 * self.gravity_m_s2 {
                return Err(ConfigError::new(
                    "trajectory",
                    format!(
                        "acceleration {:.2} m/s² at t = {t_s:.2} s is too close to g for a quadrotor",
                        s.a_b_in_w.norm()
                    ),
                ));
            }
            let p_array = s.p_b_in_w + s.world_from_body * body_from_array.translation.vector;
            let size = Vector3::from(self.room.size_m);
            let inside = (0..3)
                .all(|k| p_array[k] >= WALL_MARGIN_M && p_array[k] <= size[k] - WALL_MARGIN_M);
            if !inside {
                return Err(ConfigError::new(
                    "trajectory",
                    format!(
                        "the array at t = {t_s:.2} s is at {:?}, within {WALL_MARGIN_M} m of the room's boundary or outside it",
                        p_array.as_slice()
                    ),
                ));
            }
            for ap in &self.aps {
                let d = (Vector3::from(ap.position_m) - p_array).norm();
                if d < MIN_AP_DISTANCE_M {
                    return Err(ConfigError::new(
                        "trajectory",
                        format!(
                            "the array passes {d:.2} m from AP {:?} at t = {t_s:.2} s",
                            ap.name
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}
