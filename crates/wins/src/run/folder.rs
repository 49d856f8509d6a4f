//! A run into its folder, as `wins run` makes it (and Python's `wins.run`): the folder checked
//! before any work ([`RunDir::prepare`]), the dataset replayed with the per-frame files written
//! as they come ([`super::run_dataset_into`]), the manifest started, the data files written,
//! what the caller adds (the figures), and the manifest finished last, listing every file.

use std::io;
use std::path::{Path, PathBuf};

use super::run_dir::{RunDir, RunInputs, RunManifest};
use super::run_output::RunOutput;
use super::{RunError, RunOptions, run_dataset_into};
use crate::config::Config;
use crate::io_safety::OutputError;

/// Why a run folder could not be made.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The folder cannot be used, or a file of it cannot be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The dataset cannot be run.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A data file cannot be written.
    #[error("writing {path}: {source}")]
    Write {
        /// The run folder.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// What the caller adds failed.
    #[error("{0}")]
    Extra(String),
}

/// What a caller adds to a run folder (the figures): given the run and the folder, the files it
/// wrote, or why it could not.
pub type Extra<'a> = dyn FnMut(&RunOutput, &Path) -> Result<Vec<PathBuf>, String> + 'a;

/// A run folder made ([`run_into_folder`]).
#[derive(Debug)]
pub struct FolderRun {
    /// What the run gave (its frames and packets are in the folder's files).
    pub run: RunOutput,
    /// The files written, the manifest's last.
    pub written: Vec<PathBuf>,
}

/// Runs `inputs` into the folder `dir` (checked by [`RunDir::prepare`] before any work, a
/// simulation say; module doc); `extra` writes more files into it (the figures) and returns
/// them. A run whose truth cannot be read keeps its estimate: its `evaluation` says so, and the
/// caller decides whether that fails.
pub fn run_into_folder(
    dir: &RunDir,
    inputs: &RunInputs<'_>,
    config: &Config,
    options: &RunOptions,
    extra: &mut Extra<'_>,
) -> Result<FolderRun, FolderError> {
    let run = run_dataset_into(inputs.dataset, config, options, dir.path())?;
    let path = dir.path().to_path_buf();
    let mut manifest = RunManifest::new(inputs, config, options.no_calibration);
    dir.start(&manifest)?;
    let mut written = run.write(&path).map_err(|source| FolderError::Write {
        path: path.clone(),
        source,
    })?;
    written.extend(extra(&run, &path).map_err(FolderError::Extra)?);
    manifest.record(&run);
    written.push(dir.finish(&manifest, &written)?);
    Ok(FolderRun { run, written })
}
