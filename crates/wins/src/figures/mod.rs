//! The figures' data of a run, made from the files the run wrote ([`RunFigures::from_files`]),
//! so that every run is drawn alike whether it has a truth or not, was spooled or held in
//! memory, and `wins eval` of a run's trajectory draws the same: the track from above with the
//! APs and their 2σ ellipses, the height (with the barometer's), the attitude, the AoA per AP
//! with the packets that were dropped, the position σ over time, and the events (convergence,
//! losses, starts again); with a truth, the truth beside each and the position error per axis
//! within its ±σ band. Only numbers: drawing is the caller's (the CLI uses `wins-plot`).
//!
//! A gap is a gap: converged poses further apart than [`POSE_GAP_S`] (the coverage's gap) are
//! split by a point with NaN coordinates, which a line plot breaks at.

mod against_truth;
mod read;
#[cfg(test)]
mod tests;

use std::path::Path;

use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector3};

pub use against_truth::TruthFigures;
use read::RunFiles;

use crate::dataset::truth::{Pose, TRUTH_DIR, Truth};
use crate::eval::{EvalError, EvalOptions};
use crate::run::coverage::POSE_GAP_S;
use crate::run::output::TRAJECTORY_FILE;
use crate::time::Timestamp;

/// Points of a series, `(x, y)`; a point with NaN coordinates is a gap.
pub type Points = Vec<(f64, f64)>;

/// The gap point of [`Points`].
pub const GAP: (f64, f64) = (f64::NAN, f64::NAN);

/// Besides the poses paired with the estimate's, the truth's drawn every this, ns.
const TRUTH_DRAWN_EVERY_NS: i64 = 100_000_000;

/// Points on an AP's ellipse.
const ELLIPSE_POINTS: usize = 48;

/// An AP on the map.
#[derive(Clone, Debug, PartialEq)]
pub struct ApFigure {
    /// Its name.
    pub name: String,
    /// Where it was placed, (x, y) m.
    pub xy: (f64, f64),
    /// The 2σ ellipse of its horizontal position (a closed line; empty when the run gave no
    /// covariance).
    pub ellipse_2sigma: Points,
}

/// One AP's AoA over time.
#[derive(Clone, Debug, PartialEq)]
pub struct AoaFigure {
    /// The AP's name.
    pub name: String,
    /// Packets fed to the estimator: (time s, AoA degrees).
    pub fed: Points,
    /// Packets dropped with an AoA (gated, off the track, ...): where they were, same axes.
    pub dropped: Points,
    /// Packets dropped without an AoA (no credible peak, ...): at the AoA the IMU predicted,
    /// when there was one.
    pub dropped_without_aoa: Points,
    /// The truth's direct-path AoA of each packet slot (empty without a truth).
    pub truth: Points,
}

/// What happened to the estimate, marked on the plots over time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// The estimate converged (the first accepted window).
    Converged,
    /// The estimate was lost (its window failed), and a start began again.
    Lost,
    /// Accepted again after a loss.
    Recovered,
}

impl EventKind {
    /// Its label on a plot.
    pub fn label(self) -> &'static str {
        match self {
            Self::Converged => "converged",
            Self::Lost => "lost",
            Self::Recovered => "accepted again",
        }
    }
}

/// An [`EventKind`] at a time, s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// When, s on the IMU clock.
    pub t_s: f64,
    /// What.
    pub kind: EventKind,
}

/// The figures' data (module doc). Times are s on the IMU clock; positions and attitudes are
/// in the estimate's world frame, or in the truth's after the alignment when there is a truth.
#[derive(Clone, Debug, PartialEq)]
pub struct RunFigures {
    /// The converged track from above, (x, y) m.
    pub track_xy: Points,
    /// Height of the converged poses, (s, z m).
    pub height: Points,
    /// The barometer's altitude, shifted by its mean difference to the estimated height (empty
    /// without a barometer).
    pub baro_height: Points,
    /// Roll, pitch and yaw of the converged poses, (s, degrees); yaw is broken where it wraps.
    pub attitude_deg: [Points; 3],
    /// The position's σ along x, y and z over time, (s, m) (empty without `covariance.csv`).
    pub sigma_m: [Points; 3],
    /// The APs the run placed.
    pub aps: Vec<ApFigure>,
    /// The AoA per AP (empty without the run's `aoa.csv`).
    pub aoa: Vec<AoaFigure>,
    /// Convergence, losses, recoveries (from the run's `stats.json`).
    pub events: Vec<Event>,
    /// With a truth: the truth and the errors.
    pub truth: Option<TruthFigures>,
}

/// Why a run's figures cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// A file of the run cannot be read.
    #[error("{path}: {reason}")]
    File {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// The estimate cannot be aligned to the truth.
    #[error("aligning the estimate to the truth: {0}")]
    Align(#[from] EvalError),
}

impl RunFigures {
    /// The figures of the run whose trajectory (TUM) is `trajectory`, with the files beside it
    /// when they are there (`covariance.csv`, `aps.csv`, `aoa.csv`, `stats.json`, as `wins run`
    /// writes them), the barometer of `dataset` when given, and `truth` when given (aligned as
    /// the metrics are, by `options`).
    ///
    /// Errors: the trajectory cannot be read, a file beside it is malformed, or the estimate
    /// cannot be aligned to the truth.
    pub fn from_files(
        trajectory: &Path,
        dataset: Option<&Path>,
        truth: Option<&Truth>,
        options: &EvalOptions,
    ) -> Result<Self, FigureError> {
        Self::of_files(&RunFiles::read(trajectory, dataset)?, truth, options)
    }

    /// [`RunFigures::from_files`] of the files read.
    fn of_files(
        files: &RunFiles,
        truth: Option<&Truth>,
        options: &EvalOptions,
    ) -> Result<Self, FigureError> {
        let aligned = match truth {
            Some(t) => Some(against_truth::Aligned::new(files, t, options)?),
            None => None,
        };
        let rotation = aligned
            .as_ref()
            .map_or(Matrix3::identity(), |a| a.rotation());
        let to_frame = |p: &Vector3<f64>| aligned.as_ref().map_or(*p, |a| a.point(p));
        let poses: Vec<Pose> = files
            .poses
            .iter()
            .map(|p| aligned.as_ref().map_or(*p, |a| a.pose(p)))
            .collect();
        let breaks = gaps(&poses);
        let series = |f: &dyn Fn(&Pose) -> (f64, f64)| with_gaps(&poses, &breaks, f);
        let height = series(&|p| (p.t.as_secs_f64(), p.p_b_in_w.z));
        let attitude_deg = [0, 1, 2].map(|k| {
            let angles = series(&|p| (p.t.as_secs_f64(), euler_deg(&p.world_from_body)[k]));
            if k == 2 { break_wraps(angles) } else { angles }
        });
        let sigma_m = [0, 1, 2].map(|k| {
            let points = files
                .covariances
                .iter()
                .map(|(t, c)| match c {
                    Some(c) => (
                        *t,
                        (rotation * c * rotation.transpose())[(k, k)]
                            .max(0.0)
                            .sqrt(),
                    ),
                    None => GAP,
                })
                .collect();
            let breaks: Vec<usize> = (1..files.covariances.len())
                .filter(|&i| files.covariances[i].0 - files.covariances[i - 1].0 > POSE_GAP_S)
                .collect();
            insert_gaps(points, &breaks)
        });
        let aps = files
            .aps
            .iter()
            .map(|a| {
                let p = to_frame(&a.position());
                ApFigure {
                    name: a.name.clone(),
                    xy: (p.x, p.y),
                    ellipse_2sigma: a.covariance().map_or_else(Vec::new, |c| {
                        ellipse(p.x, p.y, &(rotation * c * rotation.transpose()), 2.0)
                    }),
                }
            })
            .collect();
        let mut aoa = files.aoa.clone();
        if let Some(t) = truth {
            against_truth::add_true_aoa(&mut aoa, t);
        }
        Ok(Self {
            track_xy: series(&|p| (p.p_b_in_w.x, p.p_b_in_w.y)),
            baro_height: baro_shifted(&files.baro, &poses),
            height,
            attitude_deg,
            sigma_m,
            aps,
            aoa,
            events: files.events.clone(),
            truth: match (aligned, truth) {
                (Some(a), Some(t)) => Some(a.figures(t, &poses, &breaks)),
                _ => None,
            },
        })
    }
}

impl RunFigures {
    /// The figures of the run written into `run_dir` from `dataset`
    /// ([`RunFigures::from_files`] of its trajectory), against the dataset's truth when it has
    /// one the estimate can be aligned to, else alone, with why in the second value. The truth's
    /// poses are read near the estimate's ([`Truth::load_dir_near`]), so an hour-long flight's
    /// truth at the IMU's rate is never held.
    pub fn of_run(
        run_dir: &Path,
        dataset: &Path,
        options: &EvalOptions,
    ) -> Result<(Self, Option<String>), FigureError> {
        // The run's files are read once; the truth's poses near the estimate's.
        let files = RunFiles::read(&run_dir.join(TRAJECTORY_FILE), Some(dataset))?;
        let alone = |why: Option<String>| Self::of_files(&files, None, options).map(|f| (f, why));
        let truth_dir = dataset.join(TRUTH_DIR);
        if !truth_dir.is_dir() {
            return alone(None);
        }
        let times: Vec<Timestamp> = files.poses.iter().map(|p| p.t).collect();
        let truth = match Truth::load_dir_near(&truth_dir, &times, TRUTH_DRAWN_EVERY_NS) {
            Ok(t) => t,
            Err(e) => return alone(Some(format!("the truth cannot be read: {e}"))),
        };
        match Self::of_files(&files, Some(&truth), options) {
            Err(FigureError::Align(e)) => alone(Some(e.to_string())),
            other => other.map(|f| (f, None)),
        }
    }
}

/// Indices `i` of `poses` where a gap lies between pose `i - 1` and pose `i`.
fn gaps(poses: &[Pose]) -> Vec<usize> {
    (1..poses.len())
        .filter(|&i| (poses[i].t.0 - poses[i - 1].t.0) as f64 * 1e-9 > POSE_GAP_S)
        .collect()
}

/// `f` of each pose, a [`GAP`] before each index of `breaks`.
fn with_gaps(poses: &[Pose], breaks: &[usize], f: &dyn Fn(&Pose) -> (f64, f64)) -> Points {
    insert_gaps(poses.iter().map(f).collect(), breaks)
}

/// `points` with a [`GAP`] before each index of `breaks` (increasing).
fn insert_gaps(points: Points, breaks: &[usize]) -> Points {
    let mut out = Vec::with_capacity(points.len() + breaks.len());
    let mut next = breaks.iter().peekable();
    for (i, p) in points.into_iter().enumerate() {
        if next.next_if(|&&b| b == i).is_some() {
            out.push(GAP);
        }
        out.push(p);
    }
    out
}

/// Roll, pitch, yaw (z-y-x Euler angles of `world_from_body`), degrees.
fn euler_deg(q: &UnitQuaternion<f64>) -> [f64; 3] {
    let (roll, pitch, yaw) = q.euler_angles();
    [roll, pitch, yaw].map(f64::to_degrees)
}

/// A gap where consecutive angles jump by more than half a turn (a wrap at ±180°).
fn break_wraps(points: Points) -> Points {
    let mut out = Vec::with_capacity(points.len());
    let mut last: Option<f64> = None;
    for p in points {
        if let Some(prev) = last
            && p.1.is_finite()
            && (p.1 - prev).abs() > 180.0
        {
            out.push(GAP);
        }
        last = p.1.is_finite().then_some(p.1);
        out.push(p);
    }
    out
}

/// The barometer's altitudes over time, shifted by the mean difference between the estimated
/// height and the altitude (at the reading nearest each pose): a barometer's datum is its own.
fn baro_shifted(baro: &[(f64, f64)], poses: &[Pose]) -> Points {
    if baro.is_empty() || poses.is_empty() {
        return Vec::new();
    }
    let nearest = |t: f64| {
        let i = baro.partition_point(|(tb, _)| *tb < t);
        match (i.checked_sub(1).map(|j| baro[j]), baro.get(i).copied()) {
            (Some(a), Some(b)) => Some(if t - a.0 <= b.0 - t { a } else { b }),
            (a, b) => a.or(b),
        }
    };
    let differences: Vec<f64> = poses
        .iter()
        .filter_map(|p| nearest(p.t.as_secs_f64()).map(|(_, alt)| p.p_b_in_w.z - alt))
        .collect();
    let shift = differences.iter().sum::<f64>() / differences.len() as f64;
    baro.iter().map(|&(t, alt)| (t, alt + shift)).collect()
}

/// The closed line at `sigmas` standard deviations around `(x, y)` of the horizontal block of
/// `c`; empty when that block is not a covariance (not finite, or not positive semidefinite).
fn ellipse(x: f64, y: f64, c: &Matrix3<f64>, sigmas: f64) -> Points {
    let h = Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)]);
    if !h.iter().all(|v| v.is_finite()) {
        return Vec::new();
    }
    let eig = h.symmetric_eigen();
    if eig.eigenvalues.iter().any(|&l| l < 0.0) {
        return Vec::new();
    }
    let axes = eig.eigenvectors * Matrix2::from_diagonal(&eig.eigenvalues.map(f64::sqrt));
    (0..=ELLIPSE_POINTS)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / ELLIPSE_POINTS as f64;
            let d = axes * nalgebra::Vector2::new(a.cos(), a.sin()) * sigmas;
            (x + d.x, y + d.y)
        })
        .collect()
}
