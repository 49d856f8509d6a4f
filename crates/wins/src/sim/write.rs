//! Writing a simulated flight as a dataset directory (layout: `crate::dataset`).

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::lab_calibration::{CALIBRATION_FILE, lab_calibration};
use super::run::ApOutput;
use super::run::{SimOutput, ap_mac, rotors_interval_s};
use super::scenario::Scenario;
use super::vibration::broadband_density;
use crate::csi::logged::{LogWriter, Logged};
use crate::dataset::load::{MANIFEST_FILE, imu_minus_nic_ns};
use crate::dataset::manifest::{
    ApEntry, ArrayEntry, BaroEntry, ChannelEntry, FORMAT, ImuEntry, Manifest, VERSION,
};
use crate::dataset::manifest::{DEFAULT_ACCEL_RANGE_M_S2, DEFAULT_GYRO_RANGE_RAD_S, format_mac};
use crate::dataset::truth::{
    self, ApRow, BaroRow, BiasRow, PacketRow, Pose, TRUTH_DIR, TruthInfo, VibrationTruth,
    packets_file,
};
use crate::dataset::{baro_csv, imu_csv};

/// The IMU file's name in simulated datasets.
pub const IMU_FILE: &str = "imu.csv";
/// The barometer file's name in simulated datasets.
pub const BARO_FILE: &str = "baro.csv";

/// What was written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WriteReport {
    /// Files written, relative to the dataset directory.
    pub files: Vec<PathBuf>,
    /// IMU samples.
    pub imu_samples: usize,
    /// Per AP: (name, packets sent, packets received).
    pub packets: Vec<(String, usize, usize)>,
    /// CSI components clipped by the 8-bit quantizer, over all APs.
    pub clipped: u64,
}

/// A dataset directory that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}")]
pub struct WriteError {
    /// The file or directory.
    pub path: PathBuf,
    /// The cause.
    pub source: io::Error,
}

/// Writes `output` of `scenario` into `dir` (created if needed; existing files are replaced).
pub fn write_dataset(
    dir: &Path,
    scenario: &Scenario,
    output: &SimOutput,
) -> Result<WriteReport, WriteError> {
    let truth_dir = dir.join(TRUTH_DIR);
    fs::create_dir_all(&truth_dir).map_err(|source| WriteError {
        path: truth_dir.clone(),
        source,
    })?;
    let mut report = WriteReport {
        imu_samples: output.imu.len(),
        ..WriteReport::default()
    };
    let mut put = |rel: &str, f: &mut dyn FnMut(&mut BufWriter<File>) -> io::Result<()>| {
        let path = dir.join(rel);
        let result = File::create(&path).and_then(|file| {
            let mut w = BufWriter::new(file);
            f(&mut w)?;
            w.flush()
        });
        result.map_err(|source| WriteError {
            path: path.clone(),
            source,
        })?;
        report.files.push(PathBuf::from(rel));
        Ok::<(), WriteError>(())
    };

    let manifest = manifest(scenario);
    let manifest_text = toml::to_string(&manifest).map_err(|e| WriteError {
        path: dir.join(MANIFEST_FILE),
        source: io::Error::other(e),
    })?;
    put(MANIFEST_FILE, &mut |w| {
        w.write_all(manifest_text.as_bytes())
    })?;
    put(IMU_FILE, &mut |w| imu_csv::write(w, &output.imu))?;
    if manifest.baro.is_some() {
        put(BARO_FILE, &mut |w| baro_csv::write(w, &output.baro))?;
        let rows: Vec<BaroRow> = output
            .baro_truth
            .iter()
            .map(|r| BaroRow {
                t_ns: r.t.as_nanos(),
                height_m: r.height_m,
                offset_m: r.offset_m,
                drift_m: r.drift_m,
            })
            .collect();
        put(&format!("{TRUTH_DIR}/{BARO_FILE}"), &mut |w| {
            truth::write_csv(w, &rows)
        })?;
    }
    if scenario.radio.lab_calibration {
        let calibration = lab_calibration(scenario)
            .map_err(io::Error::other)
            .and_then(|c| toml::to_string(&c).map_err(io::Error::other))
            .map_err(|source| WriteError {
                path: dir.join(CALIBRATION_FILE),
                source,
            })?;
        put(CALIBRATION_FILE, &mut |w| {
            w.write_all(calibration.as_bytes())
        })?;
    }

    let mut clipped = 0u64;
    let mut counts = Vec::new();
    for (ap, entry) in output.aps.iter().zip(&manifest.aps) {
        put(&entry.log, &mut |w| write_log(w, ap))?;
        let rows: Vec<PacketRow> = ap
            .packets
            .iter()
            .map(|p| {
                let t = &p.truth;
                PacketRow {
                    t_ns: p.t.as_nanos(),
                    received: p.record.is_some(),
                    bfee_count: p.record.as_ref().map_or(0, Logged::count),
                    aoa_rad: t.aoa_rad,
                    aoa_deg: t.aoa_rad.to_degrees(),
                    elevation_rad: t.elevation_rad,
                    in_front: t.in_front,
                    tof_s: t.tof_s,
                    range_m: t.range_m,
                    direct_obstructed: t.direct_obstructed,
                    snr_db: t.snr_db,
                    k_factor_db: t.k_factor_db,
                    sto_s: t.sto_s,
                    common_phase_rad: t.common_phase_rad,
                    clipped: t.clipped,
                }
            })
            .collect();
        clipped += ap
            .received_records()
            .map(|(p, _)| u64::from(p.truth.clipped))
            .sum::<u64>();
        put(
            &format!("{TRUTH_DIR}/{}", packets_file(&ap.config.name)),
            &mut |w| truth::write_csv(w, &rows),
        )?;
        counts.push((
            ap.config.name.clone(),
            ap.packets.len(),
            ap.received_records().count(),
        ));
    }

    let poses: Vec<Pose> = output
        .states
        .iter()
        .map(|(t, s)| Pose {
            t: *t,
            p_b_in_w: s.p_b_in_w,
            world_from_body: s.world_from_body,
        })
        .collect();
    put(&format!("{TRUTH_DIR}/poses.tum"), &mut |w| {
        truth::write_tum(w, &poses)
    })?;
    let aps: Vec<ApRow> = scenario
        .aps
        .iter()
        .map(|a| ApRow {
            name: a.name.clone(),
            x_m: a.position_m[0],
            y_m: a.position_m[1],
            z_m: a.position_m[2],
        })
        .collect();
    put(&format!("{TRUTH_DIR}/aps.csv"), &mut |w| {
        truth::write_csv(w, &aps)
    })?;
    let biases: Vec<BiasRow> = output
        .imu
        .iter()
        .zip(&output.imu_biases)
        .map(|(s, b)| BiasRow {
            t_ns: s.t.as_nanos(),
            bg_x: b.gyro_rad_s.x,
            bg_y: b.gyro_rad_s.y,
            bg_z: b.gyro_rad_s.z,
            ba_x: b.accel_m_s2.x,
            ba_y: b.accel_m_s2.y,
            ba_z: b.accel_m_s2.z,
        })
        .collect();
    put(&format!("{TRUTH_DIR}/imu_biases.csv"), &mut |w| {
        truth::write_csv(w, &biases)
    })?;
    let info = TruthInfo {
        scenario: scenario.name.clone(),
        seed: scenario.seed,
        chain_phase_offsets_rad: output.chain_phase_offsets_rad.clone(),
        gravity_m_s2: scenario.gravity_m_s2,
        imu_vibration: vibration_truth(scenario),
    };
    let info_text = toml::to_string(&info).map_err(|e| WriteError {
        path: truth_dir.join("truth.toml"),
        source: io::Error::other(e),
    })?;
    put(&format!("{TRUTH_DIR}/truth.toml"), &mut |w| {
        w.write_all(info_text.as_bytes())
    })?;
    let scenario_text = scenario.to_toml().map_err(|e| WriteError {
        path: truth_dir.join("scenario.toml"),
        source: io::Error::other(e),
    })?;
    put(&format!("{TRUTH_DIR}/scenario.toml"), &mut |w| {
        w.write_all(scenario_text.as_bytes())
    })?;
    put("README.md", &mut |w| w.write_all(DATASET_README.as_bytes()))?;
    report.packets = counts;
    report.clipped = clipped;
    Ok(report)
}

/// One AP's received records in its card's log format.
fn write_log(w: &mut BufWriter<File>, ap: &ApOutput) -> io::Result<()> {
    let mut log = LogWriter::new(w);
    for (_, record) in ap.received_records() {
        log.write(record)?;
    }
    log.finish().map(|_| ())
}

/// The vibration's density near 0 Hz while the rotors spin, for `truth.toml`.
fn vibration_truth(scenario: &Scenario) -> Option<VibrationTruth> {
    let model = scenario.imu.vibration_model()?;
    let d = broadband_density(&model, scenario.imu.period_ns() as f64 * 1e-9);
    let (from_s, to_s) = rotors_interval_s(scenario);
    let ns = |s: f64| (s.min(scenario.duration_s) * 1e9).round() as i64;
    Some(VibrationTruth {
        from_ns: ns(from_s),
        to_ns: ns(to_s),
        accel_density_m_s2_sqrt_hz: [d[0], d[1], d[2]],
        gyro_density_rad_s_sqrt_hz: [d[3], d[4], d[5]],
    })
}

/// The manifest a simulated scenario gets.
pub fn manifest(scenario: &Scenario) -> Manifest {
    Manifest {
        format: FORMAT.into(),
        version: VERSION,
        description: format!(
            "simulated by wins {} from scenario {:?} (seed {}): {}",
            env!("CARGO_PKG_VERSION"),
            scenario.name,
            scenario.seed,
            scenario.description
        ),
        imu: ImuEntry {
            file: IMU_FILE.into(),
            rate_hz: scenario.imu.rate_hz,
            accel_range_m_s2: DEFAULT_ACCEL_RANGE_M_S2,
            gyro_range_rad_s: DEFAULT_GYRO_RANGE_RAD_S,
            noise: Some(scenario.imu.model.noise()),
        },
        array: ArrayEntry {
            card: scenario.radio.card,
            calibration: scenario
                .radio
                .lab_calibration
                .then(|| CALIBRATION_FILE.into()),
            ..ArrayEntry::new(scenario.array.geometry, &scenario.body_from_array())
        },
        channel: ChannelEntry {
            center_freq_hz: scenario.radio.center_freq_hz,
            bandwidth: scenario.radio.bandwidth,
        },
        aps: scenario
            .aps
            .iter()
            .enumerate()
            .map(|(l, a)| ApEntry {
                name: a.name.clone(),
                log: format!("{}.dat", a.name),
                imu_minus_nic_ns: imu_minus_nic_ns(scenario.radio.nic_clock_at_imu_zero_us),
                // A locally administered address per AP, for `wins replay --realtime`'s frame
                // records.
                mac: Some(format_mac(&ap_mac(l))),
            })
            .collect(),
        baro: scenario.baro.as_ref().map(|b| BaroEntry {
            file: BARO_FILE.into(),
            rate_hz: b.rate_hz,
        }),
    }
}

/// The README written into every simulated dataset.
const DATASET_README: &str = include_str!("dataset_readme.md");
