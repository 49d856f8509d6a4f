//! A [`BoundInput`] from a simulated dataset folder: its manifest, `baro.csv` and `truth/`.

use std::io::BufReader;
use std::path::Path;

use nalgebra::Vector3;

use super::{BoundInput, ImuVibration};
use crate::dataset::truth::Truth;
use crate::imu::STANDARD_GRAVITY_M_S2;
use crate::time::Timestamp;

/// Reads what [`super::flight_bound`] needs from `dir`: the IMU noise and the array's mounting
/// from `dataset.toml`, the barometer's sample times, and from `truth/` the poses, the APs, the
/// rotors' vibration (when `truth.toml` records it) and every AP's packets (a simulated dataset writes them all; a motion-capture truth lacks the
/// packets and is refused with a message saying so).
pub fn load_bound_input(dir: &Path) -> Result<BoundInput, String> {
    let manifest = crate::dataset::load::read_manifest(dir).map_err(|e| e.to_string())?;
    let noise = manifest.imu.noise.ok_or_else(|| {
        format!(
            "{}: dataset.toml has no [imu.noise]: the bound needs the IMU's noise",
            dir.display()
        )
    })?;
    let truth = Truth::load(dir).map_err(|e| e.to_string())?;
    if truth.aps.is_empty() {
        return Err(format!(
            "{}: truth/aps.csv is missing or empty: the bound needs the APs' true positions and \
             packets (a simulated dataset has them)",
            dir.display()
        ));
    }
    let aps = truth
        .aps
        .iter()
        .map(|a| Vector3::new(a.x_m, a.y_m, a.z_m))
        .collect();
    let packets = truth
        .packets
        .iter()
        .map(|rows| {
            rows.iter()
                .filter(|r| r.received)
                .map(|r| Timestamp(r.t_ns))
                .collect()
        })
        .collect();
    let baro = match &manifest.baro {
        Some(entry) => {
            let path = dir.join(&entry.file);
            let file = crate::io_safety::open_regular(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            crate::dataset::baro_csv::read(BufReader::new(file))
                .map_err(|e| format!("{}: {e}", path.display()))?
                .into_iter()
                .map(|s| s.t)
                .collect()
        }
        None => Vec::new(),
    };
    let vibration = truth
        .info
        .as_ref()
        .and_then(|i| i.imu_vibration.as_ref())
        .map(|v| {
            let over_axes = |d: [f64; 3]| (d.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt();
            ImuVibration {
                from: Timestamp(v.from_ns),
                to: Timestamp(v.to_ns),
                accel_density_m_s2_sqrt_hz: over_axes(v.accel_density_m_s2_sqrt_hz),
                gyro_density_rad_s_sqrt_hz: over_axes(v.gyro_density_rad_s_sqrt_hz),
            }
        });
    Ok(BoundInput {
        poses: truth.poses,
        noise,
        vibration,
        body_from_array: manifest.array.body_from_array(),
        aps,
        packets,
        baro,
        gravity_m_s2: truth.info.map_or(STANDARD_GRAVITY_M_S2, |i| i.gravity_m_s2),
    })
}
