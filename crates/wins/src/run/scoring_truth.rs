//! What scoring a run reads of `truth/`, without holding the poses ([`ScoringTruth`]): the
//! poses are checked as they are parsed and read again, in passes, by the evaluation
//! ([`crate::eval::stream`]).

use std::io;
use std::path::{Path, PathBuf};

use crate::dataset::truth::{
    ApRow, PacketRow, TRUTH_DIR, TruthError, TruthInfo, packets_file, read_optional, tum_poses,
};
use crate::eval::scan::TrajectoryScan;

/// `truth/` as a run's scoring reads it: the poses' file and its scan, the APs, and per AP the
/// time and true AoA of each packet slot.
#[derive(Clone, Debug)]
pub(crate) struct ScoringTruth {
    /// `truth/poses.tum`.
    pub(crate) poses_path: PathBuf,
    /// What one pass over it found.
    pub(crate) poses: TrajectoryScan,
    /// AP positions.
    pub(crate) aps: Vec<ApRow>,
    /// Per AP (in `aps` order), every packet slot's `(time ns, true AoA °)`.
    pub(crate) packet_aoa_deg: Vec<Vec<(i64, f64)>>,
}

impl ScoringTruth {
    /// Reads `dataset_dir/truth/` as [`crate::dataset::truth::Truth::load_for_scoring`] does, with the
    /// same errors, keeping of the poses only their scan.
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
        let mut poses = TrajectoryScan::default();
        for p in tum_poses(io::BufReader::new(file)) {
            poses.push(&p.map_err(|e| parse_err("poses.tum", e))?);
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
            poses_path,
            poses,
            aps,
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
