//! A dataset read as it is consumed ([`DatasetStream`]): what [`super::Dataset::load`] gives,
//! without holding the IMU samples or the CSI records.
//!
//! Two passes over the files. [`DatasetStream::open`] reads the manifest, the calibration and
//! the barometer, and checks the IMU file and every log one row or record at a time
//! ([`super::incremental`]), keeping only counts: the [`InputReport`] and every error are
//! those of `Dataset::load`, before anything is run. [`DatasetStream::events`] then reads the
//! files again and yields the kept samples and records merged by time, as
//! `crate::run::replay` orders them (a packet before a barometer sample before an IMU
//! sample at the same time, APs in manifest order, each AP's records by time then log order).
//! Each AP's records wait in a buffer until no later record can come before them (the checks
//! never keep a record more than [`JUMP_BACK_NS`] before the latest kept), at most
//! [`MAX_REORDER`] of them.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::ap_reader::{ApEvent, ApReader};
use super::baro_csv::{self, BaroSample};
use super::checks::{self, CsiPacket, ImuLimits, InputReport};
use super::events::Sources;
pub use super::events::{DatasetEvent, Events};
use super::imu_csv::RowReader;
use super::incremental::{ApCheck, ImuCheck, JUMP_BACK_NS};
use super::load::{ApLog, Dataset, DatasetError, read_manifest};
use super::manifest::Manifest;
use crate::csi::Received;
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{SkipReason, read_log};
use crate::imu::ImuSample;
use crate::io_safety::open_regular;
use crate::rig::ChainCalibration;
use crate::time::Timestamp;

/// Records of one AP held at once to put them in time order; past it the earliest goes (only
/// a log with more than this many records within 0.1 s of NIC time gets there).
pub const MAX_REORDER: usize = 4096;

/// A checked dataset whose samples and records stay on disk until [`DatasetStream::events`].
#[derive(Clone, Debug)]
pub struct DatasetStream {
    /// The directory.
    pub dir: PathBuf,
    /// `dataset.toml`.
    pub manifest: Manifest,
    /// The NIC's chain calibration, when the manifest names one.
    pub calibration: Option<ChainCalibration>,
    /// Barometer readings (small: tens per second), strictly increasing in time.
    pub baro: Vec<BaroSample>,
    /// What the input checks dropped, counted and found.
    pub inputs: InputReport,
    /// The first and last IMU sample kept.
    pub imu_span: (Timestamp, Timestamp),
}

impl Dataset {
    /// Loads `dir/dataset.toml` and everything it names: the checks of
    /// [`DatasetStream::open`] (its errors, its report), then the kept samples and records read
    /// into memory ([`DatasetStream::into_memory`]).
    pub fn load(dir: impl AsRef<Path>) -> Result<Self, DatasetError> {
        DatasetStream::open(dir)?.into_memory()
    }
}

impl DatasetStream {
    /// Reads `dir/dataset.toml` and checks everything it names (module docs); the same errors,
    /// in the same order, as [`super::Dataset::load`].
    pub fn open(dir: impl AsRef<Path>) -> Result<Self, DatasetError> {
        Self::open_with(dir, true)
    }

    /// [`Self::open`]; without `read_calibration` the chain calibration the manifest names is
    /// not read at all (a run told to fly without one). A calibration the manifest names but
    /// that is not there is no calibration, with a warning saying so.
    pub fn open_with(dir: impl AsRef<Path>, read_calibration: bool) -> Result<Self, DatasetError> {
        let dir = dir.as_ref();
        let manifest = read_manifest(dir)?;
        let inputs_error = |source| DatasetError::Inputs {
            dir: dir.to_path_buf(),
            source,
        };
        let mut inputs = InputReport::default();
        let mut imu = ImuSource::open(dir, &manifest)?;
        let (mut first, mut last) = (None, None);
        while let Some(s) = imu.next_checked(&mut inputs)? {
            first = first.or(Some(s.t));
            last = Some(s.t);
        }
        imu.check
            .finish(imu.rows.cut_last_line(), &mut inputs)
            .map_err(inputs_error)?;
        let (Some(from), Some(to)) = (first, last) else {
            return Err(inputs_error(checks::InputError::NoImu("no sample".into())));
        };
        let mut inside = 0;
        let mut csi_span: Option<(Timestamp, Timestamp)> = None;
        for (l, entry) in manifest.aps.iter().enumerate() {
            let path = dir.join(&entry.log);
            let card = manifest.array.card;
            let reader = ApReader::open(&path, card, &entry.name, Some(&mut inputs.warnings))?;
            let mut check = ApCheck::new(l, &entry.name, entry.imu_minus_nic_ns, true);
            let (mut before, mut after, mut kept) = (0, 0, 0);
            for event in reader {
                let ApEvent::Packet(record) = event? else {
                    continue;
                };
                let Some(p) = check.push(record, &mut inputs).map_err(inputs_error)? else {
                    continue;
                };
                kept += 1;
                before += u64::from(p.t < from);
                after += u64::from(p.t > to);
                csi_span = Some(csi_span.map_or((p.t, p.t), |(a, b)| (a.min(p.t), b.max(p.t))));
            }
            check.finish(&mut inputs);
            if let Some(ap) = inputs.aps.last_mut() {
                ap.before_imu = before;
                ap.after_imu = after;
            }
            inside += kept - before - after;
        }
        let offsets: Vec<(&str, i64)> = manifest
            .aps
            .iter()
            .map(|a| (a.name.as_str(), a.imu_minus_nic_ns))
            .collect();
        checks::judge_spans((from, to), inside, csi_span, &offsets, &mut inputs)
            .map_err(inputs_error)?;
        checks::summarize(&mut inputs);
        let calibration = match &manifest.array.calibration {
            Some(file) if read_calibration => {
                let path = dir.join(file);
                if path.exists() {
                    Some(ChainCalibration::load(&path)?)
                } else {
                    inputs.warnings.push(format!(
                        "dataset.toml names the chain calibration {file}, which is not in the \
                         dataset: running without one (remove the line, or add the file: wins \
                         calibrate)"
                    ));
                    None
                }
            }
            _ => None,
        };
        let baro = match &manifest.baro {
            Some(entry) => {
                let path = dir.join(&entry.file);
                let file = open_regular(&path).map_err(|source| DatasetError::Io {
                    path: path.clone(),
                    source,
                })?;
                baro_csv::read(BufReader::new(file))
                    .map_err(|source| DatasetError::Baro { path, source })?
            }
            None => Vec::new(),
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            manifest,
            calibration,
            baro,
            inputs,
            imu_span: (from, to),
        })
    }

    /// The checked dataset read into memory: the kept IMU samples, and every AP's log whole
    /// (its skipped stretches listed) with its kept records in log order.
    pub fn into_memory(self) -> Result<Dataset, DatasetError> {
        // The checks' counts were made by `open`; these are thrown away.
        let mut scratch = InputReport::default();
        let mut source = ImuSource::open(&self.dir, &self.manifest)?;
        let mut imu = Vec::new();
        while let Some(s) = source.next_checked(&mut scratch)? {
            imu.push(s);
        }
        let mut aps = Vec::with_capacity(self.manifest.aps.len());
        let bandwidth_mhz = self.manifest.channel.bandwidth.mhz();
        for (l, entry) in self.manifest.aps.iter().enumerate() {
            let path = self.dir.join(&entry.log);
            let (records, skips): (Vec<Received>, _) = match self.manifest.array.card {
                CaptureFormat::Intel5300 => {
                    let log = read_log(&path)?;
                    (
                        log.records.into_iter().map(Received::from).collect(),
                        log.skips,
                    )
                }
                card => {
                    let mut records = Vec::new();
                    for event in ApReader::open(&path, card, &entry.name, None)? {
                        if let ApEvent::Packet(r) = event? {
                            records.push(r);
                        }
                    }
                    (records, Vec::new())
                }
            };
            let bandwidth_mismatches = records
                .iter()
                .filter(|r| r.bandwidth_mhz() != bandwidth_mhz)
                .count();
            let mut check = ApCheck::new(l, &entry.name, entry.imu_minus_nic_ns, false);
            let mut packets = Vec::with_capacity(records.len());
            for record in records {
                let kept =
                    check
                        .push(record, &mut scratch)
                        .map_err(|source| DatasetError::Inputs {
                            dir: self.dir.clone(),
                            source,
                        })?;
                packets.extend(kept);
            }
            aps.push(ApLog {
                name: entry.name.clone(),
                packets,
                skips,
                bandwidth_mismatches,
            });
        }
        Ok(Dataset {
            dir: self.dir,
            manifest: self.manifest,
            imu,
            aps,
            calibration: self.calibration,
            baro: self.baro,
            inputs: self.inputs,
        })
    }

    /// The kept IMU samples, barometer readings (when `with_baro`) and CSI records, merged by
    /// time (module docs).
    pub fn events(&self, with_baro: bool) -> Result<Events<'static>, DatasetError> {
        let aps = self
            .manifest
            .aps
            .iter()
            .enumerate()
            .map(|(l, entry)| {
                let path = self.dir.join(&entry.log);
                Ok(ApSource {
                    reader: ApReader::open(&path, self.manifest.array.card, &entry.name, None)?,
                    check: ApCheck::new(l, &entry.name, entry.imu_minus_nic_ns, false),
                    buffer: BTreeMap::new(),
                    next_seq: 0,
                    done: false,
                    path,
                    skips: SkipCount::default(),
                })
            })
            .collect::<Result<Vec<_>, DatasetError>>()?;
        let files = Files {
            imu: ImuSource::open(&self.dir, &self.manifest)?,
            aps,
        };
        let baro = if with_baro {
            self.baro.clone()
        } else {
            Vec::new()
        };
        Ok(Events::new(Box::new(files), baro))
    }
}

/// The IMU file's rows through its checks.
#[derive(Debug)]
struct ImuSource {
    rows: RowReader<BufReader<File>>,
    check: ImuCheck,
    path: PathBuf,
}

impl ImuSource {
    fn open(dir: &Path, manifest: &Manifest) -> Result<Self, DatasetError> {
        let path = dir.join(&manifest.imu.file);
        let file = open_regular(&path).map_err(|source| DatasetError::Io {
            path: path.clone(),
            source,
        })?;
        let limits = ImuLimits {
            rate_hz: manifest.imu.rate_hz,
            accel_range_m_s2: manifest.imu.accel_range_m_s2,
            gyro_range_rad_s: manifest.imu.gyro_range_rad_s,
        };
        Ok(Self {
            rows: RowReader::new(BufReader::new(file)),
            check: ImuCheck::new(limits),
            path,
        })
    }

    /// The next kept sample, its drops counted in `report`.
    fn next_checked(
        &mut self,
        report: &mut InputReport,
    ) -> Result<Option<ImuSample>, DatasetError> {
        loop {
            let row = self.rows.next_row().map_err(|source| DatasetError::Imu {
                path: self.path.clone(),
                source,
            })?;
            let Some(row) = row else {
                return Ok(None);
            };
            if let Some(s) = self.check.push(row, report) {
                return Ok(Some(s));
            }
        }
    }
}

/// Stretches of a log its reader skipped: counted as `read_log` lists them (consecutive
/// stretches of one reason as one).
#[derive(Clone, Copy, Debug, Default)]
struct SkipCount {
    count: u64,
    bytes: u64,
    last: Option<(u64, SkipReason)>,
}

/// One AP's log through its checks and its reorder buffer.
#[derive(Debug)]
struct ApSource {
    reader: ApReader,
    check: ApCheck,
    /// Kept records by (time ns, order kept).
    buffer: BTreeMap<(i64, u64), CsiPacket>,
    next_seq: u64,
    done: bool,
    path: PathBuf,
    skips: SkipCount,
}

impl ApSource {
    /// The next record in time order, or `None` at the end of the log.
    fn next_packet(&mut self, report: &mut InputReport) -> Result<Option<CsiPacket>, DatasetError> {
        loop {
            if let Some((&(t, _), _)) = self.buffer.first_key_value()
                && (self.done
                    || t < self.check.latest_ns().saturating_sub(JUMP_BACK_NS)
                    || self.buffer.len() > MAX_REORDER)
            {
                return Ok(self.buffer.pop_first().map(|(_, p)| p));
            }
            if self.done {
                return Ok(None);
            }
            match self.reader.next() {
                None => self.done = true,
                Some(event) => match event? {
                    ApEvent::Packet(record) => {
                        let kept = self.check.push(record, report).map_err(|source| {
                            DatasetError::Inputs {
                                dir: self.path.clone(),
                                source,
                            }
                        })?;
                        if let Some(p) = kept {
                            self.buffer.insert((p.t.0, self.next_seq), p);
                            self.next_seq += 1;
                        }
                    }
                    ApEvent::Lost(n) => self.skips.count += n,
                    ApEvent::Skipped(s) => {
                        let k = &mut self.skips;
                        if k.last != Some((s.offset, s.reason)) {
                            k.count += 1;
                        }
                        k.bytes += s.len;
                        k.last = Some((s.offset + s.len, s.reason));
                    }
                },
            }
        }
    }
}

/// A dataset's files as [`Sources`]: the IMU file and every AP's log through their checks.
#[derive(Debug)]
struct Files {
    imu: ImuSource,
    aps: Vec<ApSource>,
}

impl Sources for Files {
    fn next_imu(&mut self) -> Result<Option<ImuSample>, DatasetError> {
        // The checks' counts were made by the first pass; these are thrown away.
        self.imu.next_checked(&mut InputReport::default())
    }

    fn next_packet(&mut self, ap: usize) -> Result<Option<CsiPacket>, DatasetError> {
        match self.aps.get_mut(ap) {
            Some(source) => source.next_packet(&mut InputReport::default()),
            None => Ok(None),
        }
    }

    fn aps(&self) -> usize {
        self.aps.len()
    }

    fn skips(&self) -> Vec<(u64, u64)> {
        self.aps
            .iter()
            .map(|a| (a.skips.count, a.skips.bytes))
            .collect()
    }

    fn buffered(&self) -> usize {
        self.aps.iter().map(|a| a.buffer.len()).sum()
    }
}
