//! The settings tree: every stage's settings under one [`Config`], read from one TOML file whose
//! tables are the stages (`[aoa]`, `[pipeline]`, `[window]`, `[nonlinear]`, `[imu_gap]`,
//! `[live]`, `[eval]`) and one key, `estimator`; loading, validation ([`Config::problems`],
//! [`Config::validate`]) and [`ConfigError`]. Missing keys take the defaults (shipped as
//! `configs/default.toml`, equal to [`Config::default`]); an unknown key, a value of the wrong
//! kind or out of its range is refused, and every such problem is listed at once. What describes
//! the hardware is not here but in the dataset's rig ([`crate::rig::Rig`]).
//!
//! A stage below this module keeps its own section's type (`[aoa]` in [`crate::aoa`],
//! `[window]` and `[nonlinear]` in [`crate::fusion`], `[imu_gap]` in [`crate::imu`], `[eval]` in
//! [`crate::eval`]) and the tree imports it. The sections of the stages above it, which are built
//! from the whole tree, are here: `[pipeline]` ([`pipeline`]) and `[live]` ([`live`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

pub mod live;
pub mod pipeline;

pub use self::live::{ApBy, LiveConfig, PoseMessage};
pub use self::pipeline::{ChainOffsetsConfig, PipelineConfig};
use crate::aoa::AoaConfig;
use crate::check::{Problems, overlay};
use crate::eval::EvalOptions;
use crate::fusion::choice::EstimatorKind;
use crate::fusion::nonlinear::NonlinearConfig;
use crate::fusion::paper::window::WindowConfig;
use crate::imu::ImuGap;

/// Every setting of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// The estimator: `"nonlinear"` (the 6-DoF sliding window, default) or `"paper"` (the
    /// paper's linear window, for comparison).
    pub estimator: EstimatorKind,
    /// The AoA stage: MUSIC grid, PAoA half-width, SpotFi clustering.
    pub aoa: AoaConfig,
    /// Per-AP tracking and the bearings' path into the estimator.
    pub pipeline: PipelineConfig,
    /// The paper's linear sliding window (also the nonlinear estimator's start).
    pub window: WindowConfig,
    /// The nonlinear sliding window.
    pub nonlinear: NonlinearConfig,
    /// How both estimators integrate across a gap in the IMU stream.
    pub imu_gap: ImuGap,
    /// `wins live`: the links to the NIC and the flight controller.
    pub live: LiveConfig,
    /// Scoring against a truth (association, RPE).
    pub eval: EvalOptions,
}

/// Why a configuration cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not TOML.
    #[error("{origin}: not TOML: {reason}")]
    Syntax {
        /// The file (or `<string>`).
        origin: String,
        /// The parser's message.
        reason: String,
    },
    /// Keys or values that cannot be used, every one.
    #[error("{origin}: {} problem(s):\n{problems}", problems.0.len())]
    Invalid {
        /// The file (or `<string>`).
        origin: String,
        /// Each problem under its key.
        problems: Problems,
    },
}

impl Config {
    /// Every problem of every stage, each under its dotted key.
    pub fn problems(&self) -> Problems {
        let mut p = self.aoa.problems("aoa");
        p.extend(self.pipeline.problems("pipeline"));
        p.extend(self.window.problems("window"));
        p.extend(self.nonlinear.problems("nonlinear"));
        p.extend(self.imu_gap.problems("imu_gap"));
        p.extend(self.live.problems("live"));
        p.extend(self.eval.problems("eval"));
        p
    }

    /// `Ok` when every setting is usable; else every problem at once.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.problems()
            .into_result()
            .map_err(|problems| ConfigError::Invalid {
                origin: "configuration".into(),
                problems,
            })
    }

    /// Reads a configuration from TOML text: missing keys take the defaults; unknown keys, wrong
    /// kinds and out-of-range values are all listed in one [`ConfigError::Invalid`]. `origin`
    /// names the text in messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let syntax = |reason: String| ConfigError::Syntax {
            origin: origin.into(),
            reason,
        };
        let user: toml::Table = toml::from_str(text).map_err(|e| syntax(e.to_string()))?;
        let defaults =
            toml::Table::try_from(Config::default()).map_err(|e| syntax(e.to_string()))?;
        let mut problems = Problems::new();
        let merged = overlay(&defaults, &user, "", &mut problems);
        // Every key has a default of the same kind now, so this fails only on a value that
        // fits its kind but not its type (a negative count).
        let config = match toml::Value::Table(merged).try_into::<Config>() {
            Ok(c) => c,
            Err(e) => {
                let (key, message) = crate::check::located(&e.to_string());
                problems.push("", &key, message);
                Config::default()
            }
        };
        problems.extend(config.problems());
        problems
            .into_result()
            .map(|()| config)
            .map_err(|problems| ConfigError::Invalid {
                origin: origin.into(),
                problems,
            })
    }

    /// Reads a configuration file ([`Config::from_toml_str`]).
    pub fn from_toml_file(path: &Path) -> Result<Self, ConfigError> {
        let text = crate::io_safety::read_text(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }
}

/// The shipped example of `wins live`'s settings, `configs/live.toml`, as text.
pub const LIVE_EXAMPLE_TOML: &str = include_str!("../../../../configs/live.toml");

/// The shipped defaults, `configs/default.toml`, as text.
pub const DEFAULT_TOML: &str = include_str!("../../../../configs/default.toml");

#[cfg(test)]
mod tests;
