//! A live session's inputs written as a dataset folder (docs/DATASET.md) that `wins run`
//! replays to the same trajectory.
//!
//! What is written is what the pipeline was given, in the order it was given: the IMU samples
//! and barometer readings as decoded from MAVLink, and each CSI record with its time already on
//! the flight controller's clock, in the card's format (a 5300 log, a Nexmon pcap). The CSI Tool's
//! log keeps 32-bit microseconds, so each AP's log counts from its first packet
//! (`timestamp_low` = µs since it, modulo 2³²; a pcap's time likewise) and the manifest's
//! `imu_minus_nic_ns` puts it back on the flight controller's clock; the session hands the
//! pipeline whole microseconds, so nothing is rounded away. The NIC's own timestamps are not
//! kept in the logs (the clock relation the session used is in its `stats.json`), nor are the
//! frame records (the manifest keeps each AP's `mac`).
//!
//! Every file is written in whole lines and whole records ([`WholeRecords`]), handed to the
//! files when [`Recorder::flush`] is called (`wins live` does every half second) and when a
//! buffer fills; the manifest is replaced atomically. A run killed while it records leaves a
//! dataset that `wins run` reads: every IMU and barometer row whole, every CSI log ending with
//! a whole record, the manifest naming each AP's first packet before its records reach the log.

use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use super::merge::Merged;
use crate::csi::logged::{Logged, encode};
use crate::csi::nexmon::write::pcap_header;
use crate::dataset::load::MANIFEST_FILE;
use crate::dataset::{BaroEntry, Manifest, baro_csv, imu_csv};
use crate::io_safety::WholeRecords;

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
    imu: WholeRecords<File>,
    baro: Option<WholeRecords<File>>,
    /// The barometer's nominal rate for the manifest, Hz.
    baro_rate_hz: f64,
    logs: Vec<WholeRecords<File>>,
    /// Each AP's first packet, µs on the flight controller's clock.
    first_us: Vec<Option<i64>>,
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
            logs.push(WholeRecords::new(File::create(dir.join(&ap.log))?));
        }
        let mut imu = WholeRecords::new(File::create(dir.join(IMU_FILE))?);
        imu.line(|b| writeln!(b, "{}", imu_csv::HEADER))?;
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
        let mut w = WholeRecords::new(File::create(self.dir.join(BARO_FILE))?);
        w.line(|b| writeln!(b, "{}", baro_csv::HEADER))?;
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
                self.imu.line(|b| imu_csv::write_row(b, s))?;
                self.counts[0] += 1;
            }
            Merged::Baro { t, altitude_m } => {
                if let Some(w) = &mut self.baro {
                    w.line(|b| writeln!(b, "{},{}", t.as_nanos(), altitude_m))?;
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
                // µs since the AP's first packet, as the card's clock keeps them.
                record.set_clock_us(t_us - base);
                // The manifest first: the record's time in the log needs the AP's base.
                if new_base {
                    if let Some(entry) = self.manifest.aps.get_mut(*ap) {
                        entry.imu_minus_nic_ns = base * 1000;
                    }
                    write_manifest(&self.dir, &self.manifest)?;
                }
                log.record(|b| {
                    // A Nexmon log is a pcap: its global header before the first packet.
                    if new_base && matches!(record, Logged::Nexmon(_)) {
                        pcap_header(b);
                    }
                    encode(&record, b)
                })?;
                self.counts[2] += 1;
            }
        }
        Ok(())
    }

    /// Hands what is buffered (whole rows and records) to every file.
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
        write_manifest(&self.dir, &self.manifest)
    }
}

/// Replaces the manifest of the recording in `dir` (atomically).
fn write_manifest(dir: &Path, manifest: &Manifest) -> io::Result<()> {
    let text = toml::to_string(manifest).map_err(io::Error::other)?;
    crate::io_safety::write_atomically(&dir.join(MANIFEST_FILE), |w| w.write_all(text.as_bytes()))
}
