//! The one configuration tree: every stage's settings under one [`Config`], read from one TOML
//! file whose tables are the stages (`[aoa]`, `[pipeline]`, `[window]`, `[nonlinear]`, `[eval]`) and one key, `estimator`. Missing keys
//! take the defaults (shipped as `configs/default.toml`, equal to [`Config::default`]); an unknown
//! key, a value of the wrong kind or out of its range is refused, and every such problem is listed
//! at once. What describes the hardware is not here but in the dataset's rig
//! ([`crate::rig::Rig`]).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::chains::ChainOffsetsConfig;
use super::live_config::LiveConfig;
use crate::aoa::AoaConfig;
use crate::aoa::spotfi::MIN_GROUP_SIZE;
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

/// Settings of the pipeline between the AoA stage and the estimator: per-AP tracks (SpotFi start,
/// PAoA gates) and the bearings handed to the window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// Packets of an AP whose SpotFi direct path starts its track (paper: 10).
    pub init_packets: usize,
    /// Standard deviation given to every accepted bearing, degrees. PAoA's errors on the
    /// simulated multipath are heavy-tailed (median 1.7°, 90th percentile 5.5°): 2° made the
    /// window declare convergence too early and diverge; 3° does not.
    pub bearing_sigma_deg: f64,
    /// Frame grid, ms: bearings are grouped into frames this far apart (0: every packet is a
    /// frame). 20 ms keeps one AP's 50 packets/s one per frame.
    pub frame_period_ms: f64,
    /// Consecutive packets without a credible peak after which an AP's track starts over.
    pub max_misses: usize,
    /// After convergence, bearings further than this from the state's prediction are dropped,
    /// degrees.
    pub gate_deg: f64,
    /// After this many gated packets in a row of one AP the next is fed anyway (the state, not
    /// the AoA, is then the suspect).
    pub max_gated_in_row: usize,
    /// Packets further than this from the track's own prediction (the last track angle turned
    /// by the gyro) are dropped as jumps to another path, degrees.
    pub track_gate_deg: f64,
    /// After this many packets off the track in a row, the track starts over from SpotFi.
    pub max_off_track_in_row: usize,
    /// An AP silent for longer than this (an outage), s: its track starts over from SpotFi,
    /// and the state's gate is not applied to it until one of its bearings falls within the
    /// gate (the state was dead reckoned across the silence).
    pub max_silence_s: f64,
    /// How far the track follows each accepted angle (1: to the raw angle, the paper's
    /// Algorithm 1; smaller: a first-order filter against multipath jitter).
    pub track_gain: f64,
    /// Before convergence, how fast the track learns the rate of change of its angle not due
    /// to the turns: the share of the innovation the rate takes per second, 1/s (0: no rate, a
    /// first-order filter that trails a moving AP, the more the slower the packets come).
    pub track_rate_gain_hz: f64,
    /// Before convergence the state cannot tell front from back: assume front (the paper's
    /// set-up), flagged in the packet log. `false` drops bearings until convergence, which
    /// never comes with one AP.
    pub assume_front_until_converged: bool,
    /// Use the dataset's barometer (`baro.csv`) when it has one; `false` runs on the cone model
    /// alone (the barometer's samples are counted in the run's warnings).
    pub use_barometer: bool,
    /// The receive chains' offsets resolved from the flight ([`super::chains`]).
    pub chains: ChainOffsetsConfig,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            init_packets: 10,
            bearing_sigma_deg: 3.0,
            frame_period_ms: 20.0,
            max_misses: 25,
            gate_deg: 5.0,
            max_gated_in_row: 10,
            track_gate_deg: 10.0,
            max_off_track_in_row: 10,
            max_silence_s: 1.0,
            track_gain: 0.3,
            track_rate_gain_hz: 0.5,
            assume_front_until_converged: true,
            use_barometer: true,
            chains: ChainOffsetsConfig::default(),
        }
    }
}

impl PipelineConfig {
    /// Every setting in its range, under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.require(
            (MIN_GROUP_SIZE..=1000).contains(&self.init_packets),
            prefix,
            "init_packets",
            format!(
                "{} is not in [{MIN_GROUP_SIZE}, 1000] (SpotFi needs two packets)",
                self.init_packets
            ),
        );
        p.in_range(
            prefix,
            "bearing_sigma_deg",
            self.bearing_sigma_deg,
            0.01,
            90.0,
        );
        p.in_range(prefix, "frame_period_ms", self.frame_period_ms, 0.0, 1000.0);
        p.at_least(prefix, "max_misses", self.max_misses, 1);
        p.in_range(prefix, "gate_deg", self.gate_deg, 0.01, 180.0);
        p.in_range(prefix, "track_gate_deg", self.track_gate_deg, 0.01, 180.0);
        p.at_least(prefix, "max_off_track_in_row", self.max_off_track_in_row, 1);
        p.in_range(prefix, "max_silence_s", self.max_silence_s, 0.001, 1e9);
        p.require(
            self.track_gain > 0.0 && self.track_gain <= 1.0,
            prefix,
            "track_gain",
            format!("{} is not in (0, 1]", self.track_gain),
        );
        p.in_range(
            prefix,
            "track_rate_gain_hz",
            self.track_rate_gain_hz,
            0.0,
            20.0,
        );
        p.extend(self.chains.problems(&format!("{prefix}.chains")));
        p
    }
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
                problems.push("", "", e.to_string().trim().to_string());
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
mod tests {
    use super::*;

    #[test]
    fn the_shipped_live_example_is_valid_and_lists_every_live_setting() {
        let example = Config::from_toml_str(LIVE_EXAMPLE_TOML, "configs/live.toml")
            .expect("the shipped example is valid");
        let mut want = Config::default();
        want.live.rig = "my_rig".into();
        assert_eq!(example, want);
        let file: toml::Table = toml::from_str(LIVE_EXAMPLE_TOML).unwrap();
        let code = toml::Table::try_from(Config::default()).unwrap();
        let keys = |t: &toml::Table| -> Vec<String> {
            t.get("live")
                .and_then(toml::Value::as_table)
                .map(|l| l.keys().cloned().collect())
                .unwrap_or_default()
        };
        assert_eq!(
            keys(&file),
            keys(&code),
            "configs/live.toml lacks or adds keys"
        );
    }

    #[test]
    fn the_shipped_defaults_equal_the_code() {
        let shipped = Config::from_toml_str(DEFAULT_TOML, "configs/default.toml")
            .expect("the shipped defaults are valid");
        assert_eq!(shipped, Config::default());
        // Every key is written out, so the file documents the whole tree.
        let file: toml::Table = toml::from_str(DEFAULT_TOML).unwrap();
        let code = toml::Table::try_from(Config::default()).unwrap();
        assert_eq!(file, code, "configs/default.toml lacks or adds keys");
        assert_eq!(Config::default().validate().ok(), Some(()));
    }

    #[test]
    fn every_problem_is_listed_at_once() {
        let text = "[aoa]\npaoa_half_width_deg = 120.0\n[aoa.music]\naoa_step_deg = 1e-9\n\
                    [pipeline]\ngate_rad = 0.1\nmax_misses = \"many\"\n[window]\n\
                    max_frames = 0\nbody_from_array = 1\n[extra]\n";
        let Err(ConfigError::Invalid { problems, origin }) = Config::from_toml_str(text, "t.toml")
        else {
            panic!("accepted");
        };
        assert_eq!(origin, "t.toml");
        let keys: Vec<&str> = problems.0.iter().map(|p| p.key.as_str()).collect();
        for want in [
            "extra",
            "pipeline.gate_rad",
            "pipeline.max_misses",
            "window.body_from_array",
            "aoa.music.aoa_step_deg",
            "aoa.paoa_half_width_deg",
            "window.max_frames",
        ] {
            assert!(keys.contains(&want), "{want} missing from {keys:?}");
        }
        assert_eq!(keys.len(), 7, "{problems}");
        assert!(
            problems.to_string().contains("did you mean `gate_deg`"),
            "{problems}"
        );
    }

    #[test]
    fn the_estimator_is_chosen_by_name_and_an_unknown_one_is_refused() {
        use crate::fusion::choice::EstimatorKind;
        assert_eq!(Config::default().estimator, EstimatorKind::Nonlinear);
        let c = Config::from_toml_str("estimator = \"paper\"\n", "t").unwrap();
        assert_eq!(c.estimator, EstimatorKind::Paper);
        let c = Config::from_toml_str("estimator = \"nonlinear\"\n", "t").unwrap();
        assert_eq!(c.estimator, EstimatorKind::Nonlinear);
        assert!(Config::from_toml_str("estimator = \"kalman\"\n", "t").is_err());
        let Err(ConfigError::Invalid { problems, .. }) =
            Config::from_toml_str("[nonlinear]\nmax_keyframes = 1\n", "t")
        else {
            panic!("accepted");
        };
        assert_eq!(problems.0[0].key, "nonlinear.max_keyframes", "{problems}");
    }

    #[test]
    fn missing_keys_take_the_defaults_and_integers_pass_for_floats() {
        let c = Config::from_toml_str("[pipeline]\ngate_deg = 7\n", "t").unwrap();
        assert_eq!(c.pipeline.gate_deg, 7.0);
        assert_eq!(c.window, WindowConfig::default());
        assert!(matches!(
            Config::from_toml_str("[pipeline", "t"),
            Err(ConfigError::Syntax { .. })
        ));
        // A negative count has the right kind (integer) but not the right type.
        let Err(ConfigError::Invalid { problems, .. }) =
            Config::from_toml_str("[window]\nmax_frames = -3\n", "t")
        else {
            panic!("accepted");
        };
        assert_eq!(problems.0.len(), 1, "{problems}");
    }
}
