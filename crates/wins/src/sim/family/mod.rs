//! Flight families: seeded generators that draw whole flights from a distribution.
//!
//! A built-in scenario is one flight; a family is a distribution over flights. `Family::draw`
//! turns a seed into a complete [`Scenario`] (room, APs, obstacles, mission, heading, IMU,
//! radio, chain calibration, start, duration, vibration) and the record of what was drawn
//! ([`DrawnFlight`], the labels a sweep's tables break results down by). The same seed draws the
//! same flight on any machine: the draws come from one named stream of the seed
//! (`family/<name>`, see [`crate::sim::rng`]) through arithmetic alone (no `sin`, `exp` or
//! `powf`, whose last bit may differ between maths libraries), in a fixed order, and every drawn
//! scenario is validated before it is returned. The ranges of each family are in
//! docs/DESIGN.md §8.
//!
//! ```text
//!  seed ─► family/<name> stream ─► room, APs, obstacles ─► flight box ─► mission, heading
//!                                  ─► IMU, radio, calibration, start, duration ─► Scenario ─► validate
//!                                                                              └► DrawnFlight (labels)
//! ```
//!
//! `wins simulate --family NAME --seed S` writes a draw as a dataset with its scenario
//! ([`SCENARIO_FILE`], which `--scenario-file` flies again alone) and labels ([`DRAWN_FILE`]);
//! `wins sweep --family NAME` flies many (docs/SWEEP.md).

mod hall;
mod labels;
mod mission;
mod rig;
mod room;
mod sampler;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use labels::{
    BREAKDOWNS, Calibration, DrawnFlight, ImuClass, LabelBreakdown, Start, TrajectoryKind, YawKind,
};

use super::ConfigError;
use super::scenario::{Scenario, ScenarioError};

/// Version of the draws: a change to any family's distribution or draw order bumps it (it is
/// part of a sweep plan's identity, so shards drawn differently are not merged).
pub const GENERATOR_VERSION: u32 = 1;
/// The drawn scenario's file beside a dataset written by `wins simulate --family`.
pub const SCENARIO_FILE: &str = "scenario.toml";
/// The drawn labels' file beside it.
pub const DRAWN_FILE: &str = "drawn.toml";

/// A distribution of flights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// Offices and labs: 5–15 × 4–12 × 2.5–4 m, 1–3 APs on the walls or the ceiling, 0.4–2.5 m/s.
    Room,
    /// Warehouse halls: 20–60 × 10–30 × 6–12 m with racks, 1–3 APs 3–10 m up, 1–5 m/s.
    Hall,
}

/// Every family, in the order they are listed.
pub const FAMILIES: [Family; 2] = [Family::Room, Family::Hall];

/// Why a flight cannot be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum FamilyError {
    /// No family has this name.
    #[error("no flight family {name:?} (families: {known})")]
    Unknown {
        /// The name asked for.
        name: String,
        /// The names there are, comma separated.
        known: String,
    },
    /// A drawn flight (with its overrides) that does not validate.
    #[error("the flight drawn from family {family} with seed {seed}: {source}")]
    Invalid {
        /// The family's name.
        family: &'static str,
        /// The seed.
        seed: u64,
        /// What is wrong.
        source: ConfigError,
    },
    /// The scenario cannot be written as TOML.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A file that cannot be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

impl Family {
    /// Its name (`room`, `hall`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Room => "room",
            Self::Hall => "hall",
        }
    }

    /// One line on what it draws.
    pub fn description(self) -> &'static str {
        match self {
            Self::Room => {
                "rooms 5-15 x 4-12 x 2.5-4 m, 1-3 APs on walls or ceiling, 0-2 boards, \
                 circles, eights, random flights and loops at 0.4-2.5 m/s, 30-600 s"
            }
            Self::Hall => {
                "halls 20-60 x 10-30 x 6-12 m with 1-3 rows of racks, 1-3 APs 3-10 m up, \
                 long loops and wide circles at 1-5 m/s, 30-600 s"
            }
        }
    }

    /// The family called `name`; the error lists the families.
    pub fn from_name(name: &str) -> Result<Self, FamilyError> {
        FAMILIES
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| FamilyError::Unknown {
                name: name.to_string(),
                known: FAMILIES.map(Self::name).join(", "),
            })
    }

    /// The flight of `seed`: its scenario (validated; its master seed is `seed` too) and its
    /// labels.
    pub fn draw(self, seed: u64) -> Result<Draw, FamilyError> {
        let scenario = match self {
            Self::Room => room::draw(seed),
            Self::Hall => hall::draw(seed),
        };
        Draw::checked(self, seed, scenario)
    }

    /// Shortest flight a duration override may ask of a draw that starts on the ground, s: its
    /// rest, take-off, landing and final rest, and the mission's two speed ramps.
    pub fn min_duration_s(self) -> f64 {
        let p = rig::phases();
        p.rest_s + p.takeoff_s + p.landing_s + p.final_rest_s + 2.0 * p.ramp_s
    }

    /// What identifies the family in a sweep's `plan.json` (as a scenario's TOML there): its
    /// name and [`GENERATOR_VERSION`].
    pub fn plan_toml(self) -> String {
        format!(
            "# flights drawn from a family, one per seed (wins simulate --family {name} --seed S)\n\
             family = \"{name}\"\ngenerator_version = {GENERATOR_VERSION}\n",
            name = self.name()
        )
    }
}

/// A drawn flight: the scenario to fly and its labels.
#[derive(Clone, Debug, PartialEq)]
pub struct Draw {
    /// The flight, validated.
    pub scenario: Scenario,
    /// What was drawn (as flown: after any override).
    pub flight: DrawnFlight,
}

impl Draw {
    fn checked(family: Family, seed: u64, scenario: Scenario) -> Result<Self, FamilyError> {
        scenario.validate().map_err(|source| FamilyError::Invalid {
            family: family.name(),
            seed,
            source,
        })?;
        let flight = DrawnFlight::of(family, seed, &scenario);
        Ok(Self { scenario, flight })
    }

    /// The same flight with another duration (s; `None`: its own) and, when `airborne`, started
    /// in the air ([`Scenario::airborne`]): validated again, the labels updated.
    pub fn with_overrides(
        self,
        duration_s: Option<f64>,
        airborne: bool,
    ) -> Result<Self, FamilyError> {
        let family = self.flight.family;
        let mut scenario = self.scenario;
        if let Some(d) = duration_s {
            scenario.duration_s = d;
        }
        if airborne {
            scenario = scenario.airborne();
        }
        Self::checked(family, self.flight.seed, scenario)
    }

    /// The scenario as TOML, every field spelt out, after a comment that says where it comes
    /// from and what was drawn: a file `wins simulate --scenario-file` flies again.
    pub fn scenario_toml(&self) -> Result<String, FamilyError> {
        scenario_toml(&self.scenario, &self.flight)
    }

    /// Writes [`SCENARIO_FILE`] and [`DRAWN_FILE`] into `dir` (which must exist); returns their
    /// paths.
    pub fn write_files(&self, dir: &Path) -> Result<Vec<PathBuf>, FamilyError> {
        let drawn = toml::to_string(&self.flight).map_err(ScenarioError::from)?;
        let files = [(SCENARIO_FILE, self.scenario_toml()?), (DRAWN_FILE, drawn)];
        let mut written = Vec::with_capacity(files.len());
        for (name, text) in files {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|source| FamilyError::Write {
                path: path.clone(),
                source,
            })?;
            written.push(path);
        }
        Ok(written)
    }
}

/// `scenario` as TOML, every field spelt out, after a comment that says it was drawn, from
/// which family and seed, and what was drawn (`flight`): a file `wins simulate --scenario-file`
/// flies again.
pub fn scenario_toml(scenario: &Scenario, flight: &DrawnFlight) -> Result<String, FamilyError> {
    let mut out = format!(
        "# A flight drawn from the flight family {:?} with seed {} (wins {}, generator version \
         {GENERATOR_VERSION}).\n# Drawn: {}.\n# Every field with its value, defaults included; \
         units are in the names.\n\n",
        flight.family.name(),
        flight.seed,
        env!("CARGO_PKG_VERSION"),
        flight.describe(),
    );
    out.push_str(&scenario.to_toml().map_err(ScenarioError::from)?);
    Ok(out)
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_flights;
