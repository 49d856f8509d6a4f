//! Sweeps: the estimator measured over many simulated flights, scenarios × seeds.
//!
//! ```text
//!  plan (scenarios × seeds, duration, Config) ─► runs in a fixed order ─► shard K/N keeps i % N = K−1
//!     each run, on a rayon pool: simulate ─► write dataset ─► run_dataset ─► score ─► one RunRow
//!  rows ─► runs.csv (one row per run) ─► summary.json (per scenario: counts, median / p90 / worst)
//!  shards' runs.csv + plan.json ─► merge ─► the same runs.csv and summary.json as one unsharded run
//! ```
//!
//! What `wins sweep` does, as a library: [`plan`] resolves what to run (built-in scenarios,
//! scenario files and flight families side by side, seeds, shards) and enumerates the runs, [`record`] is
//! `plan.json`, [`execute`] runs them on all cores (a run that fails is a row with its error,
//! never a panic and never a dropped row), [`table`] flattens each run's
//! [`crate::eval::Metrics`] into the columns of `runs.csv` generically (new metrics become new
//! columns) beside a family's drawn labels, [`summary`] computes the per-scenario statistics
//! and a family's breakdown by its labels, and [`merge`] joins shards. The
//! library never prints: progress is a callback, problems are [`SweepError`]s or warnings
//! returned with the data. The user's guide, with every column and key, is docs/SWEEP.md.
//!
//! Determinism: a run's row depends only on its scenario, seed, duration and settings, never on
//! the number of threads or the shard it ran in; the only column that changes between two
//! sweeps of one plan is `wall_s`, and `summary.json` holds no wall time.

pub mod execute;
pub mod merge;
pub mod plan;
pub mod record;
pub mod shard;
pub mod summary;
pub mod table;

use std::path::PathBuf;

pub use execute::{Progress, SweepOptions, SweepReport, prepare_out_dir, run_sweep, write_outputs};
pub use merge::{Merged, copy_scenario_files, merge_dirs, read_plan};
pub use plan::{Plan, PlanSpec, RunFlight, RunId, Seeds, Shard, SweepScenario};
pub use record::{PlanRecord, PlanScenario};
pub use summary::{ScenarioSummary, Spread, SweepSummary, percentile, summarize};
pub use table::{RunRow, read_runs_csv};

use crate::ConfigError;
use crate::sim::family::FamilyError;
use crate::sim::scenario::ScenarioError;

/// `runs.csv`: one row per run.
pub const RUNS_FILE: &str = "runs.csv";
/// `summary.json`: per-scenario statistics.
pub const SUMMARY_FILE: &str = "summary.json";
/// `plan.json`: what was run (and which shard), so that shards can be merged safely.
pub const PLAN_FILE: &str = "plan.json";
/// The runs' temporary datasets, inside the output directory (one folder per run,
/// `<scenario>-<seed>`; deleted after each run unless kept).
pub const DATASETS_DIR: &str = ".datasets";
/// The scenarios of the runs of flight families, inside the output directory (one file per run,
/// `<family>-<seed>.toml`, which `wins simulate --scenario-file` flies again).
pub const SCENARIOS_DIR: &str = "scenarios";

/// Why a sweep (or a merge) cannot be made. A single run that fails is not an error: it is a row
/// of `runs.csv` with its `error` cell filled.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// No scenario was named.
    #[error(
        "no scenarios: name built-in ones, scenario files or flight families (e.g. --scenario \
         paper-circle, --family room)"
    )]
    NoScenarios,
    /// No seed was given.
    #[error("no seeds: give a range or a list (e.g. --seeds 1..20)")]
    NoSeeds,
    /// A seed list that does not parse or is empty.
    #[error("seeds {text:?}: {reason}")]
    Seeds {
        /// What was given.
        text: String,
        /// What is wrong.
        reason: String,
    },
    /// A shard that does not parse or is out of range.
    #[error("shard {text:?}: {reason}")]
    Shard {
        /// What was given.
        text: String,
        /// What is wrong.
        reason: String,
    },
    /// More runs than [`plan::MAX_RUNS`].
    #[error("{runs} runs planned; at most {max} are allowed in one sweep")]
    TooManyRuns {
        /// Scenarios × seeds.
        runs: u128,
        /// The limit.
        max: usize,
    },
    /// A scenario cannot be had (unknown name: the message lists the built-in ones).
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A flight family cannot be had (unknown name: the message lists the families), or a
    /// drawn flight cannot be flown with the plan's duration.
    #[error(transparent)]
    Family(#[from] FamilyError),
    /// A scenario cannot be flown with the plan's card.
    #[error("scenario {label:?} with card = {card}: {source}")]
    Card {
        /// The scenario's label.
        label: String,
        /// The card asked for.
        card: crate::csi::format::CaptureFormat,
        /// Why.
        source: crate::sim::ConfigError,
    },
    /// A scenario cannot be flown with the plan's duration override.
    #[error("scenario {label:?} with duration_s = {duration_s}: {source}")]
    Duration {
        /// The scenario's label.
        label: String,
        /// The override, s.
        duration_s: f64,
        /// What is wrong.
        source: crate::sim::ConfigError,
    },
    /// Two scenarios of a plan with one label.
    #[error(
        "scenario {label:?} is listed twice (a file's label is its file name without .toml; \
         rename one)"
    )]
    DuplicateScenario {
        /// The label.
        label: String,
    },
    /// The pipeline's settings cannot be used.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A plan file that does not parse.
    #[error("plan {path}: {reason}")]
    PlanFile {
        /// The file.
        path: PathBuf,
        /// What is wrong (the TOML parser's message, with line and column).
        reason: String,
    },
    /// A file or directory that cannot be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// What was read.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A file or directory that cannot be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// What was written.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The output directory already holds files.
    #[error("{path} is not empty: a sweep writes into a new or empty directory")]
    OutputNotEmpty {
        /// The directory.
        path: PathBuf,
    },
    /// The worker threads cannot be started.
    #[error("cannot start {jobs} worker threads: {reason}")]
    ThreadPool {
        /// Threads asked for (0: one per core).
        jobs: usize,
        /// rayon's message.
        reason: String,
    },
    /// A malformed `runs.csv` or `plan.json`.
    #[error("{path}: {reason}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the row when there is one.
        reason: String,
    },
    /// Shards that cannot be merged (another plan, conflicting or missing runs).
    #[error("merge: {0}")]
    Merge(String),
}
