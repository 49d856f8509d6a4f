//! A run's per-frame and per-packet files written as the replay produces them ([`Spool`]), so
//! a long flight's run does not hold them: the trajectories, the covariances and the packet log
//! go to hidden files in the output folder, renamed into place by [`super::replay::RunOutput::write`]
//! (removed when the run is dropped without being written). What the scoring needs is kept in
//! compact form ([`Spooled`]): per converged frame its pose and position covariance, per fed
//! packet its AoA.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Matrix3;

use super::drive::RunSink;
use super::output::{
    AOA_FILE, COVARIANCE_FILE, TRAJECTORY_ALL_FILE, TRAJECTORY_FILE, write_covariance_header,
    write_covariance_row,
};
use super::{PacketLog, PacketStatus};
use crate::dataset::truth::{Pose, write_tum_header, write_tum_pose};
use crate::fusion::estimator::PoseEstimate;

/// Prefix of a spool file in the output folder.
pub const SPOOL_PREFIX: &str = ".wins-spool-";

/// The spool files, removed when the last holder drops them unless they were renamed into place.
#[derive(Debug)]
struct SpoolFiles {
    /// (spool file, final name), in the order [`super::output`] lists them.
    files: Vec<(PathBuf, &'static str)>,
}

impl Drop for SpoolFiles {
    fn drop(&mut self) {
        for (path, _) in &self.files {
            // Gone already when renamed into place.
            let _ = std::fs::remove_file(path);
        }
    }
}

/// What a spooled run keeps: counts, the converged poses and what scoring reads of them and of
/// the packets.
#[derive(Clone, Debug, Default)]
pub struct Spooled {
    /// Frames solved.
    pub frames: usize,
    /// Frames after convergence.
    pub frames_converged: usize,
    /// Whether the poses, covariances and AoAs below are kept (for scoring against a truth).
    pub kept_for_scoring: bool,
    /// The poses after convergence.
    pub converged: Vec<Pose>,
    /// Their position covariance in `w`, m² (`None`: none given).
    pub position_covariance: Vec<Option<Matrix3<f64>>>,
    /// Per fed packet: AP, time ns, measured AoA °.
    pub fed_aoa: Vec<(usize, i64, Option<f64>)>,
    files: Option<Arc<SpoolFiles>>,
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

/// A [`RunSink`] writing the per-frame and per-packet files as they come.
#[derive(Debug)]
pub struct Spool {
    trajectory: BufWriter<File>,
    covariance: BufWriter<File>,
    trajectory_all: BufWriter<File>,
    aoa: csv::Writer<BufWriter<File>>,
    kept: Spooled,
}

impl Spool {
    /// Spool files in `dir` (created if needed), named after this process; `for_scoring`: keep
    /// what scoring reads ([`Spooled`]; without it the run holds nothing per frame or packet).
    pub fn create(dir: &Path, for_scoring: bool) -> io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let names = [
            TRAJECTORY_FILE,
            COVARIANCE_FILE,
            TRAJECTORY_ALL_FILE,
            AOA_FILE,
        ];
        let id = std::process::id();
        let files = SpoolFiles {
            files: names
                .iter()
                .map(|name| (dir.join(format!("{SPOOL_PREFIX}{id}-{name}")), *name))
                .collect(),
        };
        let open = |k: usize| File::create(&files.files[k].0).map(BufWriter::new);
        let (mut trajectory, mut covariance, mut trajectory_all) = (open(0)?, open(1)?, open(2)?);
        let aoa = csv::Writer::from_writer(open(3)?);
        write_tum_header(&mut trajectory)?;
        write_covariance_header(&mut covariance)?;
        write_tum_header(&mut trajectory_all)?;
        Ok(Self {
            trajectory,
            covariance,
            trajectory_all,
            aoa,
            kept: Spooled {
                kept_for_scoring: for_scoring,
                files: Some(Arc::new(files)),
                ..Spooled::default()
            },
        })
    }

    /// Flushes the files; what the run keeps of them.
    pub fn finish(mut self) -> io::Result<Spooled> {
        self.trajectory.flush()?;
        self.covariance.flush()?;
        self.trajectory_all.flush()?;
        self.aoa.flush()?;
        Ok(self.kept)
    }
}

impl RunSink for Spool {
    fn frame(&mut self, frame: PoseEstimate) -> io::Result<()> {
        let pose = Pose {
            t: frame.t,
            p_b_in_w: frame.p_b_in_w,
            world_from_body: frame.world_from_body,
        };
        write_tum_pose(&mut self.trajectory_all, &pose)?;
        self.kept.frames += 1;
        if frame.converged {
            write_tum_pose(&mut self.trajectory, &pose)?;
            write_covariance_row(&mut self.covariance, &frame)?;
            self.kept.frames_converged += 1;
            if !self.kept.kept_for_scoring {
                return Ok(());
            }
            self.kept.converged.push(pose);
            self.kept.position_covariance.push(
                frame
                    .covariance
                    .map(|c| c.fixed_view::<3, 3>(3, 3).into_owned()),
            );
        }
        Ok(())
    }

    fn packet(&mut self, row: PacketLog) -> io::Result<()> {
        self.aoa.serialize(&row).map_err(io::Error::other)?;
        if self.kept.kept_for_scoring && row.status == PacketStatus::Fed {
            self.kept.fed_aoa.push((row.ap, row.t_ns, row.aoa_deg));
        }
        Ok(())
    }
}
