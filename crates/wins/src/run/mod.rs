//! Batch runs: a dataset replayed through the [`crate::pipeline`] and its run folder written.
//! The library's front door is here: a dataset folder in, a scored run out ([`run_dataset`]),
//! what `wins run` does.
//!
//! - [`replay`]: a dataset (in memory or read as it is consumed) pushed through a
//!   [`crate::pipeline::ChainResolver`] by one loop ([`drive`]); [`RunOutput`] is what it gives;
//! - [`output`], [`run_dir`]: the run folder's files and its manifest `run.json`; the one writer
//!   of `trajectory.tum` is [`trajectory`] (`wins live` writes through it too);
//! - [`spool`]: the per-frame and per-packet files written as they come, for a run whose memory
//!   does not grow with the flight ([`run_dataset_into`]), and its scoring from those files;
//! - [`coverage`]: how much of the flight the converged poses cover. The figures are made
//!   from the run's files afterwards ([`crate::figures`]).

pub mod coverage;
pub mod drive;
pub mod folder;
pub mod output;
pub mod replay;
pub mod run_dir;
pub mod run_output;
mod scoring;
pub(crate) mod scoring_truth;
pub mod spool;
pub mod spooled;
pub mod trajectory;

use std::path::Path;

use self::drive::{Collected, RunSink};
use self::replay::{replay_stream, rig_of_manifest};
use self::run_output::{Evaluation, ReplayError, RunOutput};
use self::scoring_truth::ScoringTruth;
use self::spool::{ScoringSpool, Spool};
use crate::config::Config;
use crate::dataset::DatasetError;
use crate::dataset::stream::DatasetStream;
use crate::dataset::truth::TRUTH_DIR;
use crate::pipeline::chains::resolves;
use crate::rig::{ChainCalibration, ImuNoise};

/// What a run may take from outside the dataset.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// A chain calibration to use instead of the dataset's.
    pub calibration: Option<ChainCalibration>,
    /// IMU noise densities to use instead of the dataset's.
    pub imu_noise: Option<ImuNoise>,
    /// Use no chain calibration, not even the dataset's: the offsets are resolved from the
    /// flight alone ([`crate::pipeline::chains`]).
    pub no_calibration: bool,
}

/// Why a dataset could not be run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The settings cannot be used (every problem listed).
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// The dataset cannot be loaded.
    #[error("loading {path}: {source}")]
    Dataset {
        /// The dataset folder.
        path: String,
        /// Why (boxed: a dataset error carries the reader's details).
        source: Box<DatasetError>,
    },
    /// The replay failed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
}

/// Runs WINS on the dataset folder at `path` with `config` ([`run_dataset_with`] with no
/// overrides).
///
/// ```no_run
/// let run = wins::run_dataset("my_flight".as_ref(), &wins::Config::default())?;
/// println!("converged at {:?}", run.converged_at);
/// # Ok::<(), wins::RunError>(())
/// ```
pub fn run_dataset(path: &Path, config: &Config) -> Result<RunOutput, RunError> {
    run_dataset_with(path, config, &RunOptions::default())
}

/// Reads the dataset at `path` as it is consumed ([`DatasetStream`]), replays it through the
/// [`crate::pipeline::Pipeline`], and when it has a `truth/` folder scores the converged trajectory
/// against it (`metrics`, `figures`). What limits the result (no chain calibration, a run that
/// cannot be scored) is in `warnings`. The frames and packet rows are kept in the output; for a
/// run whose memory does not grow with the flight's length, [`run_dataset_into`].
///
/// A truth that cannot be read does not stop the run: the estimate is returned, with
/// [`Evaluation::Failed`] naming the file in `evaluation` and a warning.
pub fn run_dataset_with(
    path: &Path,
    config: &Config,
    options: &RunOptions,
) -> Result<RunOutput, RunError> {
    let mut sink = Collected::default();
    let mut run = run_into_sink(path, config, options, &mut sink)?;
    run.frames = sink.frames;
    run.sent = sink.sent;
    run.packets = sink.packets;
    score(&mut run, path, config, None);
    Ok(run)
}

/// [`run_dataset_with`], with the per-frame and per-packet files (`trajectory.tum`,
/// `trajectory_all.tum`, `covariance.csv`, `aoa.csv`) written into `out` as they are produced
/// ([`Spool`]; [`RunOutput::write`] into `out` renames them into place): the run holds neither
/// the dataset nor those rows ([`RunOutput::converged_poses`] is empty). With a truth, what
/// scoring reads (the converged poses and covariances, the fed packets' AoA) goes to two more
/// spool files, and the scoring reads them and the truth's poses in passes, holding neither
/// trajectory: the metrics are those of [`run_dataset_with`]. The scoring's
/// files are removed before this returns.
pub fn run_dataset_into(
    path: &Path,
    config: &Config,
    options: &RunOptions,
    out: &Path,
) -> Result<RunOutput, RunError> {
    let for_scoring = path.join(TRUTH_DIR).is_dir();
    let mut spool = Spool::create(out, for_scoring).map_err(ReplayError::Output)?;
    let mut run = run_into_sink(path, config, options, &mut spool)?;
    let (spooled, scoring) = spool.finish_with_scoring().map_err(ReplayError::Output)?;
    run.spooled = Some(spooled);
    score(&mut run, path, config, scoring.as_ref());
    Ok(run)
}

/// The replay of the dataset at `path` into `sink`, with the warnings of the rig.
fn run_into_sink(
    path: &Path,
    config: &Config,
    options: &RunOptions,
    sink: &mut dyn RunSink,
) -> Result<RunOutput, RunError> {
    config.validate()?;
    let data = DatasetStream::open_with(path, !options.no_calibration).map_err(|source| {
        RunError::Dataset {
            path: path.display().to_string(),
            source: Box::new(source),
        }
    })?;
    let mut rig = rig_of_manifest(
        &data.manifest,
        data.calibration.as_ref(),
        options.imu_noise.clone(),
        options.calibration.clone(),
    )?;
    if options.no_calibration {
        rig.calibration = None;
    }
    let mut warnings = Vec::new();
    if rig.calibration.is_none() && resolves(config, &rig) {
        warnings.push(
            "no chain calibration: the chains' phase offsets are resolved from the flight alone \
             (stats.json chain_offsets; a calibration makes the start faster and surer)"
                .to_string(),
        );
    } else if rig.calibration.is_none() {
        warnings.push(
            "no chain calibration, and the offsets are not resolved from the flight \
             (pipeline.chains.resolve = false, the paper's estimator or two antennas): AoA will \
             be wrong by tens of degrees"
                .to_string(),
        );
    }
    let mut run = replay_stream(&data, rig, config, sink)?;
    run.warnings.extend(warnings);
    if run.wins.imu_gaps > 0 {
        run.warnings.push(format!(
            "the estimator met {} IMU gap(s) longer than {} s: {} frame(s) inside them got no \
             pose; the nonlinear estimator restarts after a gap met while tracking",
            run.wins.imu_gaps, config.imu_gap.max_s, run.wins.frames_in_imu_gap
        ));
    }
    run.warnings.extend(run.coverage.warning());
    Ok(run)
}

/// Scores `run` against the truth of the dataset at `path`, when it has one: from the spool's
/// `files` for a spooled run, from memory for one held. A truth that cannot be read fails the
/// evaluation, not the estimate.
fn score(run: &mut RunOutput, path: &Path, config: &Config, files: Option<&ScoringSpool>) {
    if !path.join(TRUTH_DIR).is_dir() {
        return;
    }
    let scored = ScoringTruth::open(path)
        .map_err(|e| Box::new(e) as Box<dyn std::error::Error>)
        .and_then(|truth| {
            match files {
                Some(files) => run.score_spooled(&truth, files, &config.eval),
                None => run.score_held(&truth, &config.eval),
            }
            .map_err(Into::into)
        });
    if let Err(e) = scored {
        evaluation_failed(run, path, e.as_ref());
    }
}

/// The truth of the dataset at `path` could not be read (`e`): the evaluation failed.
fn evaluation_failed(run: &mut RunOutput, path: &Path, e: &dyn std::error::Error) {
    let why = format!(
        "reading the truth of {}: {}",
        path.display(),
        with_causes(e)
    );
    run.warnings.push(format!("evaluation failed: {why}"));
    run.evaluation = Evaluation::Failed(why);
}

/// An error's text followed by its causes', `: `-separated (a cause already in the text once):
/// how every front end (the CLI, Python) words an error.
pub fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let more = c.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        cause = c.source();
    }
    text
}
