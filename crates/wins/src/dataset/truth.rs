//! `truth/`: what only a simulator (or a motion-capture system) knows. The estimator never reads
//! it; evaluation and tests do.

use std::io::{self, BufRead, Write};
use std::path::{Path, PathBuf};

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::time::{NANOS_PER_SEC, Timestamp};

/// The truth folder's name inside a dataset.
pub const TRUTH_DIR: &str = "truth";

/// One body pose (TUM: `t x y z qx qy qz qw`, seconds, `world_from_body`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Time on the IMU clock.
    pub t: Timestamp,
    /// Body (IMU) position in the world, m.
    pub p_b_in_w: Vector3<f64>,
    /// Body attitude.
    pub world_from_body: UnitQuaternion<f64>,
}

/// One row of `truth/packets_<ap>.csv`: a packet slot of one AP.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PacketRow {
    /// Arrival time on the IMU clock, ns.
    pub t_ns: i64,
    /// Whether the NIC logged it (lost packets are listed with `received = false`).
    pub received: bool,
    /// Its `bfee_count` in the log (only meaningful when received).
    pub bfee_count: u16,
    /// True direct-path AoA in the array frame (steering-vector convention), rad.
    pub aoa_rad: f64,
    /// The same in degrees.
    pub aoa_deg: f64,
    /// Elevation of the AP above the array's `a_x a_y` plane, rad.
    pub elevation_rad: f64,
    /// Whether the AP is in front of the array (`û·x̂_a > 0`).
    pub in_front: bool,
    /// Direct-path time of flight, s.
    pub tof_s: f64,
    /// Array-centre-to-AP distance, m.
    pub range_m: f64,
    /// Whether the obstacle attenuates the direct path.
    pub direct_obstructed: bool,
    /// Per-subcarrier SNR averaged over chains, dB.
    pub snr_db: f64,
    /// Direct over reflected power, dB.
    pub k_factor_db: f64,
    /// Sampling-time offset of the packet, s.
    pub sto_s: f64,
    /// Common phase of the packet, rad.
    pub common_phase_rad: f64,
    /// CSI components clipped by the 8-bit quantizer.
    pub clipped: u32,
}

/// One row of `truth/aps.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ApRow {
    /// AP name (as in `dataset.toml`).
    pub name: String,
    /// Position in the world, m.
    pub x_m: f64,
    /// Position in the world, m.
    pub y_m: f64,
    /// Position in the world, m.
    pub z_m: f64,
}

/// One row of `truth/imu_biases.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BiasRow {
    /// Sample time, ns.
    pub t_ns: i64,
    /// Gyro bias, rad/s.
    pub bg_x: f64,
    /// Gyro bias, rad/s.
    pub bg_y: f64,
    /// Gyro bias, rad/s.
    pub bg_z: f64,
    /// Accelerometer bias, m/s².
    pub ba_x: f64,
    /// Accelerometer bias, m/s².
    pub ba_y: f64,
    /// Accelerometer bias, m/s².
    pub ba_z: f64,
}

/// One row of `truth/baro.csv`: what lies behind a barometer reading
/// (`altitude_m = height_m + offset_m + drift_m + noise`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaroRow {
    /// Sample time, ns.
    pub t_ns: i64,
    /// True height of the body (IMU) origin above the floor, m.
    pub height_m: f64,
    /// The flight's constant offset, m.
    pub offset_m: f64,
    /// The slow drift at this sample, m.
    pub drift_m: f64,
}

/// `truth/truth.toml`: constants of the simulated hardware.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthInfo {
    /// Scenario that produced the dataset.
    pub scenario: String,
    /// Its master seed.
    pub seed: u64,
    /// Fixed phase offset of each receive chain (A, B, C), rad: what `wins calibrate` estimates.
    pub chain_phase_offsets_rad: Vec<f64>,
    /// Gravity magnitude used, m/s².
    pub gravity_m_s2: f64,
    /// The rotors' vibration on the IMU, as an integration sees it (`None`: none, or a dataset
    /// written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imu_vibration: Option<VibrationTruth>,
}

/// `[imu_vibration]` of `truth/truth.toml`: the rotors' vibration the IMU's samples carry beyond
/// the datasheet's noise, as its density near 0 Hz (what a preintegration over a keyframe
/// integrates; the rotor lines far above it average out), while the rotors spin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VibrationTruth {
    /// The rotors spin from here (IMU clock), ns.
    pub from_ns: i64,
    /// to here, ns.
    pub to_ns: i64,
    /// Per axis (body x, y, z), the accelerometer's density, m/s²/√Hz.
    pub accel_density_m_s2_sqrt_hz: [f64; 3],
    /// Per axis, the gyro's density, rad/s/√Hz.
    pub gyro_density_rad_s_sqrt_hz: [f64; 3],
}

/// Everything in `truth/`.
#[derive(Clone, Debug, PartialEq)]
pub struct Truth {
    /// Body poses at IMU rate.
    pub poses: Vec<Pose>,
    /// AP positions.
    pub aps: Vec<ApRow>,
    /// Per AP (in `aps` order), every packet slot.
    pub packets: Vec<Vec<PacketRow>>,
    /// IMU biases at each IMU sample.
    pub imu_biases: Vec<BiasRow>,
    /// Hardware constants (`None` without `truth.toml`).
    pub info: Option<TruthInfo>,
}

/// A truth file that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    /// I/O failure.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// A malformed CSV or TUM row.
    #[error("{path}: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Line and reason.
        reason: String,
    },
}

/// File name of one AP's packet truth.
pub fn packets_file(ap: &str) -> String {
    format!("packets_{ap}.csv")
}

/// Writes poses in TUM format with a comment header.
pub fn write_tum(out: &mut impl Write, poses: &[Pose]) -> io::Result<()> {
    write_tum_header(out)?;
    for p in poses {
        write_tum_pose(out, p)?;
    }
    Ok(())
}

/// The header line of [`write_tum`].
pub fn write_tum_header(out: &mut impl Write) -> io::Result<()> {
    writeln!(out, "# timestamp tx ty tz qx qy qz qw")
}

/// One line of [`write_tum`].
pub fn write_tum_pose(out: &mut impl Write, p: &Pose) -> io::Result<()> {
    let q = p.world_from_body.quaternion();
    let t = p.t.as_nanos();
    writeln!(
        out,
        "{}.{:09} {} {} {} {} {} {} {}",
        t.div_euclid(NANOS_PER_SEC),
        t.rem_euclid(NANOS_PER_SEC),
        p.p_b_in_w.x,
        p.p_b_in_w.y,
        p.p_b_in_w.z,
        q.i,
        q.j,
        q.k,
        q.w
    )
}

/// Reads a TUM trajectory (`#` comments and blank lines skipped; times in seconds, rounded to ns).
pub fn read_tum(input: impl BufRead) -> Result<Vec<Pose>, String> {
    tum_poses(input).collect()
}

/// The poses of a TUM trajectory one at a time, as [`read_tum`] reads them (the first error
/// ends the reading).
pub fn tum_poses(input: impl BufRead) -> impl Iterator<Item = Result<Pose, String>> {
    let mut failed = false;
    input
        .lines()
        .enumerate()
        .map_while(move |(i, line)| {
            if failed {
                return None;
            }
            let pose = line
                .map_err(|e| e.to_string())
                .and_then(|line| tum_line(i, &line));
            failed = pose.is_err();
            Some(pose)
        })
        .filter_map(Result::transpose)
}

/// The pose of line `i` (from 0) of a TUM file, `None` for a comment or a blank line.
fn tum_line(i: usize, line: &str) -> Result<Option<Pose>, String> {
    let text = line.trim();
    if text.is_empty() || text.starts_with('#') {
        return Ok(None);
    }
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|f| f.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("line {}: not all numbers", i + 1))?;
    if v.len() != 8 {
        return Err(format!("line {}: {} fields, expected 8", i + 1, v.len()));
    }
    let t = Timestamp((v[0] * NANOS_PER_SEC as f64).round() as i64);
    if !t.is_in_range() {
        return Err(format!(
            "line {}: time {} s is 146 years or more from the clock's origin",
            i + 1,
            v[0]
        ));
    }
    Ok(Some(Pose {
        t,
        p_b_in_w: Vector3::new(v[1], v[2], v[3]),
        world_from_body: UnitQuaternion::from_quaternion(Quaternion::new(v[7], v[4], v[5], v[6])),
    }))
}

impl Truth {
    /// Loads `dataset_dir/truth/`: `poses.tum` is required, every other file is optional (a
    /// motion-capture truth has only poses); a file that is there must parse.
    pub fn load(dataset_dir: impl AsRef<Path>) -> Result<Self, TruthError> {
        Self::load_dir(dataset_dir.as_ref().join(TRUTH_DIR))
    }

    /// Loads a truth folder itself (a dataset's `truth/`, or a copy of it elsewhere), as
    /// [`Truth::load`].
    pub fn load_dir(dir: impl AsRef<Path>) -> Result<Self, TruthError> {
        let dir = dir.as_ref().to_path_buf();
        let open = |name: &str| {
            let path = dir.join(name);
            crate::io_safety::open_regular(&path)
                .map(io::BufReader::new)
                .map_err(|source| TruthError::Io { path, source })
        };
        let parse_err = |name: &str, reason: String| TruthError::Parse {
            path: dir.join(name),
            reason,
        };
        let info: Option<TruthInfo> = read_optional(&dir, "truth.toml")?
            .map(|b| toml::from_str(&String::from_utf8_lossy(&b)))
            .transpose()
            .map_err(|e| parse_err("truth.toml", e.to_string()))?;
        let poses = read_tum(open("poses.tum")?).map_err(|e| parse_err("poses.tum", e))?;
        let (aps, packets) = aps_and_packets(&dir)?;
        let imu_biases = csv_or_empty(&dir, "imu_biases.csv")?;
        Ok(Self {
            poses,
            aps,
            packets,
            imu_biases,
            info,
        })
    }
}

impl Truth {
    /// The truth folder `dir` as [`Truth::load_dir`] reads it, but of its poses only, for each
    /// time of `near` (increasing), the one nearest to it, and one every `every_ns` besides;
    /// and without the IMU biases. Its memory is that of `near`, not of the truth's IMU-rate
    /// poses (what a run's figures need of an hour-long flight's truth).
    pub fn load_dir_near(
        dir: impl AsRef<Path>,
        near: &[Timestamp],
        every_ns: i64,
    ) -> Result<Self, TruthError> {
        let dir = dir.as_ref();
        let path = dir.join("poses.tum");
        let file = crate::io_safety::open_regular(&path).map_err(|source| TruthError::Io {
            path: path.clone(),
            source,
        })?;
        let mut poses: Vec<Pose> = Vec::new();
        let (mut next, mut previous): (usize, Option<Pose>) = (0, None);
        for pose in tum_poses(io::BufReader::new(file)) {
            let pose = pose.map_err(|reason| TruthError::Parse {
                path: path.clone(),
                reason,
            })?;
            let mut keep = poses.last().is_none_or(|k| pose.t.0 - k.t.0 >= every_ns);
            // Each time of `near` up to this pose takes the nearer of it and the one before.
            while let Some(&t) = near.get(next).filter(|t| t.0 <= pose.t.0) {
                match previous {
                    Some(p) if (t.0 - p.t.0) <= (pose.t.0 - t.0) => {
                        if poses.last().is_none_or(|k| k.t != p.t) {
                            poses.push(p);
                        }
                    }
                    _ => keep = true,
                }
                next += 1;
            }
            if keep && poses.last().is_none_or(|k| k.t != pose.t) {
                poses.push(pose);
            }
            previous = Some(pose);
        }
        // Times beyond the last pose take it.
        if let Some(p) =
            previous.filter(|p| next < near.len() && poses.last().is_none_or(|k| k.t != p.t))
        {
            poses.push(p);
        }
        let (aps, packets) = aps_and_packets(dir)?;
        Ok(Self {
            poses,
            aps,
            packets,
            imu_biases: Vec::new(),
            info: None,
        })
    }
}

/// The truth folder `dir`'s APs and each one's packet rows (none without `aps.csv`).
fn aps_and_packets(dir: &Path) -> Result<(Vec<ApRow>, Vec<Vec<PacketRow>>), TruthError> {
    let aps: Vec<ApRow> = csv_or_empty(dir, "aps.csv")?;
    let packets = aps
        .iter()
        .map(|ap| csv_or_empty(dir, &packets_file(&ap.name)))
        .collect::<Result<_, _>>()?;
    Ok((aps, packets))
}

/// The bytes of `dir/name`, or `None` when there is no such file.
pub(crate) fn read_optional(dir: &Path, name: &str) -> Result<Option<Vec<u8>>, TruthError> {
    let path = dir.join(name);
    match std::fs::read(&path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(TruthError::Io { path, source }),
    }
}

/// The rows of the CSV file `dir/name`, none when there is no such file (read as it is parsed).
fn csv_or_empty<T: serde::de::DeserializeOwned>(
    dir: &Path,
    name: &str,
) -> Result<Vec<T>, TruthError> {
    let path = dir.join(name);
    let file = match crate::io_safety::open_regular(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => return Err(TruthError::Io { path, source }),
    };
    read_csv(io::BufReader::new(file)).map_err(|reason| TruthError::Parse { path, reason })
}

/// Serializes rows as CSV with a header.
pub fn write_csv<T: Serialize>(out: impl Write, rows: &[T]) -> io::Result<()> {
    let mut w = csv::Writer::from_writer(out);
    for r in rows {
        w.serialize(r).map_err(io::Error::other)?;
    }
    w.flush()
}

fn read_csv<T: serde::de::DeserializeOwned>(input: impl io::Read) -> Result<Vec<T>, String> {
    csv::Reader::from_reader(input)
        .deserialize()
        .enumerate()
        .map(|(i, r)| r.map_err(|e| format!("row {}: {e}", i + 1)))
        .collect()
}

#[cfg(test)]
#[path = "truth_tests.rs"]
mod tests;
