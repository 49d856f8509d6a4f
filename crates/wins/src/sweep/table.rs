//! `runs.csv`: one row per run, the run's [`Metrics`] flattened generically into columns.
//!
//! Flattening: the metrics are serialized as `metrics.json` is, then every leaf becomes a
//! column named by its path, `.`-joined (as `pandas.json_normalize` names them): an array
//! element `position_error_std_xyz_m.0`, a map entry `ap_position_error_m.ap0`, a nested field
//! `alignment.rotation_xyzw.3`. A new field of [`Metrics`] is a new column with no change
//! here. Numbers are written as `serde_json` writes them (the shortest text that reads back to
//! the same `f64`, bit for bit), null as an empty cell. Metrics measured on the wall clock
//! ([`WALL_CLOCK_METRICS`]) are left out: the row would change from one sweep to the next.
//!
//! A run of a flight family also has the labels of its drawn flight
//! ([`crate::sim::family::DrawnFlight::labels`]), each a column `drawn.<label>` between the
//! leading columns and the metrics; a sweep with no family has no such column.

mod flatten;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use nalgebra::{UnitQuaternion, Vector3};

use super::SweepError;
use crate::dataset::truth::{ApRow, Pose};
use crate::eval::{EstimatedAp, EvalOptions, Metrics, evaluate};
use crate::time::Timestamp;
pub use flatten::{flatten, number_cell};

/// Metrics left out of `runs.csv` because they depend on the machine's speed, not on the run
/// (flight time over wall time); `wall_s` carries the timing.
pub const WALL_CLOCK_METRICS: &[&str] = &["realtime_factor"];

/// Columns before the metrics.
pub const LEADING_COLUMNS: [&str; 5] = [
    "scenario",
    "seed",
    "converged",
    "restarts",
    "rejected_convergences",
];
/// Prefix of the columns of a family's drawn labels.
pub const LABEL_PREFIX: &str = "drawn.";
/// Columns after the metrics.
pub const TRAILING_COLUMNS: [&str; 5] = [
    "ap_position_error_max_m",
    "max_error_after_convergence_m",
    "pose_coverage",
    "wall_s",
    "error",
];

/// One run: a row of `runs.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct RunRow {
    /// The scenario's label.
    pub scenario: String,
    /// The seed.
    pub seed: u64,
    /// For a flight family's run, the drawn flight's labels, `(label, value)` in the record's
    /// order ([`crate::sim::family::DrawnFlight::labels`]); empty for a scenario's run.
    pub labels: Vec<(String, String)>,
    /// Whether the estimator converged (the pipeline reported a convergence, or wrote
    /// converged poses); false for a run that failed before.
    pub converged: bool,
    /// Times the converged estimate was lost and the window started over (`EstimatorStats`); `None`
    /// when the pipeline did not run.
    pub restarts: Option<u64>,
    /// Candidate convergences rejected as implausible (`EstimatorStats`); `None` when the pipeline
    /// did not run.
    pub rejected_convergences: Option<u64>,
    /// The flattened metrics, `(column, cell)` in serialization order; empty when the run
    /// could not be scored.
    pub metrics: Vec<(String, String)>,
    /// The largest of the per-AP position errors, m.
    pub ap_position_error_max_m: Option<f64>,
    /// `Metrics::position_error_max_m`: the largest aligned position error over the
    /// converged trajectory (the pipeline writes converged poses only), m.
    pub max_error_after_convergence_m: Option<f64>,
    /// Share of the flight after convergence its converged poses cover (`stats.json`
    /// `coverage.share`; 1: never lost); `None` when it never converged.
    pub pose_coverage: Option<f64>,
    /// Wall time of the whole run (simulation, dataset, pipeline, scoring), s.
    pub wall_s: f64,
    /// Why the run failed (empty: it did not). A run that never converged has not failed.
    pub error: String,
}

impl RunRow {
    /// A row with no results, for a run that failed with `error`.
    pub fn failed(scenario: &str, seed: u64, error: String) -> Self {
        Self {
            scenario: scenario.to_string(),
            seed,
            labels: Vec::new(),
            converged: false,
            restarts: None,
            rejected_convergences: None,
            metrics: Vec::new(),
            ap_position_error_max_m: None,
            max_error_after_convergence_m: None,
            pose_coverage: None,
            wall_s: 0.0,
            error,
        }
    }

    /// The drawn label `name` (`None`: no such label, as for a scenario's run).
    pub fn label(&self, name: &str) -> Option<&str> {
        self.labels
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// The metric in column `key` as a number (`None`: absent, empty or not a number).
    pub fn metric(&self, key: &str) -> Option<f64> {
        self.metrics
            .iter()
            .find(|(k, _)| k == key)
            .and_then(|(_, v)| v.parse::<f64>().ok())
    }

    /// Fills the metric columns from `metrics` ([`flatten`] less [`WALL_CLOCK_METRICS`]) and
    /// the columns derived from them.
    pub fn set_metrics(&mut self, metrics: &Metrics) -> Result<(), serde_json::Error> {
        self.metrics = flatten(metrics)?
            .into_iter()
            .filter(|(k, _)| !WALL_CLOCK_METRICS.contains(&k.as_str()))
            .collect();
        self.ap_position_error_max_m = metrics
            .ap_position_error_m
            .values()
            .copied()
            .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))));
        self.max_error_after_convergence_m = Some(metrics.position_error_max_m);
        Ok(())
    }
}

/// The metric columns of a run of a flight with the APs `ap_names`, for a run that was not
/// scored: those of a made-up scored run (a circle flown exactly), so that a new field of
/// [`Metrics`] is a column of every row. Empty if the made-up run cannot be scored.
pub fn metric_keys(ap_names: &[String]) -> Vec<String> {
    const POSES: i64 = 24;
    const PERIOD_NS: i64 = 100_000_000;
    let poses: Vec<Pose> = (0..POSES)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / POSES as f64;
            Pose {
                t: Timestamp(k * PERIOD_NS),
                p_b_in_w: Vector3::new(a.cos(), a.sin(), 0.1 * a),
                world_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, a),
            }
        })
        .collect();
    let estimated: Vec<EstimatedAp> = ap_names
        .iter()
        .map(|name| EstimatedAp {
            name: name.clone(),
            x_m: 3.0,
            y_m: 0.0,
            z_m: 1.0,
            ..Default::default()
        })
        .collect();
    let truth: Vec<ApRow> = ap_names
        .iter()
        .map(|name| ApRow {
            name: name.clone(),
            x_m: 3.0,
            y_m: 0.0,
            z_m: 1.0,
        })
        .collect();
    let Ok(mut m) = evaluate(&poses, &poses, &estimated, &truth, &EvalOptions::default()) else {
        return Vec::new();
    };
    // The run-only fields, as a scored run has them.
    m.aoa_error_median_deg = Some(0.0);
    m.packets_used = Some(0);
    m.packets_dropped = Some(0);
    m.realtime_factor = Some(1.0);
    flatten(&m)
        .map(|cells| {
            cells
                .into_iter()
                .map(|(k, _)| k)
                .filter(|k| !WALL_CLOCK_METRICS.contains(&k.as_str()))
                .collect()
        })
        .unwrap_or_default()
}

/// The metric columns of a table whose rows (or shards' headers) have the column lists
/// `lists`: every column of any list, in an order consistent with each list; where the lists
/// leave the order open, alphabetical. Rows of one sweep and the headers of its shards give
/// the same columns in the same order.
pub fn merge_columns<'a, I>(lists: I) -> Vec<String>
where
    I: IntoIterator<Item = &'a [String]>,
{
    let mut after: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    let mut pending: BTreeMap<&str, usize> = BTreeMap::new();
    for list in lists {
        for c in list {
            pending.entry(c).or_insert(0);
        }
        for w in list.windows(2) {
            if after.entry(&w[0]).or_default().insert(&w[1]) {
                *pending.entry(&w[1]).or_insert(0) += 1;
            }
        }
    }
    // Kahn's algorithm, the alphabetically first free column first.
    let mut ready: BTreeSet<&str> = pending
        .iter()
        .filter(|&(_, &n)| n == 0)
        .map(|(&c, _)| c)
        .collect();
    let mut out = Vec::with_capacity(pending.len());
    while let Some(c) = ready.pop_first() {
        out.push(c.to_string());
        pending.remove(c);
        for &next in after.get(c).into_iter().flatten() {
            if let Some(n) = pending.get_mut(next) {
                *n -= 1;
                if *n == 0 {
                    ready.insert(next);
                }
            }
        }
    }
    // Lists that disagree (a cycle): the rest alphabetically.
    out.extend(pending.into_keys().map(str::to_string));
    out
}

/// The metric columns of `rows`.
pub fn metric_columns(rows: &[RunRow]) -> Vec<String> {
    let lists: Vec<Vec<String>> = rows
        .iter()
        .map(|r| r.metrics.iter().map(|(k, _)| k.clone()).collect())
        .collect();
    merge_columns(lists.iter().map(Vec::as_slice))
}

/// The label columns of `rows` (without [`LABEL_PREFIX`]): every label of any row, in the
/// rows' order.
pub fn label_columns(rows: &[RunRow]) -> Vec<String> {
    let lists: Vec<Vec<String>> = rows
        .iter()
        .map(|r| r.labels.iter().map(|(k, _)| k.clone()).collect())
        .collect();
    merge_columns(lists.iter().map(Vec::as_slice))
}

/// `runs.csv` as bytes: the header ([`LEADING_COLUMNS`], the rows' labels each prefixed with
/// [`LABEL_PREFIX`], `columns`, [`TRAILING_COLUMNS`]) and one line per row, in the order given.
pub fn runs_csv(columns: &[String], rows: &[RunRow]) -> Result<Vec<u8>, SweepError> {
    let malformed = |e: csv::Error| SweepError::Malformed {
        path: super::RUNS_FILE.into(),
        reason: e.to_string(),
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    let labels = label_columns(rows);
    let header = LEADING_COLUMNS
        .iter()
        .map(|c| c.to_string())
        .chain(labels.iter().map(|l| format!("{LABEL_PREFIX}{l}")))
        .chain(columns.iter().cloned())
        .chain(TRAILING_COLUMNS.iter().map(|c| c.to_string()));
    w.write_record(header).map_err(malformed)?;
    for r in rows {
        let by_key: BTreeMap<&str, &str> = r
            .metrics
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        let opt = |x: Option<u64>| x.map(|v| v.to_string()).unwrap_or_default();
        let mut record = vec![
            r.scenario.clone(),
            r.seed.to_string(),
            r.converged.to_string(),
            opt(r.restarts),
            opt(r.rejected_convergences),
        ];
        record.extend(labels.iter().map(|l| r.label(l).unwrap_or("").to_string()));
        record.extend(
            columns
                .iter()
                .map(|c| by_key.get(c.as_str()).copied().unwrap_or("").to_string()),
        );
        record.extend([
            number_cell(r.ap_position_error_max_m),
            number_cell(r.max_error_after_convergence_m),
            number_cell(r.pose_coverage),
            format!("{:.3}", r.wall_s),
            r.error.clone(),
        ]);
        w.write_record(&record).map_err(malformed)?;
    }
    w.into_inner().map_err(|e| SweepError::Malformed {
        path: super::RUNS_FILE.into(),
        reason: e.to_string(),
    })
}

/// Reads a `runs.csv`: its metric columns and its rows. A metric column's empty cells are
/// kept as empty cells, so the rows write back to the same file.
pub fn read_runs_csv(path: &Path) -> Result<(Vec<String>, Vec<RunRow>), SweepError> {
    let bad = |reason: String| SweepError::Malformed {
        path: path.to_path_buf(),
        reason,
    };
    let bytes = std::fs::read(path).map_err(|source| SweepError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header: Vec<String> = r
        .headers()
        .map_err(|e| bad(e.to_string()))?
        .iter()
        .map(str::to_string)
        .collect();
    let (lead, trail) = (LEADING_COLUMNS.len(), TRAILING_COLUMNS.len());
    if header.len() < lead + trail
        || header[..lead] != LEADING_COLUMNS
        || header[header.len() - trail..] != TRAILING_COLUMNS
    {
        return Err(bad(format!(
            "the header is not that of a sweep's runs.csv (it starts with {} and ends with {})",
            LEADING_COLUMNS.join(","),
            TRAILING_COLUMNS.join(",")
        )));
    }
    let middle = lead..header.len() - trail;
    // (index in the header, name without the prefix) of the label columns, then the metrics'.
    let labels: Vec<(usize, String)> = middle
        .clone()
        .filter_map(|j| Some((j, header[j].strip_prefix(LABEL_PREFIX)?.to_string())))
        .collect();
    let metric_at: Vec<usize> = middle
        .filter(|&j| !header[j].starts_with(LABEL_PREFIX))
        .collect();
    let columns: Vec<String> = metric_at.iter().map(|&j| header[j].clone()).collect();
    let mut rows = Vec::new();
    for (i, record) in r.records().enumerate() {
        let line = i + 2;
        let rec = record.map_err(|e| bad(format!("line {line}: {e}")))?;
        let at = |k: usize| rec.get(k).unwrap_or("");
        let whole = |k: usize| -> Result<Option<u64>, SweepError> {
            match at(k) {
                "" => Ok(None),
                s => s
                    .parse()
                    .map(Some)
                    .map_err(|e| bad(format!("line {line}, column {}: {s:?}: {e}", header[k]))),
            }
        };
        let real = |k: usize| -> Result<Option<f64>, SweepError> {
            match at(k) {
                "" => Ok(None),
                s => s
                    .parse()
                    .map(Some)
                    .map_err(|e| bad(format!("line {line}, column {}: {s:?}: {e}", header[k]))),
            }
        };
        let t = header.len() - trail;
        let row = RunRow {
            scenario: at(0).to_string(),
            seed: whole(1)?.ok_or_else(|| bad(format!("line {line}: no seed")))?,
            // A scenario's run beside a family's has empty label cells: no labels.
            labels: labels
                .iter()
                .filter(|(j, _)| !at(*j).is_empty())
                .map(|(j, name)| (name.clone(), at(*j).to_string()))
                .collect(),
            converged: match at(2) {
                "true" => true,
                "false" => false,
                s => return Err(bad(format!("line {line}: converged is {s:?}"))),
            },
            restarts: whole(3)?,
            rejected_convergences: whole(4)?,
            metrics: metric_at
                .iter()
                .map(|&j| (header[j].clone(), at(j).to_string()))
                .collect(),
            ap_position_error_max_m: real(t)?,
            max_error_after_convergence_m: real(t + 1)?,
            pose_coverage: real(t + 2)?,
            wall_s: real(t + 3)?.unwrap_or(0.0),
            error: at(t + 4).to_string(),
        };
        rows.push(row);
    }
    Ok((columns, rows))
}

#[cfg(test)]
pub(crate) mod tests;
