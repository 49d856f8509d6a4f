//! What scoring a run reads of the truth ([`ScoringTruth`]): of a dataset's `truth/` without
//! holding the poses (they are checked as they are parsed and read again, in passes, by the
//! evaluation, [`crate::eval::stream`]), or of a [`Truth`] in memory.

use std::borrow::Cow;
use std::io;
use std::path::{Path, PathBuf};

use crate::dataset::truth::{
    ApRow, PacketRow, Pose, TRUTH_DIR, Truth, TruthError, TruthInfo, packets_file, read_optional,
    tum_poses,
};
use crate::eval::scan::TrajectoryScan;
use crate::eval::stream::TruthSource;

/// The truth as a run's scoring reads it: the poses and their scan, the APs, and per AP the
/// time and true AoA of each packet slot.
#[derive(Clone, Debug)]
pub(crate) struct ScoringTruth<'a> {
    /// The poses.
    poses: TruthPoses<'a>,
    /// What one pass over them found.
    pub(crate) scan: TrajectoryScan,
    /// AP positions.
    pub(crate) aps: Cow<'a, [ApRow]>,
    /// Per AP (in `aps` order), every packet slot's `(time ns, true AoA °)`.
    pub(crate) packet_aoa_deg: Vec<Vec<(i64, f64)>>,
}

/// Where the truth's poses are.
#[derive(Clone, Debug)]
enum TruthPoses<'a> {
    /// `truth/poses.tum`.
    File(PathBuf),
    /// In memory.
    Memory(&'a [Pose]),
}

impl<'a> ScoringTruth<'a> {
    /// `truth` in memory.
    pub(crate) fn of(truth: &'a Truth) -> Self {
        Self {
            poses: TruthPoses::Memory(&truth.poses),
            scan: TrajectoryScan::of(&truth.poses),
            aps: Cow::Borrowed(&truth.aps),
            packet_aoa_deg: truth
                .packets
                .iter()
                .map(|rows| rows.iter().map(|r| (r.t_ns, r.aoa_deg)).collect())
                .collect(),
        }
    }

    /// Where the evaluation reads the poses from.
    pub(crate) fn poses(&self) -> TruthSource<'_> {
        match &self.poses {
            TruthPoses::File(path) => TruthSource::File(path),
            TruthPoses::Memory(poses) => TruthSource::Poses(poses),
        }
    }
}

impl ScoringTruth<'static> {
    /// Reads `dataset_dir/truth/` as [`Truth::load`] does (without the IMU biases, which
    /// scoring does not read), with the same errors, keeping of the poses only their scan.
    pub(crate) fn open(dataset_dir: &Path) -> Result<Self, TruthError> {
        let dir = dataset_dir.join(TRUTH_DIR);
        let parse_err = |name: &str, reason: String| TruthError::Parse {
            path: dir.join(name),
            reason,
        };
        let _info: Option<TruthInfo> = read_optional(&dir, "truth.toml")?
            .map(|b| toml::from_str(&String::from_utf8_lossy(&b)))
            .transpose()
            .map_err(|e| parse_err("truth.toml", e.to_string()))?;
        let poses_path = dir.join("poses.tum");
        let file =
            crate::io_safety::open_regular(&poses_path).map_err(|source| TruthError::Io {
                path: poses_path.clone(),
                source,
            })?;
        let mut scan = TrajectoryScan::default();
        for p in tum_poses(io::BufReader::new(file)) {
            scan.push(&p.map_err(|e| parse_err("poses.tum", e))?);
        }
        let aps: Vec<ApRow> = rows_or_empty(&dir, "aps.csv", |r: ApRow| r)?;
        let mut packet_aoa_deg = Vec::with_capacity(aps.len());
        for ap in &aps {
            packet_aoa_deg.push(rows_or_empty(
                &dir,
                &packets_file(&ap.name),
                |r: PacketRow| (r.t_ns, r.aoa_deg),
            )?);
        }
        Ok(Self {
            poses: TruthPoses::File(poses_path),
            scan,
            aps: Cow::Owned(aps),
            packet_aoa_deg,
        })
    }
}

/// `keep` of each row of the CSV file `dir/name`, read as it is parsed (none when there is no
/// such file; the errors of [`crate::dataset::truth::Truth::load`]).
fn rows_or_empty<T: serde::de::DeserializeOwned, K>(
    dir: &Path,
    name: &str,
    keep: impl Fn(T) -> K,
) -> Result<Vec<K>, TruthError> {
    let path = dir.join(name);
    let file = match crate::io_safety::open_regular(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => return Err(TruthError::Io { path, source }),
    };
    csv::Reader::from_reader(io::BufReader::new(file))
        .deserialize()
        .enumerate()
        .map(|(i, r)| {
            r.map(&keep).map_err(|e| TruthError::Parse {
                path: path.clone(),
                reason: format!("row {}: {e}", i + 1),
            })
        })
        .collect()
}
