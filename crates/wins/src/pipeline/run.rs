//! The library's front door: a dataset folder in, a scored run out ([`run_dataset`]), what
//! `wins run` does.

use std::path::Path;

use super::Config;
use super::chains::resolves;
use super::replay::{Evaluation, ReplayError, RunOutput, replay, rig_of};
use crate::dataset::truth::{TRUTH_DIR, Truth};
use crate::dataset::{Dataset, DatasetError};
use crate::rig::{ChainCalibration, ImuNoise};

/// What a run may take from outside the dataset.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// A chain calibration to use instead of the dataset's.
    pub calibration: Option<ChainCalibration>,
    /// IMU noise densities to use instead of the dataset's.
    pub imu_noise: Option<ImuNoise>,
    /// Use no chain calibration, not even the dataset's: the offsets are resolved from the
    /// flight alone ([`super::chains`]).
    pub no_calibration: bool,
}

/// Why a dataset could not be run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The settings cannot be used (every problem listed).
    #[error(transparent)]
    Config(#[from] super::ConfigError),
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

/// Loads the dataset at `path`, replays it through the [`super::Pipeline`], and when it has a
/// `truth/` folder scores the converged trajectory against it (`metrics`, `figures`). What
/// limits the result (no chain calibration, a run that cannot be scored) is in `warnings`.
///
/// A truth that cannot be read does not stop the run: the estimate is returned, with
/// [`Evaluation::Failed`] naming the file in `evaluation` and a warning.
pub fn run_dataset_with(
    path: &Path,
    config: &Config,
    options: &RunOptions,
) -> Result<RunOutput, RunError> {
    config.validate()?;
    let data = Dataset::load(path).map_err(|source| RunError::Dataset {
        path: path.display().to_string(),
        source: Box::new(source),
    })?;
    let mut rig = rig_of(
        &data,
        options.imu_noise.clone(),
        options.calibration.clone(),
    )?;
    if options.no_calibration {
        rig.calibration = None;
    }
    let mut warnings = Vec::new();
    if rig.calibration.is_none() && resolves(config, rig.geometry) {
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
    // Read before the replay, used after it: a truth that cannot be read fails the evaluation,
    // not the estimate.
    let truth = path
        .join(TRUTH_DIR)
        .is_dir()
        .then(|| Truth::load(path).map_err(|e| with_causes(&e)));
    let mut run = replay(&data, rig, config)?;
    run.warnings.extend(warnings);
    if run.wins.imu_gaps > 0 {
        run.warnings.push(format!(
            "the estimator met {} IMU gap(s) longer than {} s: {} frame(s) inside them got no \
             pose; the nonlinear estimator restarts after a gap met while tracking",
            run.wins.imu_gaps, config.imu_gap.max_s, run.wins.frames_in_imu_gap
        ));
    }
    match &truth {
        Some(Ok(truth)) => run.score_against(truth, &config.eval),
        Some(Err(why)) => {
            let why = format!("reading the truth of {}: {why}", path.display());
            run.warnings.push(format!("evaluation failed: {why}"));
            run.evaluation = Evaluation::Failed(why);
        }
        None => {}
    }
    Ok(run)
}

/// An error's text followed by its causes', `: `-separated (a cause already in the text once).
fn with_causes(e: &dyn std::error::Error) -> String {
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
