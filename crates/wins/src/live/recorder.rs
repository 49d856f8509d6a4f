//! A live session's inputs written as a dataset folder (docs/DATASET.md) that `wins run`
//! replays to the same trajectory.
//!
//! What is written is what the pipeline was given, in the order it was given: the IMU samples
//! and barometer readings as decoded from MAVLink, and each CSI record with its time already on
//! the flight controller's clock. The CSI Tool's log keeps 32-bit microseconds, so each AP's log
//! counts from its first packet (`timestamp_low` = µs since it, modulo 2³²) and the manifest's
//! `imu_minus_nic_ns` puts it back on the flight controller's clock; the session hands the
//! pipeline whole microseconds, so nothing is rounded away. The NIC's own timestamps are not
//! kept in the logs (the clock relation the session used is in its `stats.json`), nor are the
//! frame records (the manifest keeps each AP's `mac`).

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::merge::Merged;
use crate::csi::intel5300::encode_record;
use crate::dataset::load::MANIFEST_FILE;
use crate::dataset::{BaroEntry, Manifest, baro_csv, imu_csv};

/// The IMU file of a recording.
const IMU_FILE: &str = "imu.csv";
/// Its barometer file.
const BARO_FILE: &str = "baro.csv";
/// Its calibration file (a copy of the rig's).
const CALIBRATION_FILE: &str = "calibration.toml";

/// Writes a recording (module doc).
#[derive(Debug)]
pub struct Recorder {
    dir: PathBuf,
    manifest: Manifest,
    imu: BufWriter<File>,
    baro: Option<BufWriter<File>>,
    /// The barometer's nominal rate for the manifest, Hz.
    baro_rate_hz: f64,
    logs: Vec<BufWriter<File>>,
    /// Each AP's first packet, µs on the flight controller's clock.
    first_us: Vec<Option<i64>>,
    buf: Vec<u8>,
    /// Inputs written: IMU samples, barometer readings, CSI records.
    pub counts: [u64; 3],
}

impl Recorder {
    /// Creates `dir` (which must not exist yet) with the files of a recording of a rig
    /// described by `rig` (read from `rig_dir`, whose calibration file is copied); the
    /// barometer's file comes with [`Recorder::enable_baro`].
    pub fn create(dir: &Path, rig_dir: &Path, rig: &Manifest) -> io::Result<Self> {
        fs::create_dir(dir)?;
        let mut manifest = rig.clone();
        manifest.description = format!(
            "recorded by wins {} live from the rig {}; times on the flight controller's clock",
            env!("CARGO_PKG_VERSION"),
            rig_dir.display()
        );
        manifest.imu.file = IMU_FILE.into();
        manifest.baro = None;
        if let Some(file) = &rig.array.calibration {
            fs::copy(rig_dir.join(file), dir.join(CALIBRATION_FILE))?;
            manifest.array.calibration = Some(CALIBRATION_FILE.into());
        }
        let mut logs = Vec::with_capacity(manifest.aps.len());
        for (l, ap) in manifest.aps.iter_mut().enumerate() {
            ap.log = format!("ap{l}.dat");
            ap.imu_minus_nic_ns = 0;
            logs.push(BufWriter::new(File::create(dir.join(&ap.log))?));
        }
        let mut imu = BufWriter::new(File::create(dir.join(IMU_FILE))?);
        writeln!(imu, "{}", imu_csv::HEADER)?;
        let baro_rate_hz = rig.baro.as_ref().map_or(rig.imu.rate_hz, |b| b.rate_hz);
        let n = manifest.aps.len();
        let recorder = Self {
            dir: dir.to_path_buf(),
            manifest,
            imu,
            baro: None,
            baro_rate_hz,
            logs,
            first_us: vec![None; n],
            buf: Vec::with_capacity(512),
            counts: [0; 3],
        };
        recorder.write_manifest()?;
        Ok(recorder)
    }

    /// Records the barometer too (its file and manifest entry).
    pub fn enable_baro(&mut self) -> io::Result<()> {
        if self.baro.is_some() {
            return Ok(());
        }
        let mut w = BufWriter::new(File::create(self.dir.join(BARO_FILE))?);
        writeln!(w, "{}", baro_csv::HEADER)?;
        self.baro = Some(w);
        self.manifest.baro = Some(BaroEntry {
            file: BARO_FILE.into(),
            rate_hz: self.baro_rate_hz,
        });
        self.write_manifest()
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes one input, as the pipeline was given it.
    pub fn record(&mut self, input: &Merged) -> io::Result<()> {
        match input {
            Merged::Imu(s) => {
                imu_csv::write_row(&mut self.imu, s)?;
                self.counts[0] += 1;
            }
            Merged::Baro { t, altitude_m } => {
                if let Some(w) = &mut self.baro {
                    writeln!(w, "{},{}", t.as_nanos(), altitude_m)?;
                    self.counts[1] += 1;
                }
            }
            Merged::Csi { ap, t, record } => {
                let (Some(log), Some(first)) = (self.logs.get_mut(*ap), self.first_us.get_mut(*ap))
                else {
                    return Ok(());
                };
                let t_us = t.as_nanos().div_euclid(1000);
                let new_base = first.is_none();
                let base = *first.get_or_insert(t_us);
                let mut record = record.as_ref().clone();
                // µs since the AP's first packet, modulo 2³² as the NIC's counter wraps.
                record.header.timestamp_low = (t_us - base).rem_euclid(1 << 32) as u32;
                self.buf.clear();
                encode_record(&record, &mut self.buf);
                log.write_all(&self.buf)?;
                self.counts[2] += 1;
                if new_base {
                    if let Some(entry) = self.manifest.aps.get_mut(*ap) {
                        entry.imu_minus_nic_ns = base * 1000;
                    }
                    self.write_manifest()?;
                }
            }
        }
        Ok(())
    }

    /// Flushes every file.
    pub fn flush(&mut self) -> io::Result<()> {
        self.imu.flush()?;
        if let Some(w) = &mut self.baro {
            w.flush()?;
        }
        for log in &mut self.logs {
            log.flush()?;
        }
        Ok(())
    }

    /// Flushes and closes every file, the manifest written last.
    pub fn finish(mut self) -> io::Result<PathBuf> {
        self.flush()?;
        self.write_manifest()?;
        Ok(self.dir)
    }

    fn write_manifest(&self) -> io::Result<()> {
        let text = toml::to_string(&self.manifest).map_err(io::Error::other)?;
        crate::io_safety::write_atomically(&self.dir.join(MANIFEST_FILE), |w| {
            w.write_all(text.as_bytes())
        })
    }
}
