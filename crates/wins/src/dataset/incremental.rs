//! The input checks one sample or record at a time ([`ImuCheck`], [`ApCheck`]), with state that
//! does not grow with the flight's length, so a reader checks a file as it streams it
//! ([`super::stream::DatasetStream::open`]).
//!
//! What is kept: the IMU's sample intervals as a histogram (exact while they take at most
//! [`MAX_INTERVALS`] distinct values, else in power-of-two buckets of nanoseconds, so the median
//! rate is then approximate), the first gaps (later ones are counted); per AP, the records kept
//! within [`JUMP_BACK_NS`] of the latest (a record further back is either a repeat or after a
//! clock jump, never kept) and, when repeats are to be told from clock jumps, the NIC time and
//! header of the last [`MAX_REMEMBERED`] records kept (a repeat of an older one counts as after
//! a clock jump).

use std::collections::{BTreeMap, HashSet, VecDeque};

use super::checks::{
    ApInputReport, CsiPacket, GAP_PERIODS, ImuLimits, InputError, InputReport, Kind, MAX_LISTED,
    SILENCE_S,
};
use crate::csi::Received;
use crate::imu::ImuSample;
use crate::time::{NANOS_PER_SEC, Timestamp};

/// A NIC clock going back by more than this is a jump (a restart), not a reordered packet, ns.
pub const JUMP_BACK_NS: i64 = 100_000_000;
/// Distinct IMU sample intervals kept exactly for the median rate.
pub const MAX_INTERVALS: usize = 1 << 16;
/// Kept records per AP remembered to tell a repeat from a clock jump.
pub const MAX_REMEMBERED: usize = 1 << 18;

/// The IMU's checks, one row at a time.
#[derive(Clone, Debug)]
pub struct ImuCheck {
    limits: ImuLimits,
    gap_ns: i64,
    last: Option<Timestamp>,
    intervals: Intervals,
    /// The first gaps `(start, length ns)`, reported after the rows' events.
    gaps: Vec<(Timestamp, i64)>,
    gaps_not_kept: u64,
}

impl ImuCheck {
    /// A check against the manifest's `limits`.
    pub fn new(limits: ImuLimits) -> Self {
        Self {
            limits,
            gap_ns: (GAP_PERIODS / limits.rate_hz * NANOS_PER_SEC as f64) as i64,
            last: None,
            intervals: Intervals::default(),
            gaps: Vec::new(),
            gaps_not_kept: 0,
        }
    }

    /// The sample, when it is kept; else it is counted in `report`.
    pub fn push(&mut self, s: ImuSample, report: &mut InputReport) -> Option<ImuSample> {
        report.imu.rows += 1;
        let mut values = s.gyro_rad_s.iter().chain(s.accel_m_s2.iter());
        if values.any(|v| !v.is_finite()) {
            report.imu.not_finite += 1;
            report.event(
                Kind::NotFinite,
                s.t,
                "IMU sample with a value that is not finite: dropped".into(),
            );
            return None;
        }
        let limits = &self.limits;
        if s.accel_m_s2.amax() >= limits.accel_range_m_s2
            || s.gyro_rad_s.amax() >= limits.gyro_range_rad_s
        {
            report.imu.beyond_range += 1;
            report.event(
                Kind::BeyondRange,
                s.t,
                format!(
                    "IMU sample at or beyond the sensor's range (|a| {:.1} m/s² of {:.1}, |ω| \
                     {:.2} rad/s of {:.2}): dropped",
                    s.accel_m_s2.amax(),
                    limits.accel_range_m_s2,
                    s.gyro_rad_s.amax(),
                    limits.gyro_range_rad_s
                ),
            );
            return None;
        }
        if let Some(prev) = self.last {
            if s.t <= prev {
                report.imu.time_not_increasing += 1;
                report.event(
                    Kind::TimeBack,
                    s.t,
                    format!(
                        "IMU time goes back from {:.6} s: sample dropped",
                        prev.as_secs_f64()
                    ),
                );
                return None;
            }
            let dt = s.t.0 - prev.0;
            self.intervals.add(dt);
            if dt > self.gap_ns {
                report.imu.gaps += 1;
                let dt_s = dt as f64 / NANOS_PER_SEC as f64;
                report.imu.longest_gap_s = report.imu.longest_gap_s.max(dt_s);
                if self.gaps.len() < MAX_LISTED {
                    self.gaps.push((prev, dt));
                } else {
                    self.gaps_not_kept += 1;
                }
            }
        }
        self.last = Some(s.t);
        report.imu.samples += 1;
        Some(s)
    }

    /// The end of the file (`cut_last_line`: the line of a last row without a line end): the
    /// gaps' events, the median rate against the declared one.
    pub fn finish(
        self,
        cut_last_line: Option<usize>,
        report: &mut InputReport,
    ) -> Result<(), InputError> {
        if let Some(line) = cut_last_line {
            report.imu.cut_last_line = true;
            report.event(
                Kind::CutLine,
                self.last.unwrap_or(Timestamp(0)),
                format!("the IMU file's last line ({line}) has no line end (cut?): dropped"),
            );
        }
        if report.imu.samples < 2 {
            return Err(InputError::NoImu(format!(
                "{} of {} rows kept",
                report.imu.samples, report.imu.rows
            )));
        }
        for (t, dt) in self.gaps {
            let dt_s = dt as f64 / NANOS_PER_SEC as f64;
            report.event(Kind::Gap, t, format!("IMU gap of {dt_s:.3} s"));
        }
        report.events_not_listed += self.gaps_not_kept;
        let median_dt = self.intervals.median().max(1);
        let measured_hz = NANOS_PER_SEC as f64 / median_dt as f64;
        report.imu.measured_rate_hz = measured_hz;
        let declared = self.limits.rate_hz;
        let factor = (measured_hz / declared).max(declared / measured_hz);
        if factor > RATE_ERROR_FACTOR {
            return Err(InputError::ImuRate {
                measured_hz,
                declared_hz: declared,
            });
        }
        if factor > RATE_WARN_FACTOR {
            report.warnings.push(format!(
                "the IMU runs at {measured_hz:.1} Hz (median), imu.rate_hz says {declared} Hz"
            ));
        }
        Ok(())
    }
}

/// A measured IMU rate this far (as a factor) from the declared one is a warning.
const RATE_WARN_FACTOR: f64 = 1.5;
/// A measured IMU rate this far from the declared one is an error (the timestamps' unit).
const RATE_ERROR_FACTOR: f64 = 20.0;

/// Sample intervals, ns, as counts per value (in buckets of `2^shift` ns once there are too many
/// distinct values).
#[derive(Clone, Debug, Default)]
struct Intervals {
    counts: BTreeMap<i64, u64>,
    shift: u32,
    total: u64,
}

impl Intervals {
    fn add(&mut self, dt: i64) {
        *self
            .counts
            .entry(dt >> self.shift << self.shift)
            .or_insert(0) += 1;
        self.total += 1;
        while self.counts.len() > MAX_INTERVALS {
            self.shift += 1;
            let shift = self.shift;
            let mut coarse = BTreeMap::new();
            for (v, n) in std::mem::take(&mut self.counts) {
                *coarse.entry(v >> shift << shift).or_insert(0) += n;
            }
            self.counts = coarse;
        }
    }

    /// The interval at position `total / 2` in sorted order (0 without any).
    fn median(&self) -> i64 {
        let mut below = 0;
        for (&v, &n) in &self.counts {
            below += n;
            if below > self.total / 2 {
                return v;
            }
        }
        0
    }
}

/// One AP's checks, one record at a time.
#[derive(Clone, Debug)]
pub struct ApCheck {
    index: usize,
    imu_minus_nic_ns: i64,
    ap: ApInputReport,
    latest: i64,
    after_jump: bool,
    /// Kept records within [`JUMP_BACK_NS`] of `latest` (or newer than an older one), in the
    /// order kept.
    recent: VecDeque<(i64, u128)>,
    /// With repeats told from clock jumps: the last [`MAX_REMEMBERED`] kept records, oldest
    /// first, and the same as a set.
    remembered: Option<Remembered>,
}

/// Kept records as (time ns, [`Received::repeat_key`]): in the order kept, and as a set.
type Remembered = (VecDeque<(i64, u128)>, HashSet<(i64, u128)>);

impl ApCheck {
    /// The checks of AP `index` (its place in the manifest) named `name`. `tell_repeats`:
    /// remember kept records to tell a repeat from a clock jump (the counts only; which records
    /// are kept does not depend on it).
    pub fn new(index: usize, name: &str, imu_minus_nic_ns: i64, tell_repeats: bool) -> Self {
        Self {
            index,
            imu_minus_nic_ns,
            ap: ApInputReport {
                name: name.to_string(),
                ..ApInputReport::default()
            },
            latest: i64::MIN,
            after_jump: false,
            recent: VecDeque::new(),
            remembered: tell_repeats.then(Default::default),
        }
    }

    /// The latest time kept, ns on the IMU clock (`i64::MIN` before any): every record kept
    /// later is at least [`JUMP_BACK_NS`] after it minus.
    pub fn latest_ns(&self) -> i64 {
        self.latest
    }

    /// The record placed on the IMU clock when it is kept; else it is counted.
    pub fn push(
        &mut self,
        record: impl Into<Received>,
        report: &mut InputReport,
    ) -> Result<Option<CsiPacket>, InputError> {
        let record = record.into();
        self.ap.records += 1;
        let nic_ns = record.nic_time_ns();
        let t = nic_ns
            .checked_add(self.imu_minus_nic_ns)
            .filter(|&t| Timestamp(t).is_in_range())
            .ok_or_else(|| InputError::OffsetOverflow {
                ap: self.ap.name.clone(),
                offset_ns: self.imu_minus_nic_ns,
                nic_ns,
            })?;
        let name = &self.ap.name;
        let key = record.repeat_key();
        if t <= self.latest && self.is_repeat(t, key) {
            if self.ap.repeated == 0 {
                report.event(
                    Kind::Repeated(self.index),
                    Timestamp(t),
                    format!(
                        "AP {name}: records repeat earlier ones (the log written twice?): dropped"
                    ),
                );
            }
            self.ap.repeated += 1;
            return Ok(None);
        }
        if t < self.latest.saturating_sub(JUMP_BACK_NS) {
            if !self.after_jump {
                self.after_jump = true;
                self.ap.clock_jumps_back += 1;
                report.event(
                    Kind::ClockJump(self.index),
                    Timestamp(self.latest),
                    format!(
                        "AP {name}: the NIC clock jumped back by {:.3} s (a NIC restart?): the \
                         records until it passes this time again are dropped",
                        (self.latest - t) as f64 / NANOS_PER_SEC as f64
                    ),
                );
            }
            self.ap.after_clock_jump += 1;
            return Ok(None);
        }
        self.after_jump = false;
        if self.latest != i64::MIN && t > self.latest {
            let silent_s = (t - self.latest) as f64 / NANOS_PER_SEC as f64;
            self.ap.longest_silence_s = self.ap.longest_silence_s.max(silent_s);
            if silent_s > SILENCE_S {
                self.ap.silences += 1;
                report.event(
                    Kind::Silence(self.index),
                    Timestamp(self.latest),
                    format!("AP {name}: no record for {silent_s:.3} s (an outage?)"),
                );
            }
        }
        self.latest = self.latest.max(t);
        self.keep(t, key);
        self.ap.kept += 1;
        let t_s = Timestamp(t).as_secs_f64();
        self.ap.span_s = Some(self.ap.span_s.map_or((t_s, t_s), |(a, _)| (a, t_s)));
        Ok(Some(CsiPacket {
            t: Timestamp(t),
            record,
        }))
    }

    /// The AP's counts, appended to `report`.
    pub fn finish(self, report: &mut InputReport) {
        report.aps.push(self.ap);
    }

    fn is_repeat(&self, t: i64, key: u128) -> bool {
        self.recent.iter().any(|&(u, k)| u == t && k == key)
            || self
                .remembered
                .as_ref()
                .is_some_and(|(_, set)| set.contains(&(t, key)))
    }

    fn keep(&mut self, t: i64, key: u128) {
        self.recent.push_back((t, key));
        let oldest = self.latest.saturating_sub(JUMP_BACK_NS);
        while self.recent.front().is_some_and(|(u, _)| *u < oldest) {
            self.recent.pop_front();
        }
        if let Some((order, set)) = &mut self.remembered {
            let key = (t, key);
            if set.insert(key) {
                order.push_back(key);
            }
            if order.len() > MAX_REMEMBERED
                && let Some(old) = order.pop_front()
            {
                set.remove(&old);
            }
        }
    }
}
