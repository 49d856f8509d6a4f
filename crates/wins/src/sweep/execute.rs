//! Running a plan: each run simulates its flight, writes it as a dataset, runs the pipeline on
//! the files and scores it, exactly as `wins simulate` then `wins run` do; runs execute on a
//! rayon pool, the longest expected first (a flight's duration, doubled without a lab
//! calibration), and their rows come back in canonical order. A family's run first draws its
//! flight and keeps its scenario in `scenarios/`.

use std::io::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use super::plan::{Plan, RunId, Shard};
use super::record::PlanRecord;
use super::summary::{SweepSummary, summarize};
use super::table::{RunRow, metric_columns, metric_keys, runs_csv};
use super::{DATASETS_DIR, PLAN_FILE, RUNS_FILE, SCENARIOS_DIR, SUMMARY_FILE, SweepError};
use crate::sim;
use crate::sim::family;
use crate::{RunOutput, run_dataset};

/// How to run a plan.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SweepOptions {
    /// Worker threads (0: one per core).
    pub jobs: usize,
    /// Run only this part of the plan.
    pub shard: Option<Shard>,
    /// Keep each run's dataset in `OUT/.datasets/<scenario>-<seed>/` (deleted otherwise).
    pub keep_datasets: bool,
}

/// One finished run, handed to the progress callback.
#[derive(Clone, Copy, Debug)]
pub struct Progress<'a> {
    /// Runs finished so far, this one included.
    pub done: usize,
    /// Runs in this sweep (this shard).
    pub total: usize,
    /// This run's row.
    pub row: &'a RunRow,
}

/// What a sweep produced (also written to its directory).
#[derive(Clone, Debug)]
pub struct SweepReport {
    /// `plan.json`.
    pub record: PlanRecord,
    /// The metric columns of `runs.csv`.
    pub columns: Vec<String>,
    /// `runs.csv`, in canonical order.
    pub rows: Vec<RunRow>,
    /// `summary.json`.
    pub summary: SweepSummary,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// What did not go as it should without spoiling the results (a temporary dataset that
    /// could not be deleted).
    pub warnings: Vec<String>,
}

/// Refuses a directory that holds anything; creates it when missing.
pub fn prepare_out_dir(out: &Path) -> Result<(), SweepError> {
    match std::fs::read_dir(out) {
        Ok(mut entries) => {
            if entries.next().is_some() {
                return Err(SweepError::OutputNotEmpty {
                    path: out.to_path_buf(),
                });
            }
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            std::fs::create_dir_all(out).map_err(|source| SweepError::Write {
                path: out.to_path_buf(),
                source,
            })
        }
        Err(source) => Err(SweepError::Read {
            path: out.to_path_buf(),
            source,
        }),
    }
}

/// Runs `plan` (the part `options.shard` keeps) into `out`, which must be new or empty:
/// `runs.csv`, `summary.json` and `plan.json`, each written under a temporary name and renamed
/// into place once complete, and a family's runs' scenarios in [`SCENARIOS_DIR`]. `progress` is
/// called after each run, from the worker threads.
pub fn run_sweep(
    plan: &Plan,
    out: &Path,
    options: &SweepOptions,
    progress: &(dyn Fn(Progress<'_>) + Sync),
) -> Result<SweepReport, SweepError> {
    let record = plan.record(options.shard)?;
    prepare_out_dir(out)?;
    let runs = start_order(plan, plan.runs_of(options.shard));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.jobs)
        .build()
        .map_err(|e| SweepError::ThreadPool {
            jobs: options.jobs,
            reason: e.to_string(),
        })?;
    let done = AtomicUsize::new(0);
    let next = AtomicUsize::new(0);
    let total = runs.len();
    let finished: Mutex<Vec<(RunRow, Option<String>)>> = Mutex::new(Vec::with_capacity(total));
    // One queue, taken in order by every worker: a worker that finishes takes the next run.
    pool.broadcast(|_| {
        while let Some(run) = runs.get(next.fetch_add(1, Ordering::Relaxed)) {
            let (row, warning) = run_one(plan, *run, out, options.keep_datasets);
            let done = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(Progress {
                done,
                total,
                row: &row,
            });
            // A poisoned lock only means another worker panicked while pushing: its rows stay.
            finished
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .push((row, warning));
        }
    });
    let mut rows = finished
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    // Canonical order whatever the completion order.
    let order = |r: &RunRow| plan.scenarios.iter().position(|s| s.label == r.scenario);
    rows.sort_by_key(|(r, _)| (order(r), r.seed));
    let mut warnings: Vec<String> = rows.iter_mut().filter_map(|(_, w)| w.take()).collect();
    let rows: Vec<RunRow> = rows.into_iter().map(|(r, _)| r).collect();
    let datasets = out.join(DATASETS_DIR);
    if !options.keep_datasets
        && datasets.is_dir()
        && let Err(e) = std::fs::remove_dir(&datasets)
    {
        warnings.push(format!("cannot delete {}: {e}", datasets.display()));
    }
    let columns = metric_columns(&rows);
    let labels: Vec<String> = plan.scenarios.iter().map(|s| s.label.clone()).collect();
    let summary = summarize(&record.plan_id, &record.wins_version, &labels, &rows);
    let files = write_outputs(out, &record, &columns, &rows, &summary)?;
    Ok(SweepReport {
        record,
        columns,
        rows,
        summary,
        files,
        warnings,
    })
}

/// Writes `runs.csv`, `summary.json` and `plan.json` into `out`, each under a temporary name
/// first; returns their paths.
pub fn write_outputs(
    out: &Path,
    record: &PlanRecord,
    columns: &[String],
    rows: &[RunRow],
    summary: &SweepSummary,
) -> Result<Vec<PathBuf>, SweepError> {
    let plan_json = serde_json::to_string_pretty(record).map_err(|e| SweepError::Malformed {
        path: out.join(PLAN_FILE),
        reason: e.to_string(),
    })? + "\n";
    let files = [
        (RUNS_FILE, runs_csv(columns, rows)?),
        (SUMMARY_FILE, summary.to_json().into_bytes()),
        (PLAN_FILE, plan_json.into_bytes()),
    ];
    let mut written = Vec::with_capacity(files.len());
    for (name, bytes) in files {
        let path = out.join(name);
        write_atomic(&path, &bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// Writes `bytes` to `.NAME.tmp` beside `path`, then renames it to `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SweepError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    let err = |source| SweepError::Write {
        path: path.to_path_buf(),
        source,
    };
    let mut f = std::fs::File::create(&tmp).map_err(err)?;
    f.write_all(bytes).map_err(err)?;
    f.sync_all().map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// `runs` in the order they are started: the longest expected first ([`expected_work`]), ties
/// in their canonical order.
fn start_order(plan: &Plan, runs: Vec<RunId>) -> Vec<RunId> {
    let mut keyed: Vec<(f64, RunId)> = runs
        .into_iter()
        .map(|r| (expected_work(plan, r), r))
        .collect();
    // A stable sort: ties keep the canonical order.
    keyed.sort_by(|a, b| b.0.total_cmp(&a.0));
    keyed.into_iter().map(|(_, r)| r).collect()
}

/// A run's expected work, for the order the runs are started in (longest first, so that the
/// last runs to finish are short and no core waits long at the end): the flight's duration,
/// doubled without a lab calibration (the chain offsets are then resolved among twice as many
/// hypotheses flown side by side). Only the order depends on it, never a result.
fn expected_work(plan: &Plan, run: RunId) -> f64 {
    match plan.flight(run) {
        // Relative to a calibrated flight's hypotheses, not their count.
        Ok(f) if f.scenario.radio.lab_calibration => f.scenario.duration_s,
        Ok(f) => 2.0 * f.scenario.duration_s,
        // It fails again in its run, which reports why.
        Err(_) => 0.0,
    }
}

/// The dataset folder of a run: `<datasets>/<scenario>-<seed>`.
pub fn dataset_dir(datasets: &Path, label: &str, seed: u64) -> PathBuf {
    datasets.join(format!("{label}-{seed}"))
}

/// The file a family's run keeps its scenario in: `<out>/scenarios/<label>-<seed>.toml`.
pub fn scenario_file(out: &Path, label: &str, seed: u64) -> PathBuf {
    out.join(SCENARIOS_DIR).join(format!("{label}-{seed}.toml"))
}

/// One run, whatever happens in it: its row, and a warning if its dataset could not be
/// deleted.
fn run_one(plan: &Plan, run: RunId, out: &Path, keep: bool) -> (RunRow, Option<String>) {
    let started = Instant::now();
    let s = &plan.scenarios[run.scenario];
    let dir = dataset_dir(&out.join(DATASETS_DIR), &s.label, run.seed);
    let mut row = RunRow::failed(&s.label, run.seed, String::new());
    let mut ap_names: Vec<String> = s.scenario.aps.iter().map(|a| a.name.clone()).collect();
    // A bug in a stage must cost one row, not the sweep.
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        let flight = plan.flight(run).map_err(|e| e.to_string())?;
        ap_names = flight.scenario.aps.iter().map(|a| a.name.clone()).collect();
        if let Some(drawn) = &flight.drawn {
            row.labels = drawn
                .labels()
                .into_iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect();
            let text = family::scenario_toml(&flight.scenario, drawn).map_err(|e| e.to_string())?;
            let path = scenario_file(out, &s.label, run.seed);
            std::fs::create_dir_all(out.join(SCENARIOS_DIR))
                .map_err(|source| SweepError::Write {
                    path: out.join(SCENARIOS_DIR),
                    source,
                })
                .and_then(|()| write_atomic(&path, text.as_bytes()))
                .map_err(|e| format!("keeping the drawn scenario: {e}"))?;
        }
        fly(&flight.scenario, &dir, plan)
    }))
    .unwrap_or_else(|panic| Err(format!("panicked: {}", panic_text(panic.as_ref()))));
    match outcome {
        Ok(output) => fill_row(&mut row, &output),
        Err(error) => row.error = error,
    }
    if row.metrics.is_empty() {
        // Not scored: the columns of its APs, empty.
        row.metrics = metric_keys(&ap_names)
            .into_iter()
            .map(|k| (k, String::new()))
            .collect();
    }
    let warning = if keep || !dir.exists() {
        None
    } else {
        std::fs::remove_dir_all(&dir)
            .err()
            .map(|e| format!("cannot delete {}: {e}", dir.display()))
    };
    row.wall_s = started.elapsed().as_secs_f64();
    (row, warning)
}

/// `wins simulate --seed S [--duration D] --out DIR`, then `wins run DIR` with the plan's
/// settings, through the same library calls.
fn fly(scenario: &sim::Scenario, dir: &Path, plan: &Plan) -> Result<RunOutput, String> {
    let output = sim::simulate(scenario, &mut |_| {}).map_err(|e| format!("simulation: {e}"))?;
    sim::write_dataset(dir, scenario, &output)
        .map_err(|e| format!("writing the dataset: {e}: {}", e.source))?;
    run_dataset(dir, &plan.config).map_err(|e| format!("pipeline: {e}"))
}

/// Fills the row of a run that went through the pipeline.
fn fill_row(row: &mut RunRow, run: &RunOutput) {
    row.converged = run.converged_at.is_some() || run.metrics.is_some();
    row.restarts = Some(run.wins.restarts);
    row.rejected_convergences = Some(run.wins.rejected_convergences);
    row.pose_coverage = run.coverage.share;
    match &run.metrics {
        Some(m) => {
            if let Err(e) = row.set_metrics(m) {
                row.error = format!("cannot flatten the metrics: {e}");
            }
        }
        // Converged but not scored: say why (the pipeline's warning).
        None if row.converged => {
            row.error = run
                .warnings
                .iter()
                .find(|w| w.starts_with("cannot score"))
                .cloned()
                .unwrap_or_else(|| "converged, but not scored".to_string());
        }
        None => {}
    }
}

fn panic_text(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".to_string())
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_family;
