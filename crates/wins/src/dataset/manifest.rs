//! `dataset.toml`: what a recording needs to be interpreted.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::csi::Bandwidth;
use crate::csi::format::CaptureFormat;
use crate::rig::ArrayGeometry;
use crate::rig::ImuNoise;

/// The format name written in every manifest.
pub const FORMAT: &str = "wins-dataset";
/// The manifest version this library writes and reads.
pub const VERSION: u32 = 1;

/// The manifest of a recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Always `wins-dataset`.
    pub format: String,
    /// Manifest version (1).
    pub version: u32,
    /// Free text: where the recording comes from.
    #[serde(default)]
    pub description: String,
    /// The IMU stream.
    pub imu: ImuEntry,
    /// The receive antenna array and its mounting.
    pub array: ArrayEntry,
    /// The Wi-Fi channel.
    pub channel: ChannelEntry,
    /// One entry per access point.
    pub aps: Vec<ApEntry>,
    /// The flight controller's barometer, when recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baro: Option<BaroEntry>,
}

/// The barometer stream (`t_ns,altitude_m`, see [`crate::dataset::baro_csv`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaroEntry {
    /// CSV file, relative to the dataset directory.
    pub file: String,
    /// Nominal sample rate, Hz.
    pub rate_hz: f64,
}

/// The IMU stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuEntry {
    /// CSV file, relative to the dataset directory.
    pub file: String,
    /// Nominal sample rate, Hz.
    pub rate_hz: f64,
    /// Accelerometer full scale per axis, m/s²: a sample at or beyond it is dropped and counted
    /// (saturated or corrupt). Default 16 g.
    #[serde(default = "default_accel_range")]
    pub accel_range_m_s2: f64,
    /// Gyroscope full scale per axis, rad/s (default 2000 °/s).
    #[serde(default = "default_gyro_range")]
    pub gyro_range_rad_s: f64,
    /// Noise densities and turn-on bias spreads (from the datasheet or an Allan-variance
    /// analysis); the estimator's weights. Absent: the user must give them to `wins run`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<ImuNoise>,
}

/// The antenna array: geometry plus `body_from_array`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrayEntry {
    /// The card whose tool wrote the logs, by its capture format: `intel5300` (the default),
    /// `atheros`, `nexmon`, `feitcsi` or `picoscenes`. Every AP's log is in it.
    #[serde(default, skip_serializing_if = "is_intel5300")]
    pub card: CaptureFormat,
    /// Antenna count and spacing (antennas along the array's y axis, normal along x).
    pub geometry: ArrayGeometry,
    /// Array centre in the body (IMU) frame, m.
    pub translation_m: [f64; 3],
    /// Rotation `body_from_array` as a Hamilton quaternion `[x, y, z, w]`.
    pub rotation_xyzw: [f64; 4],
    /// The NIC's receive-chain calibration ([`crate::rig::ChainCalibration`] TOML), relative to
    /// the dataset directory: a prior. Absent (or named but not there): the chains' offsets are
    /// resolved from the flight alone, where the estimator can (`wins run` warns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<String>,
}

fn is_intel5300(card: &CaptureFormat) -> bool {
    *card == CaptureFormat::Intel5300
}

impl ArrayEntry {
    /// `body_from_array` as an isometry (the quaternion is normalized).
    pub fn body_from_array(&self) -> Isometry3<f64> {
        let [x, y, z, w] = self.rotation_xyzw;
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation_m)),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        )
    }

    /// An entry from an isometry.
    pub fn new(geometry: ArrayGeometry, body_from_array: &Isometry3<f64>) -> Self {
        let q = body_from_array.rotation.quaternion();
        let t = body_from_array.translation.vector;
        Self {
            geometry,
            card: CaptureFormat::Intel5300,
            translation_m: [t.x, t.y, t.z],
            rotation_xyzw: [q.i, q.j, q.k, q.w],
            calibration: None,
        }
    }
}

/// The Wi-Fi channel the NIC listened on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelEntry {
    /// Carrier frequency, Hz.
    pub center_freq_hz: f64,
    /// `ht20` or `ht40` (each record's rate flags say so too; this is the expected value).
    pub bandwidth: Bandwidth,
}

/// One access point's log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ApEntry {
    /// Name of the AP.
    pub name: String,
    /// Intel 5300 `.dat` log, relative to the dataset directory.
    pub log: String,
    /// IMU time = unwrapped NIC time + this offset, ns. The NIC time is the log's
    /// `timestamp_low` in µs, unwrapped from the first record of the log (lap 0).
    pub imu_minus_nic_ns: i64,
    /// The AP's transmitter address (`"aa:bb:cc:dd:ee:ff"`), by which `wins live` tells its
    /// packets from the frame records the logger interleaves; not read by `wins run`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mac: Option<String>,
}

impl ApEntry {
    /// The AP's transmitter address, when `mac` is set: `Err` with the reason when it is not
    /// six hexadecimal bytes separated by colons.
    pub fn mac_address(&self) -> Result<Option<[u8; 6]>, String> {
        let Some(text) = &self.mac else {
            return Ok(None);
        };
        parse_mac(text).map(Some).ok_or_else(|| {
            format!(
                "AP {:?}: mac = {text:?} is not six hexadecimal bytes separated by colons",
                self.name
            )
        })
    }
}

/// `"aa:bb:cc:dd:ee:ff"` (either case) as bytes; `None` when it is not that form.
pub fn parse_mac(text: &str) -> Option<[u8; 6]> {
    let mut out = [0u8; 6];
    let mut parts = text.split(':');
    for byte in &mut out {
        let part = parts.next()?;
        if part.len() != 2 {
            return None;
        }
        *byte = u8::from_str_radix(part, 16).ok()?;
    }
    parts.next().is_none().then_some(out)
}

/// `aa:bb:cc:dd:ee:ff`, lower case.
pub fn format_mac(mac: &[u8; 6]) -> String {
    mac.iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(":")
}

/// 16 g, the usual full scale of a flight controller's accelerometer, m/s².
pub const DEFAULT_ACCEL_RANGE_M_S2: f64 = 16.0 * 9.806_65;
/// 2000 °/s, the usual full scale of a flight controller's gyroscope, rad/s.
pub const DEFAULT_GYRO_RANGE_RAD_S: f64 = 2000.0 * std::f64::consts::PI / 180.0;

fn default_accel_range() -> f64 {
    DEFAULT_ACCEL_RANGE_M_S2
}

fn default_gyro_range() -> f64 {
    DEFAULT_GYRO_RANGE_RAD_S
}
