//! The files of a run directory and the scoring of a run against a dataset's truth.
//!
//! | file | content |
//! |---|---|
//! | `trajectory.tum` | body poses in `w` at every frame after convergence (TUM: `t x y z qx qy qz qw`) |
//! | `trajectory_all.tum` | the same from the first frame (before convergence `w` is not yet fixed) |
//! | `trajectory_sent.tum` | the poses a flight controller is sent, as `wins live` sends them: the causal estimate ([`crate::pipeline::Released::is_sent`]) |
//! | `covariance.csv` | the covariance reported with each pose of `trajectory.tum` ([`write_covariance`]) |
//! | `aps.csv` | estimated AP positions in `w` (`crate::eval::aps` format) |
//! | `aoa.csv` | one row per packet ([`crate::pipeline::PacketLog`]) |
//! | `stats.json` | packets used/dropped per AP and why, estimator counters, per-stage wall time |
//! | `metrics.json`, `report.txt` | with a truth only: [`crate::eval::Metrics`] and its text |
//!
//! Each file is written to a temporary file beside it and renamed into place
//! ([`crate::io_safety::write_atomically`]): a failure or a crash never leaves half a file. The
//! run's manifest, `run.json`, and the refusals of an output folder that overlaps the inputs are
//! [`super::run_dir`]'s.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::run_output::RunOutput;
use super::trajectory::{TrajectoryWriter, pose_of};
use crate::dataset::checks::InputReport;
use crate::dataset::truth::{Pose, write_csv};
use crate::eval::{EstimatedAp, Metrics, write_estimated_aps};
use crate::fusion::nonlinear::PhaseChange;
use crate::fusion::pose::PoseEstimate;
use crate::fusion::stats::EstimatorStats;
use crate::io_safety::write_atomically;
use crate::pipeline::{ChainReport, PipelineStats, StageTiming};
use crate::time::NANOS_PER_SEC;

/// Converged trajectory file.
pub const TRAJECTORY_FILE: &str = "trajectory.tum";
/// Whole trajectory file.
pub const TRAJECTORY_ALL_FILE: &str = "trajectory_all.tum";
/// The poses a flight controller is sent, as `wins live` sends them (the causal estimate).
pub const TRAJECTORY_SENT_FILE: &str = "trajectory_sent.tum";
/// Covariance of the converged poses.
pub const COVARIANCE_FILE: &str = "covariance.csv";
/// Estimated APs.
pub const APS_FILE: &str = "aps.csv";
/// Per-packet AoA log.
pub const AOA_FILE: &str = "aoa.csv";
/// Run statistics.
pub const STATS_FILE: &str = "stats.json";
/// Metrics against the truth.
pub const METRICS_FILE: &str = "metrics.json";
/// Text report.
pub const REPORT_FILE: &str = "report.txt";

/// A packet's AoA is paired with the truth packet nearest in time within this, ns (the NIC
/// clock has 1 µs resolution).
pub(crate) const TRUTH_PAIR_NS: i64 = 1_000;

/// `stats.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RunStats<'a> {
    /// Flight time replayed, s.
    pub flight_s: f64,
    /// Wall time of the replay, s.
    pub wall_s: f64,
    /// `flight_s / wall_s`.
    pub realtime_factor: f64,
    /// Convergence, s on the IMU clock (null if never).
    pub converged_at_s: Option<f64>,
    /// The first pose a flight controller is sent, s on the IMU clock (null if none).
    pub first_sent_at_s: Option<f64>,
    /// Frames solved / after convergence.
    pub frames: usize,
    /// Frames after convergence.
    pub frames_converged: usize,
    /// Frames a flight controller is sent (`trajectory_sent.tum`).
    pub frames_sent: usize,
    /// Wall time per stage, s.
    pub timing: StageTiming,
    /// Packets per AP and why they were dropped.
    pub packets: &'a PipelineStats,
    /// The estimator's counters.
    pub estimator: EstimatorStats,
    /// The estimator's phases (at rest, starting, tracking, recovering): when each began, s on
    /// the IMU clock, and why.
    pub phases: &'a [PhaseChange],
    /// IMU samples refused.
    pub imu_refused: u64,
    /// How the receive chains' offsets were resolved from the flight.
    pub chain_offsets: &'a ChainReport,
    /// What the input checks dropped, counted and found.
    pub inputs: &'a InputReport,
    /// How much of the flight after convergence the poses cover, and its gaps.
    pub coverage: &'a super::coverage::Coverage,
    /// What limits the result, in words.
    pub warnings: &'a [String],
}

impl RunOutput {
    /// Poses after convergence, as [`Pose`]s (none for a spooled run: they are in its files).
    pub fn converged_poses(&self) -> Vec<Pose> {
        self.converged_frames().map(pose_of).collect()
    }

    /// The AP estimates in the evaluation's format.
    pub fn estimated_aps(&self) -> Vec<EstimatedAp> {
        self.aps
            .iter()
            .map(|a| EstimatedAp::with_covariance(&a.name, &a.p_in_w, &a.covariance_in_w))
            .collect()
    }

    /// `stats.json`'s content.
    pub fn run_stats(&self) -> RunStats<'_> {
        RunStats {
            flight_s: self.flight_s,
            wall_s: self.wall_s,
            realtime_factor: self.realtime_factor(),
            converged_at_s: self.converged_at.map(|t| t.as_secs_f64()),
            first_sent_at_s: self.first_sent.map(|t| t.as_secs_f64()),
            frames: self
                .spooled
                .as_ref()
                .map_or(self.frames.len(), |s| s.frames),
            frames_converged: self
                .spooled
                .as_ref()
                .map_or_else(|| self.converged_frames().count(), |s| s.frames_converged),
            frames_sent: self
                .spooled
                .as_ref()
                .map_or_else(|| self.sent_frames().count(), |s| s.frames_sent),
            timing: self.timing,
            packets: &self.stats,
            estimator: self.wins,
            phases: &self.phases,
            imu_refused: self.imu_refused,
            chain_offsets: &self.chains,
            inputs: &self.inputs,
            coverage: &self.coverage,
            warnings: &self.warnings,
        }
    }
}

impl RunOutput {
    /// Writes the run directory's data files (the folder is created if needed): the
    /// trajectories, APs, packet log and statistics, and with `metrics` the metrics and the
    /// report, each atomically; returns the files written. The manifest and the removal of a
    /// previous run's files are [`super::run_dir::RunDir`]'s.
    pub fn write(&self, dir: &Path) -> io::Result<Vec<PathBuf>> {
        write_run(dir, self, self.metrics.as_ref())
    }
}

fn write_run(dir: &Path, run: &RunOutput, metrics: Option<&Metrics>) -> io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut written = Vec::new();
    let mut put =
        |name: &str, f: &mut dyn FnMut(&mut io::BufWriter<std::fs::File>) -> io::Result<()>| {
            let path = dir.join(name);
            write_atomically(&path, f)?;
            written.push(path);
            Ok::<(), io::Error>(())
        };
    // Spooled: the trajectories, covariances and packet log are there already.
    let spooled = match &run.spooled {
        Some(s) => s.persist(dir)?,
        None => Vec::new(),
    };
    if spooled.is_empty() {
        put(TRAJECTORY_FILE, &mut |w| {
            let mut tum = TrajectoryWriter::new(w)?;
            tum.frames(run.converged_frames())?;
            tum.finish().map(drop)
        })?;
        put(COVARIANCE_FILE, &mut |w| {
            write_covariance(w, run.converged_frames())
        })?;
        put(TRAJECTORY_ALL_FILE, &mut |w| {
            let mut tum = TrajectoryWriter::new(w)?;
            tum.frames(&run.frames)?;
            tum.finish().map(drop)
        })?;
        put(TRAJECTORY_SENT_FILE, &mut |w| {
            let mut tum = TrajectoryWriter::new(w)?;
            tum.frames(run.sent_frames())?;
            tum.finish().map(drop)
        })?;
    }
    put(APS_FILE, &mut |w| {
        write_estimated_aps(w, &run.estimated_aps())
    })?;
    if spooled.is_empty() {
        put(AOA_FILE, &mut |w| write_csv(w, &run.packets))?;
    }
    let stats = serde_json::to_string_pretty(&run.run_stats()).map_err(io::Error::other)?;
    put(STATS_FILE, &mut |w| writeln!(w, "{stats}"))?;
    if let Some(m) = metrics {
        let text = serde_json::to_string_pretty(m).map_err(io::Error::other)?;
        put(METRICS_FILE, &mut |w| writeln!(w, "{text}"))?;
        put(REPORT_FILE, &mut |w| w.write_all(m.report().as_bytes()))?;
    }
    // The files in the order of the module's table: the spooled packet log after the APs.
    let mut all = spooled;
    let aoa = (all.len() == 5).then(|| all.pop()).flatten();
    let mut rest = written.into_iter();
    all.extend(rest.next());
    all.extend(aoa);
    all.extend(rest);
    Ok(all)
}

/// The names of the six error-state components of [`write_covariance`]'s columns.
const COVARIANCE_AXES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

/// One row per pose: `t_s` (as in the TUM file), then the upper triangle, row by row, of the
/// 6 × 6 covariance of `[δp, δθ]` (21 columns `c_x_x, c_x_y, …, c_rz_rz`: the order of
/// MAVLink `ODOMETRY.pose_covariance`): position in `w`, m², and the attitude error on the
/// body side (`R = R̂·Exp(δθ)`), rad². A pose without a covariance has empty cells.
pub fn write_covariance<'a>(
    out: &mut impl Write,
    poses: impl Iterator<Item = &'a PoseEstimate>,
) -> io::Result<()> {
    write_covariance_header(out)?;
    for p in poses {
        write_covariance_row(out, p)?;
    }
    Ok(())
}

/// The header line of [`write_covariance`].
pub fn write_covariance_header(out: &mut impl Write) -> io::Result<()> {
    let mut header = vec!["t_s".to_string()];
    header.extend(
        UPPER
            .iter()
            .map(|&(i, j)| format!("c_{}_{}", COVARIANCE_AXES[i], COVARIANCE_AXES[j])),
    );
    writeln!(out, "{}", header.join(","))
}

/// One row of [`write_covariance`].
pub fn write_covariance_row(out: &mut impl Write, p: &PoseEstimate) -> io::Result<()> {
    // The estimate's order is [δθ, δp]: the position block first here.
    let order = [3, 4, 5, 0, 1, 2];
    let t = p.t.as_nanos();
    let mut row = vec![format!(
        "{}.{:09}",
        t.div_euclid(NANOS_PER_SEC),
        t.rem_euclid(NANOS_PER_SEC)
    )];
    row.extend(UPPER.iter().map(|&(i, j)| {
        p.covariance
            .map_or(String::new(), |c| format!("{:e}", c[(order[i], order[j])]))
    }));
    writeln!(out, "{}", row.join(","))
}

/// The upper triangle of a 6 × 6 matrix, row by row: (i, j) for i ≤ j.
const UPPER: [(usize, usize); 21] = {
    let mut out = [(0, 0); 21];
    let (mut i, mut k) = (0, 0);
    while i < 6 {
        let mut j = i;
        while j < 6 {
            out[k] = (i, j);
            k += 1;
            j += 1;
        }
        i += 1;
    }
    out
};
