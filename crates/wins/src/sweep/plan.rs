//! What a sweep runs: scenarios (built-in names or scenario files) and flight families × seeds,
//! an optional flight duration, the pipeline's settings; the runs in their canonical order, the
//! shard that keeps a part of them, what each run flies, and the record of it all written as
//! `plan.json`.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::Deserialize;

use super::SweepError;
use super::record::{PLAN_FORMAT, PLAN_VERSION, PlanRecord, PlanScenario};
pub use super::shard::Shard;
use crate::Config;
use crate::csi::format::CaptureFormat;
use crate::sim::Scenario;
use crate::sim::family::Family;
pub use family::RunFlight;

mod family;

/// At most this many runs in one sweep (scenarios × seeds).
pub const MAX_RUNS: usize = 1_000_000;
/// `source` of a built-in scenario in `plan.json`.
pub const BUILT_IN_SOURCE: &str = "built-in";
/// `source` of a flight family in `plan.json`.
pub const FAMILY_SOURCE: &str = "family";

/// Distinct seeds in increasing order (the order of the runs of each scenario).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Seeds(Vec<u64>);

impl Seeds {
    /// Parses `1..20` (inclusive: 20 seeds; `1..=20` is the same), `3` or a comma-separated list
    /// of both (`1..5,9,12..14`). A seed given twice is an error, not a repeated run.
    pub fn parse(text: &str) -> Result<Self, SweepError> {
        let fail = |reason: String| SweepError::Seeds {
            text: text.to_string(),
            reason,
        };
        let number = |s: &str| {
            s.trim().parse::<u64>().map_err(|e| {
                fail(format!(
                    "{:?} is not a seed (0 ..= 2^64 − 1): {e}",
                    s.trim()
                ))
            })
        };
        let mut seeds = Vec::new();
        for item in text.split(',') {
            let item = item.trim();
            if item.is_empty() {
                return Err(fail(
                    "an empty item (two commas, or a comma at an end)".into(),
                ));
            }
            match item.split_once("..") {
                Some((a, b)) => {
                    let (a, b) = (number(a)?, number(b.strip_prefix('=').unwrap_or(b))?);
                    if a > b {
                        return Err(fail(format!("range {item} runs backwards")));
                    }
                    if b - a >= MAX_RUNS as u64 || seeds.len() + (b - a) as usize >= MAX_RUNS {
                        return Err(fail(format!("more than {MAX_RUNS} seeds")));
                    }
                    seeds.extend(a..=b);
                }
                None => seeds.push(number(item)?),
            }
        }
        Self::from_list(seeds).map_err(|e| match e {
            SweepError::Seeds { reason, .. } => fail(reason),
            other => other,
        })
    }

    /// Seeds given one by one (a plan file's array); sorted, each at most once.
    pub fn from_list(mut seeds: Vec<u64>) -> Result<Self, SweepError> {
        if seeds.is_empty() {
            return Err(SweepError::NoSeeds);
        }
        seeds.sort_unstable();
        if let Some(w) = seeds.windows(2).find(|w| w[0] == w[1]) {
            return Err(SweepError::Seeds {
                text: format!("{seeds:?}"),
                reason: format!("seed {} is given twice", w[0]),
            });
        }
        Ok(Self(seeds))
    }

    /// The seeds, increasing.
    pub fn as_slice(&self) -> &[u64] {
        &self.0
    }
}

impl FromStr for Seeds {
    type Err = SweepError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

/// One scenario (or flight family) of a plan, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepScenario {
    /// Its name in `runs.csv` and `summary.json`: a built-in scenario's name, a file's name
    /// without `.toml`, or a family's name.
    pub label: String,
    /// [`BUILT_IN_SOURCE`], the file as given, or [`FAMILY_SOURCE`].
    pub source: String,
    /// The scenario as parsed (its own seed and duration; the sweep sets both per run); for a
    /// family, the flight of the plan's first seed (each run draws its own).
    pub scenario: Scenario,
    /// The family each run's flight is drawn from (`None`: a scenario, flown with each seed).
    pub family: Option<Family>,
}

impl SweepScenario {
    /// Resolves `name` as `wins simulate` does: a built-in scenario's name
    /// ([`Scenario::built_in`]), or a scenario file ([`Scenario::from_toml`] of its text, with
    /// the path as origin). An argument ending in `.toml` or holding a path separator is a file
    /// (relative to `base` when given); anything else is a built-in name.
    pub fn resolve(name: &str, base: Option<&Path>) -> Result<Self, SweepError> {
        let is_file = name.ends_with(".toml") || name.contains('/') || name.contains('\\');
        if !is_file {
            return Ok(Self {
                label: name.to_string(),
                source: BUILT_IN_SOURCE.to_string(),
                scenario: Scenario::built_in(name)?,
                family: None,
            });
        }
        let path = match base {
            Some(dir) if Path::new(name).is_relative() => dir.join(name),
            _ => PathBuf::from(name),
        };
        let scenario = Scenario::from_file(&path)?;
        let label = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty())
            .unwrap_or_else(|| scenario.name.clone());
        Ok(Self {
            label,
            source: path.display().to_string(),
            scenario,
            family: None,
        })
    }

    /// The scenario of run `seed`: its seed set, and the plan's duration when it has one.
    pub fn for_run(&self, seed: u64, duration_s: Option<f64>) -> Scenario {
        let mut s = self.scenario.clone();
        s.seed = seed;
        if let Some(d) = duration_s {
            s.duration_s = d;
        }
        s
    }
}

/// One run of a plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunId {
    /// Canonical index: scenario-major, then seed (`scenario · seeds + seed's position`).
    pub index: usize,
    /// Index of the scenario in [`Plan::scenarios`].
    pub scenario: usize,
    /// The seed.
    pub seed: u64,
}

/// What a plan file holds (TOML): paths in it are relative to the file.
///
/// ```toml
/// scenarios = ["paper-circle", "paper-circle-3ap", "my-flights/warehouse.toml"]
/// families = ["room"]          # optional: flights drawn from families, one per seed
/// seeds = "1..20"              # or a list: [1, 2, 3]
/// duration_s = 90.0            # optional: each scenario's own otherwise
/// config = "pipeline.toml"     # optional: the defaults otherwise
/// airborne = true              # optional: drop every scenario's [phases] (start in the air)
/// card = "atheros"             # optional: the rig's card (each scenario's own otherwise)
/// ```
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanSpec {
    /// Built-in names or scenario files.
    #[serde(default)]
    pub scenarios: Vec<String>,
    /// Flight families ([`crate::sim::family`]).
    #[serde(default)]
    pub families: Vec<String>,
    /// A range or list as text (`"1..20"`), or an array of seeds.
    pub seeds: SeedsSpec,
    /// Flight duration for every scenario, s.
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// The pipeline's settings file.
    #[serde(default)]
    pub config: Option<PathBuf>,
    /// Fly every scenario airborne from t = 0 ([`Scenario::airborne`]).
    #[serde(default)]
    pub airborne: bool,
    /// Fly every scenario with this card ([`Scenario::with_card`]).
    #[serde(default)]
    pub card: Option<CaptureFormat>,
}

/// Seeds in a plan file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum SeedsSpec {
    /// `"1..20"`, `"1,4,9"`: as `--seeds`.
    Text(String),
    /// `[1, 4, 9]`.
    List(Vec<u64>),
}

/// A resolved sweep: what to run, checked before any run starts.
#[derive(Clone, Debug)]
pub struct Plan {
    /// In the order given, the scenarios then the families: the canonical order of the runs.
    pub scenarios: Vec<SweepScenario>,
    /// Every scenario is flown with each of these.
    pub seeds: Seeds,
    /// Flight duration for every scenario, s (`None`: each scenario's own).
    pub duration_s: Option<f64>,
    /// The pipeline's settings, as `wins run --config` takes them.
    pub config: Config,
    /// The settings file, as given (`None`: the defaults).
    pub config_source: Option<String>,
    /// Whether every scenario's phases were dropped ([`Scenario::airborne`]).
    pub airborne: bool,
    /// The card every scenario is flown with (`None`: each scenario's own).
    pub card: Option<CaptureFormat>,
}

impl Plan {
    /// Resolves `scenarios` (each as [`SweepScenario::resolve`], relative to `base`; airborne
    /// from t = 0 when `airborne`) and `families` ([`SweepScenario::from_family`]), checks the
    /// duration against every scenario and the settings, and counts the runs.
    pub fn new(
        scenarios: &[String],
        families: &[String],
        seeds: Seeds,
        duration_s: Option<f64>,
        config_path: Option<&Path>,
        base: Option<&Path>,
        airborne: bool,
    ) -> Result<Self, SweepError> {
        if scenarios.is_empty() && families.is_empty() {
            return Err(SweepError::NoScenarios);
        }
        let mut resolved: Vec<SweepScenario> = Vec::with_capacity(scenarios.len() + families.len());
        for name in scenarios {
            let mut s = SweepScenario::resolve(name.trim(), base)?;
            if airborne {
                s.scenario = s.scenario.airborne();
            }
            if resolved.iter().any(|r| r.label == s.label) {
                return Err(SweepError::DuplicateScenario { label: s.label });
            }
            if let Some(d) = duration_s {
                let invalid = |reason: String| SweepError::Duration {
                    label: s.label.clone(),
                    duration_s: d,
                    source: crate::sim::ConfigError::new("duration_s", reason),
                };
                if !(d.is_finite() && d > 0.0) {
                    return Err(invalid(format!(
                        "must be a positive number of seconds, got {d}"
                    )));
                }
                s.for_run(s.scenario.seed, Some(d))
                    .validate()
                    .map_err(|source| SweepError::Duration {
                        label: s.label.clone(),
                        duration_s: d,
                        source,
                    })?;
            }
            resolved.push(s);
        }
        let first_seed = seeds.as_slice().first().copied().unwrap_or_default();
        for name in families {
            let s = SweepScenario::from_family(name.trim(), first_seed, duration_s, airborne)?;
            if resolved.iter().any(|r| r.label == s.label) {
                return Err(SweepError::DuplicateScenario { label: s.label });
            }
            resolved.push(s);
        }
        let runs = resolved.len() as u128 * seeds.as_slice().len() as u128;
        if runs > MAX_RUNS as u128 {
            return Err(SweepError::TooManyRuns {
                runs,
                max: MAX_RUNS,
            });
        }
        let (config, config_source) = match config_path {
            Some(p) => {
                let path = match base {
                    Some(dir) if p.is_relative() => dir.join(p),
                    _ => p.to_path_buf(),
                };
                (
                    Config::from_toml_file(&path)?,
                    Some(path.display().to_string()),
                )
            }
            None => (Config::default(), None),
        };
        config.validate()?;
        Ok(Self {
            scenarios: resolved,
            seeds,
            duration_s,
            config,
            config_source,
            airborne,
            card: None,
        })
    }

    /// The same plan with every run received by `card` (`None`: each scenario's own), checked
    /// on every scenario's first flight.
    pub fn with_card(mut self, card: Option<CaptureFormat>) -> Result<Self, SweepError> {
        self.card = card;
        if let (Some(card), Some(&seed)) = (card, self.seeds.as_slice().first()) {
            for (scenario, s) in self.scenarios.iter().enumerate() {
                let run = RunId {
                    index: 0,
                    scenario,
                    seed,
                };
                self.flight(run)?
                    .scenario
                    .validate()
                    .map_err(|source| SweepError::Card {
                        label: s.label.clone(),
                        card,
                        source,
                    })?;
            }
        }
        Ok(self)
    }

    /// What `run` flies: its scenario's flight for its seed with the plan's duration, start and
    /// card ([`SweepScenario::flight`]).
    pub fn flight(&self, run: RunId) -> Result<RunFlight, SweepError> {
        let s = self
            .scenarios
            .get(run.scenario)
            .ok_or(SweepError::NoScenarios)?;
        let mut f = s.flight(run.seed, self.duration_s, self.airborne)?;
        if let Some(card) = self.card {
            f.scenario = f.scenario.with_card(card);
        }
        Ok(f)
    }

    /// Reads a plan file ([`PlanSpec`]); its paths are relative to the file's directory.
    pub fn from_file(path: &Path) -> Result<Self, SweepError> {
        let text = std::fs::read_to_string(path).map_err(|source| SweepError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let spec: PlanSpec = toml::from_str(&text).map_err(|e| SweepError::PlanFile {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        let seeds = match spec.seeds {
            SeedsSpec::Text(t) => Seeds::parse(&t)?,
            SeedsSpec::List(v) => Seeds::from_list(v)?,
        };
        let base = path.parent().filter(|p| !p.as_os_str().is_empty());
        Self::new(
            &spec.scenarios,
            &spec.families,
            seeds,
            spec.duration_s,
            spec.config.as_deref(),
            base,
            spec.airborne,
        )?
        .with_card(spec.card)
    }

    /// Every run, in canonical order: scenario-major (in the order given), then seed
    /// (increasing).
    pub fn runs(&self) -> Vec<RunId> {
        let seeds = self.seeds.as_slice();
        (0..self.scenarios.len())
            .flat_map(|scenario| {
                seeds.iter().enumerate().map(move |(j, &seed)| RunId {
                    index: scenario * seeds.len() + j,
                    scenario,
                    seed,
                })
            })
            .collect()
    }

    /// The runs `shard` keeps (every run without one), in canonical order.
    pub fn runs_of(&self, shard: Option<Shard>) -> Vec<RunId> {
        self.runs()
            .into_iter()
            .filter(|r| shard.is_none_or(|s| s.keeps(r.index)))
            .collect()
    }

    /// The record of this plan (`plan.json`), for `shard`.
    pub fn record(&self, shard: Option<Shard>) -> Result<PlanRecord, SweepError> {
        let mut scenarios = Vec::with_capacity(self.scenarios.len());
        for s in &self.scenarios {
            let toml = match s.family {
                Some(family) => family.plan_toml(),
                None => s
                    .scenario
                    .to_toml()
                    .map_err(crate::sim::scenario::ScenarioError::from)?,
            };
            scenarios.push(PlanScenario {
                label: s.label.clone(),
                source: s.source.clone(),
                toml,
            });
        }
        let config_toml = toml::to_string(&self.config).map_err(|e| SweepError::Malformed {
            path: PathBuf::from("<settings>"),
            reason: format!("cannot write the settings as TOML: {e}"),
        })?;
        let mut record = PlanRecord {
            format: PLAN_FORMAT.to_string(),
            version: PLAN_VERSION,
            wins_version: env!("CARGO_PKG_VERSION").to_string(),
            plan_id: String::new(),
            scenarios,
            seeds: self.seeds.as_slice().to_vec(),
            duration_s: self.duration_s,
            config_toml,
            config_source: self.config_source.clone(),
            runs: self.scenarios.len() * self.seeds.as_slice().len(),
            shard,
        };
        record.plan_id = record.identity_hash();
        Ok(record)
    }
}

#[cfg(test)]
pub(crate) mod tests;
