//! Joining the directories of a sharded sweep into the outputs of one unsharded sweep of the
//! same plan: the same `runs.csv` (but `wall_s`) and a byte-identical `summary.json`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::record::PlanRecord;
use super::summary::{SweepSummary, summarize};
use super::table::{RunRow, merge_columns, read_runs_csv};
use super::{PLAN_FILE, RUNS_FILE, SCENARIOS_DIR, SweepError};

/// At most this many runs are named in a message; the rest are counted.
const MAX_NAMED: usize = 10;

/// Shards joined.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The plan, with no shard.
    pub record: PlanRecord,
    /// The metric columns of `runs.csv`.
    pub columns: Vec<String>,
    /// Every run of the plan, in canonical order.
    pub rows: Vec<RunRow>,
    /// The statistics.
    pub summary: SweepSummary,
}

/// Reads `plan.json` in `dir`.
pub fn read_plan(dir: &Path) -> Result<PlanRecord, SweepError> {
    let path = dir.join(PLAN_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| SweepError::Read {
        path: path.clone(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| SweepError::Malformed {
        path,
        reason: e.to_string(),
    })
}

impl Merged {
    /// Writes the merged sweep's outputs into `out` ([`super::write_outputs`]); returns the files
    /// written.
    pub fn write(&self, out: &Path) -> Result<Vec<PathBuf>, SweepError> {
        super::write_outputs(out, &self.record, &self.columns, &self.rows, &self.summary)
    }
}

/// Joins the sweeps in `dirs` (each with `plan.json` and `runs.csv`). Refuses directories of
/// different plans (saying what differs), a run found twice (and where), a run not in the
/// plan, and runs of the plan found nowhere (which, and which shards would have run them).
pub fn merge_dirs(dirs: &[PathBuf]) -> Result<Merged, SweepError> {
    let Some(first_dir) = dirs.first() else {
        return Err(SweepError::Merge(
            "no directories to merge: give each shard's output directory".into(),
        ));
    };
    let first = read_plan(first_dir)?;
    let mut headers = Vec::with_capacity(dirs.len());
    // Canonical index -> (row, directory it came from).
    let mut found: BTreeMap<usize, (RunRow, &Path)> = BTreeMap::new();
    let mut duplicates = Vec::new();
    let mut shards = Vec::new();
    for dir in dirs {
        let record = read_plan(dir)?;
        let differ = first.differences(&record);
        if !differ.is_empty() {
            return Err(SweepError::Merge(format!(
                "{} and {} hold different plans: {}",
                first_dir.display(),
                dir.display(),
                differ.join("; ")
            )));
        }
        shards.push(record.shard);
        let (columns, rows) = read_runs_csv(&dir.join(RUNS_FILE))?;
        headers.push(columns);
        for row in rows {
            let Some(index) = first.run_index(&row.scenario, row.seed) else {
                return Err(SweepError::Merge(format!(
                    "{}: run {} seed {} is not in the plan",
                    dir.join(RUNS_FILE).display(),
                    row.scenario,
                    row.seed
                )));
            };
            if let Some((_, other)) = found.get(&index) {
                duplicates.push(format!(
                    "{} seed {} (in {} and {})",
                    row.scenario,
                    row.seed,
                    other.display(),
                    dir.display()
                ));
            } else {
                found.insert(index, (row, dir));
            }
        }
    }
    if !duplicates.is_empty() {
        return Err(SweepError::Merge(format!(
            "{} runs found twice: {}",
            duplicates.len(),
            named(&duplicates)
        )));
    }
    let missing: Vec<usize> = (0..first.runs).filter(|i| !found.contains_key(i)).collect();
    if !missing.is_empty() {
        let names: Vec<String> = missing
            .iter()
            .map(|&i| {
                let seeds = first.seeds.len().max(1);
                let label = first.label(i / seeds).unwrap_or("?");
                let seed = first.seeds.get(i % seeds).copied().unwrap_or_default();
                format!("{label} seed {seed}")
            })
            .collect();
        return Err(SweepError::Merge(format!(
            "{} of the plan's {} runs are missing: {}{}",
            missing.len(),
            first.runs,
            named(&names),
            missing_shards(&shards, &missing)
        )));
    }
    let rows: Vec<RunRow> = found.into_values().map(|(r, _)| r).collect();
    let columns = merge_columns(headers.iter().map(Vec::as_slice));
    let labels: Vec<String> = first.scenarios.iter().map(|s| s.label.clone()).collect();
    let summary = summarize(&first.plan_id, &first.wins_version, &labels, &rows);
    let record = PlanRecord {
        shard: None,
        ..first
    };
    Ok(Merged {
        record,
        columns,
        rows,
        summary,
    })
}

/// Copies the scenarios of the flight families' runs (`scenarios/*.toml`) of the sweeps in
/// `dirs` into `out/scenarios/`, in name order; returns the files written (none when no sweep
/// flew a family).
pub fn copy_scenario_files(dirs: &[PathBuf], out: &Path) -> Result<Vec<PathBuf>, SweepError> {
    let mut sources: Vec<PathBuf> = Vec::new();
    for dir in dirs {
        let from = dir.join(SCENARIOS_DIR);
        if !from.is_dir() {
            continue;
        }
        let entries = std::fs::read_dir(&from).map_err(|source| SweepError::Read {
            path: from.clone(),
            source,
        })?;
        for entry in entries {
            let path = entry
                .map_err(|source| SweepError::Read {
                    path: from.clone(),
                    source,
                })?
                .path();
            if path.extension().is_some_and(|e| e == "toml") {
                sources.push(path);
            }
        }
    }
    sources.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    let to = out.join(SCENARIOS_DIR);
    if !sources.is_empty() {
        std::fs::create_dir_all(&to).map_err(|source| SweepError::Write {
            path: to.clone(),
            source,
        })?;
    }
    let mut written = Vec::with_capacity(sources.len());
    for from in sources {
        let Some(name) = from.file_name() else {
            continue;
        };
        let path = to.join(name);
        std::fs::copy(&from, &path).map_err(|source| SweepError::Write {
            path: path.clone(),
            source,
        })?;
        written.push(path);
    }
    Ok(written)
}

/// The first [`MAX_NAMED`] items, comma-separated, and how many more.
fn named(items: &[String]) -> String {
    let mut s = items
        .iter()
        .take(MAX_NAMED)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if items.len() > MAX_NAMED {
        s.push_str(&format!(" and {} more", items.len() - MAX_NAMED));
    }
    s
}

/// When every directory is a shard of the same count N: the shards the missing runs belong to.
fn missing_shards(shards: &[Option<super::Shard>], missing: &[usize]) -> String {
    let Some(Some(first)) = shards.first() else {
        return String::new();
    };
    if shards
        .iter()
        .any(|s| s.is_none_or(|s| s.count != first.count))
    {
        return String::new();
    }
    let n = first.count;
    let given: Vec<usize> = shards.iter().flatten().map(|s| s.index).collect();
    let mut ks: Vec<usize> = missing
        .iter()
        .map(|i| i % n + 1)
        .filter(|k| !given.contains(k))
        .collect();
    ks.sort_unstable();
    ks.dedup();
    if ks.is_empty() {
        return String::new();
    }
    let list: Vec<String> = ks.iter().map(|k| format!("{k}/{n}")).collect();
    format!(" (shards not given: {})", list.join(", "))
}

#[cfg(test)]
mod tests;
