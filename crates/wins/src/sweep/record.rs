//! `plan.json`: the record of what a sweep ran (scenarios with their full TOML, seeds,
//! duration, every pipeline setting, the library's version, the shard), and the plan's
//! identity, so that shards of one plan, and only those, are merged.

use serde::{Deserialize, Serialize};

use super::shard::Shard;

/// `format` of `plan.json`.
pub const PLAN_FORMAT: &str = "wins-sweep-plan";
/// `version` of `plan.json`'s layout.
pub const PLAN_VERSION: u32 = 1;

/// One scenario in `plan.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanScenario {
    /// Its name in `runs.csv`.
    pub label: String,
    /// [`BUILT_IN_SOURCE`](super::plan::BUILT_IN_SOURCE) or the file as given (not part of
    /// the plan's identity).
    pub source: String,
    /// The scenario as parsed, every field spelt out
    /// ([`Scenario::to_toml`](crate::sim::Scenario::to_toml)): a file that `wins simulate
    /// --scenario-file` runs. Its seed and duration are replaced per run.
    pub toml: String,
}

/// `plan.json`: what a sweep ran, so that shards of one plan, and only those, can be merged.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanRecord {
    /// [`PLAN_FORMAT`].
    pub format: String,
    /// [`PLAN_VERSION`].
    pub version: u32,
    /// The version of the `wins` library that ran it.
    pub wins_version: String,
    /// 16 hex digits: FNV-1a (64 bit) of the plan's identity, i.e. every field below except
    /// the sources and the shard, with the format, version and wins version.
    pub plan_id: String,
    /// In canonical order.
    pub scenarios: Vec<PlanScenario>,
    /// Increasing.
    pub seeds: Vec<u64>,
    /// Flight duration for every scenario, s (null: each scenario's own).
    pub duration_s: Option<f64>,
    /// The pipeline's settings, every value spelt out (TOML).
    pub config_toml: String,
    /// The settings file as given (null: the defaults); not part of the identity.
    pub config_source: Option<String>,
    /// Runs in the whole plan (all shards).
    pub runs: usize,
    /// The shard this directory holds (null: all runs).
    pub shard: Option<Shard>,
}

/// The fields of a [`PlanRecord`] that make a plan what it is.
#[derive(Serialize)]
struct Identity<'a> {
    format: &'a str,
    version: u32,
    wins_version: &'a str,
    scenarios: Vec<(&'a str, &'a str)>,
    seeds: &'a [u64],
    duration_s: Option<f64>,
    config_toml: &'a str,
}

impl PlanRecord {
    fn identity(&self) -> Identity<'_> {
        Identity {
            format: &self.format,
            version: self.version,
            wins_version: &self.wins_version,
            scenarios: self
                .scenarios
                .iter()
                .map(|s| (s.label.as_str(), s.toml.as_str()))
                .collect(),
            seeds: &self.seeds,
            duration_s: self.duration_s,
            config_toml: &self.config_toml,
        }
    }

    pub(crate) fn identity_hash(&self) -> String {
        // Serializing plain strings, integers and floats cannot fail.
        let text = serde_json::to_string(&self.identity()).unwrap_or_default();
        format!("{:016x}", fnv1a64(text.as_bytes()))
    }

    /// What makes `other` another plan than this one, in words (empty: the same plan). The
    /// sources and the shard do not count.
    pub fn differences(&self, other: &Self) -> Vec<String> {
        let mut d = Vec::new();
        let (a, b) = (self.identity(), other.identity());
        if (a.format, a.version) != (b.format, b.version) {
            d.push(format!(
                "layout {} v{} vs {} v{}",
                a.format, a.version, b.format, b.version
            ));
        }
        if a.wins_version != b.wins_version {
            d.push(format!(
                "wins version {} vs {}",
                a.wins_version, b.wins_version
            ));
        }
        fn labels<'a>(i: &Identity<'a>) -> Vec<&'a str> {
            i.scenarios.iter().map(|s| s.0).collect()
        }
        if labels(&a) != labels(&b) {
            d.push(format!("scenarios {:?} vs {:?}", labels(&a), labels(&b)));
        } else {
            for ((label, x), (_, y)) in a.scenarios.iter().zip(&b.scenarios) {
                if x != y {
                    d.push(format!("scenario {label:?} has different contents"));
                }
            }
        }
        if a.seeds != b.seeds {
            d.push(format!(
                "seeds {} vs {}",
                describe_seeds(a.seeds),
                describe_seeds(b.seeds)
            ));
        }
        if a.duration_s != b.duration_s {
            d.push(format!(
                "duration_s {:?} vs {:?}",
                a.duration_s, b.duration_s
            ));
        }
        if a.config_toml != b.config_toml {
            d.push("the pipeline settings differ".to_string());
        }
        if d.is_empty() && self.plan_id != other.plan_id {
            d.push(format!("plan_id {} vs {}", self.plan_id, other.plan_id));
        }
        d
    }

    /// Label of scenario `index`, if there is one.
    pub fn label(&self, index: usize) -> Option<&str> {
        self.scenarios.get(index).map(|s| s.label.as_str())
    }

    /// Canonical index of the run of scenario `label` with `seed`, if the plan has it.
    pub fn run_index(&self, label: &str, seed: u64) -> Option<usize> {
        let s = self.scenarios.iter().position(|s| s.label == label)?;
        let j = self.seeds.binary_search(&seed).ok()?;
        Some(s * self.seeds.len() + j)
    }
}

/// `1..20` for a contiguous list, else the count with its ends.
fn describe_seeds(seeds: &[u64]) -> String {
    match (seeds.first(), seeds.last()) {
        (Some(&a), Some(&b)) if (b - a) as usize + 1 == seeds.len() => format!("{a}..{b}"),
        (Some(a), Some(b)) => format!("{} seeds from {a} to {b}", seeds.len()),
        _ => "none".to_string(),
    }
}

/// FNV-1a, 64 bit.
fn fnv1a64(bytes: &[u8]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    bytes
        .iter()
        .fold(OFFSET, |h, &b| (h ^ u64::from(b)).wrapping_mul(PRIME))
}

#[cfg(test)]
mod tests;
