//! A run's per-frame and per-packet files written as the replay produces them ([`Spool`]), so
//! a long flight's run does not hold them: the trajectories, the covariances and the packet log
//! go to hidden files in the output folder, renamed into place by
//! [`super::run_output::RunOutput::write`] (removed when the run is dropped without being
//! written). What the scoring reads goes to two
//! more, binary, files (`ScoringSpool`): per converged frame its pose and position covariance,
//! per fed packet its AoA.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::drive::RunSink;
use super::output::{
    AOA_FILE, COVARIANCE_FILE, TRAJECTORY_ALL_FILE, TRAJECTORY_FILE, TRAJECTORY_SENT_FILE,
    write_covariance_header, write_covariance_row,
};
use super::spooled::SpoolFiles;
pub use super::spooled::Spooled;
use super::trajectory::{TrajectoryWriter, pose_of};
use crate::eval::records::{AoaRecord, EstRecord, RecordWriter};
use crate::eval::scan::TrajectoryScan;
use crate::fusion::pose::PoseEstimate;
use crate::pipeline::{PacketLog, PacketStatus};

/// Prefix of a spool file in the output folder.
pub const SPOOL_PREFIX: &str = ".wins-spool-";

/// What scoring reads of a spooled run, in three more spool files (removed when this is
/// dropped): per converged frame its pose and position covariance, the same of the frames sent,
/// per fed packet its AoA ([`crate::eval::records`]).
#[derive(Debug)]
pub(crate) struct ScoringSpool {
    /// The converged frames' records.
    pub(crate) est_path: PathBuf,
    /// What one pass over them found.
    pub(crate) est_scan: TrajectoryScan,
    /// The sent frames' records.
    pub(crate) sent_path: PathBuf,
    /// What one pass over them found.
    pub(crate) sent_scan: TrajectoryScan,
    /// The fed packets' records.
    pub(crate) aoa_path: PathBuf,
    /// How many.
    pub(crate) aoa_count: usize,
}

impl Drop for ScoringSpool {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.est_path);
        let _ = std::fs::remove_file(&self.sent_path);
        let _ = std::fs::remove_file(&self.aoa_path);
    }
}

/// The writers of a [`ScoringSpool`].
#[derive(Debug)]
struct ScoringWriters {
    files: ScoringSpool,
    est: RecordWriter<BufWriter<File>>,
    sent: RecordWriter<BufWriter<File>>,
    aoa: RecordWriter<BufWriter<File>>,
}

/// A [`RunSink`] writing the per-frame and per-packet files as they come.
#[derive(Debug)]
pub struct Spool {
    trajectory: TrajectoryWriter<File>,
    covariance: BufWriter<File>,
    trajectory_all: TrajectoryWriter<File>,
    trajectory_sent: TrajectoryWriter<File>,
    aoa: csv::Writer<BufWriter<File>>,
    kept: Spooled,
    scoring: Option<ScoringWriters>,
}

impl Spool {
    /// Spool files in `dir` (created if needed), named after this process; `for_scoring`: write
    /// what scoring reads too (two binary files). The run holds nothing per frame or packet.
    pub fn create(dir: &Path, for_scoring: bool) -> io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let names = [
            TRAJECTORY_FILE,
            COVARIANCE_FILE,
            TRAJECTORY_ALL_FILE,
            TRAJECTORY_SENT_FILE,
            AOA_FILE,
        ];
        let id = std::process::id();
        let files = SpoolFiles {
            files: names
                .iter()
                .map(|name| (dir.join(format!("{SPOOL_PREFIX}{id}-{name}")), *name))
                .collect(),
        };
        // The trajectories buffer their own lines.
        let file = |k: usize| File::create(&files.files[k].0);
        let open = |k: usize| file(k).map(BufWriter::new);
        let (trajectory, mut covariance, trajectory_all) = (file(0)?, open(1)?, file(2)?);
        let trajectory_sent = TrajectoryWriter::new(file(3)?)?;
        let aoa = csv::Writer::from_writer(open(4)?);
        let trajectory = TrajectoryWriter::new(trajectory)?;
        write_covariance_header(&mut covariance)?;
        let trajectory_all = TrajectoryWriter::new(trajectory_all)?;
        let scoring = for_scoring
            .then(|| {
                let path = |name: &str| dir.join(format!("{SPOOL_PREFIX}{id}-{name}"));
                let files = ScoringSpool {
                    est_path: path("eval-poses.bin"),
                    est_scan: TrajectoryScan::default(),
                    sent_path: path("eval-sent.bin"),
                    sent_scan: TrajectoryScan::default(),
                    aoa_path: path("eval-aoa.bin"),
                    aoa_count: 0,
                };
                let create =
                    |p: &Path| File::create(p).map(|f| RecordWriter::new(BufWriter::new(f)));
                Ok::<_, io::Error>(ScoringWriters {
                    est: create(&files.est_path)?,
                    sent: create(&files.sent_path)?,
                    aoa: create(&files.aoa_path)?,
                    files,
                })
            })
            .transpose()?;
        Ok(Self {
            trajectory,
            covariance,
            trajectory_all,
            trajectory_sent,
            aoa,
            kept: Spooled {
                files: Some(Arc::new(files)),
                ..Spooled::default()
            },
            scoring,
        })
    }

    /// Flushes the files; what the run keeps of them.
    pub fn finish(self) -> io::Result<Spooled> {
        self.finish_with_scoring().map(|(kept, _)| kept)
    }

    /// [`Spool::finish`], with what scoring reads when it was asked for.
    pub(crate) fn finish_with_scoring(mut self) -> io::Result<(Spooled, Option<ScoringSpool>)> {
        self.trajectory.flush()?;
        self.covariance.flush()?;
        self.trajectory_all.flush()?;
        self.trajectory_sent.flush()?;
        self.aoa.flush()?;
        let scoring = match self.scoring {
            Some(mut w) => {
                w.est.flush()?;
                w.sent.flush()?;
                w.aoa.flush()?;
                w.files.aoa_count = w.aoa.written();
                Some(w.files)
            }
            None => None,
        };
        Ok((self.kept, scoring))
    }
}

/// The scoring's record of a frame: a converged one's pose and position covariance.
pub(crate) fn est_record(frame: &PoseEstimate) -> Option<EstRecord> {
    frame.converged.then(|| EstRecord {
        pose: pose_of(frame),
        position_covariance: frame
            .covariance
            .map(|c| c.fixed_view::<3, 3>(3, 3).into_owned()),
    })
}

/// The scoring's record of a packet row: a fed packet's AoA.
pub(crate) fn aoa_record(row: &PacketLog) -> Option<AoaRecord> {
    (row.status == PacketStatus::Fed).then_some(AoaRecord {
        ap: row.ap,
        t_ns: row.t_ns,
        aoa_deg: row.aoa_deg,
    })
}

impl RunSink for Spool {
    fn frame(&mut self, frame: PoseEstimate, sent: bool) -> io::Result<()> {
        let pose = pose_of(&frame);
        self.trajectory_all.pose(&pose)?;
        self.kept.frames += 1;
        if frame.converged {
            self.trajectory.pose(&pose)?;
            write_covariance_row(&mut self.covariance, &frame)?;
            self.kept.frames_converged += 1;
        }
        if sent {
            self.trajectory_sent.pose(&pose)?;
            self.kept.frames_sent += 1;
        }
        if let Some(w) = &mut self.scoring
            && let Some(record) = est_record(&frame)
        {
            w.files.est_scan.push(&pose);
            w.est.push(&record)?;
            if sent {
                w.files.sent_scan.push(&pose);
                w.sent.push(&record)?;
            }
        }
        Ok(())
    }

    fn packet(&mut self, row: PacketLog) -> io::Result<()> {
        self.aoa.serialize(&row).map_err(io::Error::other)?;
        if let Some(w) = &mut self.scoring
            && let Some(record) = aoa_record(&row)
        {
            w.aoa.push(&record)?;
        }
        Ok(())
    }
}
