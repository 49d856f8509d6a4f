//! Reading a dataset directory back into typed data.

use std::path::{Path, PathBuf};

use super::baro_csv::{BaroCsvError, BaroSample};
pub use super::checks::CsiPacket;
use super::checks::{InputError, InputReport};
use super::imu_csv::ImuCsvError;
use super::manifest::{FORMAT, Manifest, VERSION};
use crate::csi::capture::CaptureError;
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{ReadError, Skip};
use crate::imu::ImuSample;
use crate::rig::{CalibrationError, ChainCalibration};
use crate::time::NANOS_PER_MICRO;

/// The highest IMU rate a manifest may declare, Hz.
pub const MAX_IMU_RATE_HZ: f64 = 10_000.0;

/// The manifest's file name inside a dataset directory.
pub const MANIFEST_FILE: &str = "dataset.toml";

/// A dataset that cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file could not be read.
    #[error("cannot read {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// `dataset.toml` does not parse.
    #[error("{path}: {source}")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// The parser's message.
        source: toml::de::Error,
    },
    /// `dataset.toml` parses but says something unusable.
    #[error("{path}: {reason}")]
    Invalid {
        /// The manifest.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The IMU CSV is malformed.
    #[error("{path}: {source}")]
    Imu {
        /// The CSV.
        path: PathBuf,
        /// Which line and why.
        source: ImuCsvError,
    },
    /// The barometer CSV is malformed.
    #[error("{path}: {source}")]
    Baro {
        /// The CSV.
        path: PathBuf,
        /// Which line and why.
        source: BaroCsvError,
    },
    /// A CSI log could not be read (corrupt content is skipped and counted, not an error).
    #[error(transparent)]
    Log(#[from] ReadError),
    /// An AP's log is another card's than `[array] card` says.
    #[error(
        "{path}: dataset.toml's [array] card is {card}, but this log is {found} ({describe}): \
         set card = \"{found}\"",
        describe = found.describe()
    )]
    Card {
        /// The log.
        path: PathBuf,
        /// The card the manifest names.
        card: CaptureFormat,
        /// The format the file's first bytes say.
        found: CaptureFormat,
    },
    /// Another card's capture could not be read.
    #[error("{path}: {source}")]
    Capture {
        /// The log.
        path: PathBuf,
        /// Why.
        source: Box<CaptureError>,
    },
    /// The calibration file the manifest names cannot be used.
    #[error(transparent)]
    Calibration(#[from] CalibrationError),
    /// The inputs cannot give a meaningful estimate ([`super::checks`]).
    #[error("{source}")]
    Inputs {
        /// The dataset directory.
        dir: PathBuf,
        /// Why.
        source: InputError,
    },
}

/// One AP's log, decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct ApLog {
    /// The AP's name from the manifest.
    pub name: String,
    /// Its CSI records in file order.
    pub packets: Vec<CsiPacket>,
    /// Byte ranges of the log that were skipped, with reasons.
    pub skips: Vec<Skip>,
    /// Records whose bandwidth differs from the manifest's channel (kept; the AoA stage decides).
    pub bandwidth_mismatches: usize,
}

/// A dataset in memory: the manifest, the IMU stream and every AP's CSI.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// The directory it was read from.
    pub dir: PathBuf,
    /// `dataset.toml`.
    pub manifest: Manifest,
    /// IMU samples, strictly increasing in time.
    pub imu: Vec<ImuSample>,
    /// Per AP, in manifest order.
    pub aps: Vec<ApLog>,
    /// The NIC's chain calibration, when the manifest names one.
    pub calibration: Option<ChainCalibration>,
    /// Barometer readings, strictly increasing in time; empty when the manifest names none.
    pub baro: Vec<BaroSample>,
    /// What the input checks dropped, counted and found ([`super::checks`]).
    pub inputs: InputReport,
}

/// Reads and checks `dir/dataset.toml`.
pub fn read_manifest(dir: &Path) -> Result<Manifest, DatasetError> {
    let path = dir.join(MANIFEST_FILE);
    let text = crate::io_safety::read_text(&path).map_err(|source| DatasetError::Io {
        path: path.clone(),
        source,
    })?;
    let manifest: Manifest = toml::from_str(&text).map_err(|source| DatasetError::Manifest {
        path: path.clone(),
        source,
    })?;
    let invalid = |reason: String| DatasetError::Invalid {
        path: path.clone(),
        reason,
    };
    if manifest.format != FORMAT {
        return Err(invalid(format!(
            "format is {:?}, expected {FORMAT:?}",
            manifest.format
        )));
    }
    if manifest.version != VERSION {
        return Err(invalid(format!(
            "version {} (this build reads version {VERSION})",
            manifest.version
        )));
    }
    if let Some(b) = &manifest.baro
        && !(b.rate_hz.is_finite() && b.rate_hz > 0.0)
    {
        return Err(invalid(format!("baro.rate_hz {} is not > 0", b.rate_hz)));
    }
    let imu = &manifest.imu;
    for (key, v) in [
        ("imu.rate_hz", imu.rate_hz),
        ("imu.accel_range_m_s2", imu.accel_range_m_s2),
        ("imu.gyro_range_rad_s", imu.gyro_range_rad_s),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(invalid(format!("{key} {v} is not > 0")));
        }
    }
    if imu.rate_hz > MAX_IMU_RATE_HZ {
        return Err(invalid(format!(
            "imu.rate_hz {} is above {MAX_IMU_RATE_HZ} Hz",
            imu.rate_hz
        )));
    }
    let t = manifest.array.translation_m;
    if !t.iter().all(|v| v.is_finite() && v.abs() <= 10.0) {
        return Err(invalid(format!(
            "array.translation_m {t:?} is not finite within 10 m of the IMU"
        )));
    }
    if manifest.aps.is_empty() {
        return Err(invalid("no access point".into()));
    }
    for (i, ap) in manifest.aps.iter().enumerate() {
        if manifest.aps[..i].iter().any(|o| o.name == ap.name) {
            return Err(invalid(format!("AP name {:?} appears twice", ap.name)));
        }
    }
    if let Err(e) = manifest
        .array
        .geometry
        .validate(manifest.channel.center_freq_hz)
    {
        return Err(invalid(format!("array and channel: {e}")));
    }
    let q = manifest.array.rotation_xyzw;
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !(norm.is_finite() && (norm - 1.0).abs() < 1e-6) {
        return Err(invalid(format!(
            "array.rotation_xyzw {q:?} is not a unit quaternion"
        )));
    }
    Ok(manifest)
}

/// The IMU-clock offset for a NIC whose microsecond clock read `nic_us_at_imu_zero` when the IMU
/// clock read 0: `imu_minus_nic_ns` of the manifest.
pub fn imu_minus_nic_ns(nic_us_at_imu_zero: u64) -> i64 {
    -(nic_us_at_imu_zero as i64) * NANOS_PER_MICRO
}
