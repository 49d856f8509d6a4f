//! The run directory as a whole: checked before any work, cleared of a previous run's files
//! only, and described by its manifest `run.json` ([`RunManifest`]).
//!
//! Before the run ([`RunDir::prepare`]): the folder may not be the dataset folder, lie inside it,
//! hold it, or be or hold an input file (the files the dataset's `dataset.toml` names, its
//! `truth/` files, the settings and calibration files), all compared as canonical paths; it is
//! created and a probe file is written and removed in it; and it must be empty or a previous
//! run's (it holds a `run.json`). Its other contents are refused.
//!
//! After the run: [`RunDir::start`] removes the files the previous manifest lists (only plain
//! files directly in the folder) and writes `run.json` with `"complete": false`, listing every
//! file the run may write; each output is then written atomically; [`RunDir::finish`] rewrites
//! `run.json` last with `"complete": true` and the files written. A folder whose `run.json` says
//! `"complete": false` holds an interrupted run, and a later run into it still cleans it up.

use std::fs;
use std::path::{Component, Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::output::{
    AOA_FILE, APS_FILE, COVARIANCE_FILE, METRICS_FILE, REPORT_FILE, STATS_FILE,
    TRAJECTORY_ALL_FILE, TRAJECTORY_FILE, TRAJECTORY_SENT_FILE,
};
use super::run_output::RunOutput;
use super::spool::SPOOL_PREFIX;
use crate::config::Config;
use crate::dataset::load::{MANIFEST_FILE as DATASET_MANIFEST, read_manifest};
use crate::dataset::truth::TRUTH_DIR;
use crate::io_safety::{
    OutputError, TEMP_PREFIX, check_writable_dir, refuse_overlap, resolve, write_atomically,
};

/// The run's manifest.
pub const MANIFEST_FILE: &str = "run.json";
/// Figure: the trajectory from above.
pub const TRAJECTORY_PNG: &str = "trajectory.png";
/// Figure: the position error per axis over time in its ±σ band (with a truth).
pub const POSITION_ERROR_PNG: &str = "position_error.png";
/// Figure: the AoA per packet, fed and dropped (and the truth's).
pub const AOA_PNG: &str = "aoa.png";
/// Figure: the height over time, with the barometer's.
pub const HEIGHT_PNG: &str = "height.png";
/// Figure: roll, pitch and yaw over time.
pub const ATTITUDE_PNG: &str = "attitude.png";
/// Figure: the position σ over time.
pub const SIGMA_PNG: &str = "sigma.png";

/// Every file a run may write besides its manifest.
pub const RUN_FILES: [&str; 15] = [
    TRAJECTORY_FILE,
    TRAJECTORY_ALL_FILE,
    TRAJECTORY_SENT_FILE,
    COVARIANCE_FILE,
    APS_FILE,
    AOA_FILE,
    STATS_FILE,
    METRICS_FILE,
    REPORT_FILE,
    TRAJECTORY_PNG,
    POSITION_ERROR_PNG,
    AOA_PNG,
    HEIGHT_PNG,
    ATTITUDE_PNG,
    SIGMA_PNG,
];

/// What a run reads: the dataset folder and the files given beside it.
#[derive(Clone, Copy, Debug)]
pub struct RunInputs<'a> {
    /// The dataset folder.
    pub dataset: &'a Path,
    /// The settings file (`None`: the defaults).
    pub config_file: Option<&'a Path>,
    /// A chain calibration file used instead of the dataset's.
    pub calibration_file: Option<&'a Path>,
}

impl RunInputs<'_> {
    /// The input files that exist: `dataset.toml` and the files it names, the files of
    /// `truth/`, the settings and calibration files.
    pub fn files(&self) -> Vec<PathBuf> {
        let d = self.dataset;
        let mut files = vec![d.join(DATASET_MANIFEST)];
        if let Ok(m) = read_manifest(d) {
            files.push(d.join(&m.imu.file));
            files.extend(m.aps.iter().map(|a| d.join(&a.log)));
            files.extend(m.array.calibration.iter().map(|c| d.join(c)));
            files.extend(m.baro.iter().map(|b| d.join(&b.file)));
        }
        if let Ok(entries) = fs::read_dir(d.join(TRUTH_DIR)) {
            let mut truth: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
            truth.sort();
            files.extend(truth);
        }
        files.extend(self.config_file.map(Path::to_path_buf));
        files.extend(self.calibration_file.map(Path::to_path_buf));
        files.retain(|f| f.is_file());
        files
    }
}

/// The options of a run as the manifest records them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestOptions {
    /// The calibration file used instead of the dataset's, if any.
    pub calibration_file: Option<PathBuf>,
    /// No chain calibration at all (`--no-calibration`).
    pub no_calibration: bool,
}

/// `run.json`: what produced the run directory and what it holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunManifest {
    /// The version of wins that wrote it.
    pub wins_version: String,
    /// `false` while the run is being written: a folder left so was interrupted.
    pub complete: bool,
    /// The dataset folder (canonical).
    pub dataset: PathBuf,
    /// The input files read (canonical).
    pub inputs: Vec<PathBuf>,
    /// The settings file, or `"defaults"`.
    pub config_file: String,
    /// The effective settings.
    pub config: Config,
    /// The run's options.
    pub options: ManifestOptions,
    /// Whether the estimate was written.
    pub estimate: bool,
    /// The evaluation against the truth: `"ok"`, `"no truth"`, `"not scored: …"` (it never
    /// converged, say) or `"failed: …"` (the truth cannot be read), as
    /// [`super::run_output::Evaluation`] prints.
    pub evaluation: String,
    /// The files of the folder the run wrote, by name (without `run.json`).
    pub files: Vec<String>,
}

/// `path` canonical when it can be, else as given.
fn canonical(path: &Path) -> PathBuf {
    resolve(path).unwrap_or_else(|_| path.to_path_buf())
}

impl RunManifest {
    /// The manifest of a run of `inputs` with `config`, before it has written anything.
    pub fn new(inputs: &RunInputs<'_>, config: &Config, no_calibration: bool) -> Self {
        Self {
            wins_version: env!("CARGO_PKG_VERSION").to_string(),
            complete: false,
            dataset: canonical(inputs.dataset),
            inputs: inputs.files().iter().map(|f| canonical(f)).collect(),
            config_file: inputs.config_file.map_or_else(
                || "defaults".to_string(),
                |f| canonical(f).display().to_string(),
            ),
            config: config.clone(),
            options: ManifestOptions {
                calibration_file: inputs.calibration_file.map(canonical),
                no_calibration,
            },
            estimate: false,
            evaluation: "pending".to_string(),
            files: Vec::new(),
        }
    }

    /// Records what `run` completed: the estimate, and the evaluation's outcome.
    pub fn record(&mut self, run: &RunOutput) {
        self.estimate = true;
        self.evaluation = run.evaluation.to_string();
    }
}

/// A checked output folder ([`RunDir::prepare`]), with the files of the previous run in it.
#[derive(Clone, Debug)]
pub struct RunDir {
    path: PathBuf,
    previous: Vec<String>,
}

impl RunDir {
    /// Checks `out` before any work: it does not overlap `inputs`, it is created and writable,
    /// and it is empty or a previous run's (module docs).
    pub fn prepare(out: &Path, inputs: &RunInputs<'_>) -> Result<Self, OutputError> {
        let files = inputs.files();
        let mut all: Vec<&Path> = vec![inputs.dataset];
        all.extend(inputs.config_file);
        all.extend(inputs.calibration_file);
        all.extend(files.iter().map(PathBuf::as_path));
        refuse_overlap(out, &all)?;
        check_writable_dir(out)?;
        let previous = previous_files(out)?;
        Ok(Self {
            path: out.to_path_buf(),
            previous,
        })
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Removes the previous run's files (those its manifest lists, temporary files of an
    /// interrupted write, and spool files of another process's interrupted run), then writes `manifest` with `"complete": false` and every file the
    /// run may write.
    pub fn start(&self, manifest: &RunManifest) -> Result<(), OutputError> {
        let temporaries = fs::read_dir(&self.path)
            .map_err(OutputError::io(&self.path))?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(TEMP_PREFIX) || is_stale_spool(n));
        let stale: Vec<String> = self.previous.iter().cloned().chain(temporaries).collect();
        for name in &stale {
            let mut parts = Path::new(name).components();
            let plain = matches!(
                (parts.next(), parts.next()),
                (Some(Component::Normal(_)), None)
            );
            let path = self.path.join(name);
            let is_file = fs::symlink_metadata(&path).is_ok_and(|m| m.is_file());
            if plain && is_file && name != MANIFEST_FILE {
                fs::remove_file(&path).map_err(OutputError::io(&path))?;
            }
        }
        let mut pending = manifest.clone();
        pending.complete = false;
        pending.files = RUN_FILES.iter().map(|f| f.to_string()).collect();
        self.write_manifest(&pending)
    }

    /// Writes `manifest` last, with `"complete": true` and `written` (paths in the folder) as
    /// its files; returns the manifest's path.
    pub fn finish(
        &self,
        manifest: &RunManifest,
        written: &[PathBuf],
    ) -> Result<PathBuf, OutputError> {
        let mut done = manifest.clone();
        done.complete = true;
        done.files = written
            .iter()
            .filter_map(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .collect();
        self.write_manifest(&done)?;
        Ok(self.path.join(MANIFEST_FILE))
    }

    fn write_manifest(&self, manifest: &RunManifest) -> Result<(), OutputError> {
        let path = self.path.join(MANIFEST_FILE);
        let text = serde_json::to_string_pretty(manifest).map_err(|e| OutputError::Io {
            path: path.clone(),
            source: e.into(),
        })?;
        write_atomically(&path, |w| {
            use std::io::Write;
            writeln!(w, "{text}")
        })
        .map_err(OutputError::io(&path))
    }
}

/// The files the manifest of the run in `out` lists: none when `out` is empty; refused when it
/// holds files but no manifest, or a manifest that cannot be read.
fn previous_files(out: &Path) -> Result<Vec<String>, OutputError> {
    let entries = fs::read_dir(out).map_err(OutputError::io(out))?;
    // A folder that holds only what an interrupted run left behind counts as empty.
    let leftover = |n: &str| n.starts_with(TEMP_PREFIX) || is_stale_spool(n);
    let mut entries = entries
        .flatten()
        .filter(|e| !leftover(&e.file_name().to_string_lossy()));
    if entries.next().is_none() {
        return Ok(Vec::new());
    }
    let path = out.join(MANIFEST_FILE);
    if !path.is_file() {
        return Err(OutputError::NotARunDir {
            path: out.to_path_buf(),
            manifest: MANIFEST_FILE,
        });
    }
    /// The one part of any manifest version this needs.
    #[derive(Deserialize)]
    struct Listed {
        files: Vec<String>,
    }
    let text = fs::read_to_string(&path).map_err(OutputError::io(&path))?;
    let listed: Listed = serde_json::from_str(&text).map_err(|e| OutputError::BadManifest {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    Ok(listed.files)
}

/// Whether `name` is a spool file ([`super::spool`]) of another process than this one.
fn is_stale_spool(name: &str) -> bool {
    name.starts_with(SPOOL_PREFIX)
        && !name.starts_with(&format!("{SPOOL_PREFIX}{}-", std::process::id()))
}

#[cfg(test)]
mod tests;
