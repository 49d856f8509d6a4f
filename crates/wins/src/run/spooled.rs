//! What a spooled run keeps of its spool files ([`Spooled`]): counts, and the files to rename
//! into place, removed when the last holder drops them unless they were ([`super::spool`]
//! writes them).

use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The spool files, removed when the last holder drops them unless they were renamed into place.
#[derive(Debug)]
pub(super) struct SpoolFiles {
    /// (spool file, final name), in the order [`super::output`] lists them.
    pub(super) files: Vec<(PathBuf, &'static str)>,
}

impl Drop for SpoolFiles {
    fn drop(&mut self) {
        for (path, _) in &self.files {
            // Gone already when renamed into place.
            let _ = std::fs::remove_file(path);
        }
    }
}

/// What a spooled run keeps: counts, and the files to rename into place.
#[derive(Clone, Debug, Default)]
pub struct Spooled {
    /// Frames solved.
    pub frames: usize,
    /// Frames after convergence.
    pub frames_converged: usize,
    /// Frames a flight controller is sent.
    pub frames_sent: usize,
    /// The most poses the scoring against a truth held at once, of the estimate and the truth
    /// together (0 when not scored): it reads both trajectories from files in passes, so this
    /// does not grow with the flight.
    pub scoring_poses_held: usize,
    pub(super) files: Option<Arc<SpoolFiles>>,
}

impl Spooled {
    /// Renames the spool files into `dir` (the folder they were spooled in) under their final
    /// names; returns the paths, in [`super::output`]'s order.
    pub fn persist(&self, dir: &Path) -> io::Result<Vec<PathBuf>> {
        let Some(files) = &self.files else {
            return Err(io::Error::other("the run's spool files are gone"));
        };
        let mut out = Vec::new();
        for (path, name) in &files.files {
            let target = dir.join(name);
            std::fs::rename(path, &target)?;
            out.push(target);
        }
        Ok(out)
    }
}
