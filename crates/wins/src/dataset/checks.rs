//! The checks a dataset's inputs pass as it is loaded ([`check_imu`], [`check_ap`],
//! [`check_spans`]): what can be used is used, what cannot is dropped and counted, each event is
//! reported with the time it happened, and inputs that cannot give a meaningful estimate are an
//! error that says why.
//!
//! IMU: rows whose time does not increase, values that are not finite or at or beyond the
//! sensor's range (`[imu] accel_range_m_s2`, `gyro_range_rad_s`; a saturated or corrupted
//! sample), a last row cut while written: dropped and counted. Gaps longer than
//! [`GAP_PERIODS`] sample periods: counted with their times (the estimator handles them). A rate
//! far from the declared one: a warning; so far that the timestamps' unit must be wrong: an
//! error.
//!
//! CSI, per AP: the clock offset applied with checked arithmetic (a time out of range is an error);
//! records repeated (same NIC time and header as one kept: a log written twice) and records after
//! the NIC clock jumped back (a NIC restart mid-log) dropped and counted; records outside the
//! IMU's time span counted (no IMU to place them). No overlap between the IMU and any AP's
//! packets is an error; a log or the IMU ending well before the other is a warning.

use std::collections::BTreeMap;

use serde::Serialize;

use super::imu_csv::ImuRows;
use crate::csi::intel5300::CsiRecord;
use crate::imu::ImuSample;
use crate::time::{NANOS_PER_SEC, Timestamp};

/// A gap between IMU samples longer than this many nominal periods is an event.
pub const GAP_PERIODS: f64 = 5.0;
/// A measured IMU rate this far (as a factor) from the declared one is a warning.
const RATE_WARN_FACTOR: f64 = 1.5;
/// A measured IMU rate this far from the declared one is an error (the timestamps' unit).
const RATE_ERROR_FACTOR: f64 = 20.0;
/// The IMU and the CSI ending (or starting) more than this apart is a warning, s.
const SPAN_WARN_S: f64 = 2.0;
/// A NIC clock going back by more than this is a jump (a restart), not a reordered packet, ns.
const JUMP_BACK_NS: i64 = 100_000_000;
/// Events listed with their times (the counts go on).
const MAX_LISTED: usize = 20;

/// One CSI record with its time on the IMU clock.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiPacket {
    /// Reception time on the IMU clock (the NIC time shifted by the manifest's offset).
    pub t: Timestamp,
    /// The record as logged (its `timestamp` stays on the NIC clock).
    pub record: CsiRecord,
}

/// Inputs that cannot give a meaningful estimate.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// No IMU sample is usable.
    #[error("no usable IMU sample ({0})")]
    NoImu(String),
    /// The measured IMU rate contradicts the declared one beyond any clock error.
    #[error(
        "the IMU's samples come at {measured_hz:.4} Hz (median) but imu.rate_hz is \
         {declared_hz} Hz: are the timestamps in nanoseconds?"
    )]
    ImuRate {
        /// Median rate of the file, Hz.
        measured_hz: f64,
        /// `imu.rate_hz`, Hz.
        declared_hz: f64,
    },
    /// The clock offset moves a packet's time out of range ([`crate::time::MAX_ABS_NANOS`]).
    #[error(
        "AP {ap}: imu_minus_nic_ns = {offset_ns} moves the NIC time {nic_ns} ns out of range \
         (146 years or more from the IMU clock's origin)"
    )]
    OffsetOverflow {
        /// The AP's name.
        ap: String,
        /// The manifest's offset, ns.
        offset_ns: i64,
        /// The NIC time it was applied to, ns.
        nic_ns: i64,
    },
    /// No AP's packets fall inside the IMU's time span.
    #[error(
        "no packet of any AP falls inside the IMU's time span ({imu_from_s:.3}–{imu_to_s:.3} s); \
         the packets span {csi_from_s:.3}–{csi_to_s:.3} s on the IMU clock: check \
         imu_minus_nic_ns and the IMU's time unit"
    )]
    NoOverlap {
        /// IMU span, s.
        imu_from_s: f64,
        /// IMU span, s.
        imu_to_s: f64,
        /// Packets' span, s.
        csi_from_s: f64,
        /// Packets' span, s.
        csi_to_s: f64,
    },
}

/// One event, with its time on the IMU clock.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InputEvent {
    /// When, s on the IMU clock.
    pub t_s: f64,
    /// What, in words.
    pub what: String,
}

/// The IMU's checks.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ImuInputReport {
    /// Rows read.
    pub rows: u64,
    /// Samples kept.
    pub samples: u64,
    /// Rows dropped: time not after the previous kept row.
    pub time_not_increasing: u64,
    /// Rows dropped: a value not finite.
    pub not_finite: u64,
    /// Rows dropped: a value at or beyond the sensor's range.
    pub beyond_range: u64,
    /// The last row had no line end and was dropped.
    pub cut_last_line: bool,
    /// Gaps longer than [`GAP_PERIODS`] periods.
    pub gaps: u64,
    /// The longest gap, s.
    pub longest_gap_s: f64,
    /// Median rate, Hz.
    pub measured_rate_hz: f64,
    /// First and last kept sample, s.
    pub span_s: Option<(f64, f64)>,
}

/// One AP's checks.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ApInputReport {
    /// The AP's name.
    pub name: String,
    /// Records in the log.
    pub records: u64,
    /// Records kept.
    pub kept: u64,
    /// Dropped: the same NIC time and header as a kept record (a log written twice).
    pub repeated: u64,
    /// Times the NIC clock jumped back (a NIC restart mid-log).
    pub clock_jumps_back: u64,
    /// Dropped: before the latest kept time after a jump back (their time is unknown).
    pub after_clock_jump: u64,
    /// Kept records before the first IMU sample.
    pub before_imu: u64,
    /// Kept records after the last IMU sample.
    pub after_imu: u64,
    /// First and last kept record, s on the IMU clock.
    pub span_s: Option<(f64, f64)>,
}

/// What the checks found (`stats.json` → `inputs`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct InputReport {
    /// The IMU.
    pub imu: ImuInputReport,
    /// Per AP, in manifest order.
    pub aps: Vec<ApInputReport>,
    /// The first events with their times (the counts above are complete).
    pub events: Vec<InputEvent>,
    /// Events beyond those listed.
    pub events_not_listed: u64,
    /// What limits the run, in words (also printed as warnings).
    pub warnings: Vec<String>,
    /// The time of each kind's first event, listed or not, s.
    #[serde(skip)]
    first_s: BTreeMap<Kind, f64>,
}

/// The kinds of events, for their first times (an AP's by its index).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    NotFinite,
    BeyondRange,
    TimeBack,
    CutLine,
    Gap,
    Repeated(usize),
    ClockJump(usize),
}

impl InputReport {
    fn event(&mut self, kind: Kind, t: Timestamp, what: String) {
        self.first_s.entry(kind).or_insert(t.as_secs_f64());
        if self.events.len() < MAX_LISTED {
            self.events.push(InputEvent {
                t_s: t.as_secs_f64(),
                what,
            });
        } else {
            self.events_not_listed += 1;
        }
    }

    /// `, the first at T s` for `kind`'s first event, or nothing.
    fn first(&self, kind: Kind) -> String {
        self.first_s
            .get(&kind)
            .map_or(String::new(), |t| format!(", the first at {t:.3} s"))
    }
}

/// What the IMU's checks need from the manifest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuLimits {
    /// `imu.rate_hz`.
    pub rate_hz: f64,
    /// Accelerometer full scale per axis, m/s².
    pub accel_range_m_s2: f64,
    /// Gyroscope full scale per axis, rad/s.
    pub gyro_range_rad_s: f64,
}

/// Checks the IMU rows: returns the samples kept (strictly increasing time).
pub fn check_imu(
    rows: ImuRows,
    limits: ImuLimits,
    report: &mut InputReport,
) -> Result<Vec<ImuSample>, InputError> {
    let mut kept: Vec<ImuSample> = Vec::with_capacity(rows.samples.len());
    report.imu.rows = rows.samples.len() as u64;
    for s in rows.samples {
        let mut values = s.gyro_rad_s.iter().chain(s.accel_m_s2.iter());
        if values.any(|v| !v.is_finite()) {
            report.imu.not_finite += 1;
            report.event(
                Kind::NotFinite,
                s.t,
                "IMU sample with a value that is not finite: dropped".into(),
            );
            continue;
        }
        let beyond = s.accel_m_s2.amax() >= limits.accel_range_m_s2
            || s.gyro_rad_s.amax() >= limits.gyro_range_rad_s;
        if beyond {
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
            continue;
        }
        if let Some(prev) = kept.last()
            && s.t <= prev.t
        {
            report.imu.time_not_increasing += 1;
            report.event(
                Kind::TimeBack,
                s.t,
                format!(
                    "IMU time goes back from {:.6} s: sample dropped",
                    prev.t.as_secs_f64()
                ),
            );
            continue;
        }
        kept.push(s);
    }
    if let Some(line) = rows.cut_last_line {
        report.imu.cut_last_line = true;
        let t = kept.last().map_or(Timestamp(0), |s| s.t);
        report.event(
            Kind::CutLine,
            t,
            format!("the IMU file's last line ({line}) has no line end (cut?): dropped"),
        );
    }
    if kept.len() < 2 {
        return Err(InputError::NoImu(format!(
            "{} of {} rows kept",
            kept.len(),
            report.imu.rows
        )));
    }
    let mut dts: Vec<i64> = kept.windows(2).map(|w| w[1].t.0 - w[0].t.0).collect();
    let gap_ns = (GAP_PERIODS / limits.rate_hz * NANOS_PER_SEC as f64) as i64;
    for (w, &dt) in kept.windows(2).zip(&dts) {
        if dt > gap_ns {
            report.imu.gaps += 1;
            let dt_s = dt as f64 / NANOS_PER_SEC as f64;
            report.imu.longest_gap_s = report.imu.longest_gap_s.max(dt_s);
            report.event(Kind::Gap, w[0].t, format!("IMU gap of {dt_s:.3} s"));
        }
    }
    dts.sort_unstable();
    let median_dt = dts[dts.len() / 2].max(1);
    let measured_hz = NANOS_PER_SEC as f64 / median_dt as f64;
    report.imu.measured_rate_hz = measured_hz;
    report.imu.samples = kept.len() as u64;
    let factor = (measured_hz / limits.rate_hz).max(limits.rate_hz / measured_hz);
    if factor > RATE_ERROR_FACTOR {
        return Err(InputError::ImuRate {
            measured_hz,
            declared_hz: limits.rate_hz,
        });
    }
    if factor > RATE_WARN_FACTOR {
        report.warnings.push(format!(
            "the IMU runs at {measured_hz:.1} Hz (median), imu.rate_hz says {} Hz",
            limits.rate_hz
        ));
    }
    Ok(kept)
}

/// One AP's records placed on the IMU clock (`imu_minus_nic_ns`, checked), repeated records and
/// those after a NIC clock jump dropped and counted.
pub fn check_ap(
    name: &str,
    records: Vec<CsiRecord>,
    imu_minus_nic_ns: i64,
    report: &mut InputReport,
) -> Result<Vec<CsiPacket>, InputError> {
    let mut ap = ApInputReport {
        name: name.to_string(),
        records: records.len() as u64,
        ..ApInputReport::default()
    };
    // This AP's index in the report.
    let index = report.aps.len();
    let mut kept: Vec<CsiPacket> = Vec::with_capacity(records.len());
    let mut latest = i64::MIN;
    let mut after_jump = false;
    for record in records {
        let nic_ns = record.timestamp.as_nanos();
        let t = nic_ns
            .checked_add(imu_minus_nic_ns)
            .filter(|&t| Timestamp(t).is_in_range())
            .ok_or_else(|| InputError::OffsetOverflow {
                ap: name.to_string(),
                offset_ns: imu_minus_nic_ns,
                nic_ns,
            })?;
        if t <= latest {
            // Kept records are in time order up to small reorderings.
            let i = kept.partition_point(|p| p.t.0 < t);
            let repeat = kept[i..]
                .iter()
                .take_while(|p| p.t.0 == t)
                .any(|p| p.record.header == record.header);
            if repeat {
                if ap.repeated == 0 {
                    report.event(
                        Kind::Repeated(index),
                        Timestamp(t),
                        format!(
                            "AP {name}: records repeat earlier ones (the log written twice?): \
                             dropped"
                        ),
                    );
                }
                ap.repeated += 1;
                continue;
            }
        }
        if t < latest.saturating_sub(JUMP_BACK_NS) {
            if !after_jump {
                after_jump = true;
                ap.clock_jumps_back += 1;
                report.event(
                    Kind::ClockJump(index),
                    Timestamp(latest),
                    format!(
                        "AP {name}: the NIC clock jumped back by {:.3} s (a NIC restart?): the \
                         records until it passes this time again are dropped",
                        (latest - t) as f64 / NANOS_PER_SEC as f64
                    ),
                );
            }
            ap.after_clock_jump += 1;
            continue;
        }
        after_jump = false;
        latest = latest.max(t);
        kept.push(CsiPacket {
            t: Timestamp(t),
            record,
        });
    }
    ap.kept = kept.len() as u64;
    ap.span_s = kept
        .first()
        .zip(kept.last())
        .map(|(a, b)| (a.t.as_secs_f64(), b.t.as_secs_f64()));
    report.aps.push(ap);
    Ok(kept)
}

/// The IMU's span against every AP's: records outside it counted, no overlap an error, ends far
/// apart a warning.
pub fn check_spans(
    imu: &[ImuSample],
    aps: &[&[CsiPacket]],
    report: &mut InputReport,
) -> Result<(), InputError> {
    let (Some(first), Some(last)) = (imu.first(), imu.last()) else {
        return Err(InputError::NoImu("no sample".into()));
    };
    let (from, to) = (first.t, last.t);
    report.imu.span_s = Some((from.as_secs_f64(), to.as_secs_f64()));
    let mut inside = 0;
    let mut csi_span: Option<(Timestamp, Timestamp)> = None;
    for (packets, ap) in aps.iter().zip(report.aps.iter_mut()) {
        ap.before_imu = packets.iter().filter(|p| p.t < from).count() as u64;
        ap.after_imu = packets.iter().filter(|p| p.t > to).count() as u64;
        inside += packets.len() as u64 - ap.before_imu - ap.after_imu;
        for p in packets.iter() {
            csi_span = Some(csi_span.map_or((p.t, p.t), |(a, b)| (a.min(p.t), b.max(p.t))));
        }
    }
    let Some((csi_from, csi_to)) = csi_span else {
        report
            .warnings
            .push("no CSI record in any log: the IMU alone cannot be run".into());
        return Ok(());
    };
    if inside == 0 {
        return Err(InputError::NoOverlap {
            imu_from_s: from.as_secs_f64(),
            imu_to_s: to.as_secs_f64(),
            csi_from_s: csi_from.as_secs_f64(),
            csi_to_s: csi_to.as_secs_f64(),
        });
    }
    let mut warnings = Vec::new();
    for ap in &report.aps {
        let Some((a, b)) = ap.span_s else {
            warnings.push(format!("AP {}: no CSI record", ap.name));
            continue;
        };
        if a - from.as_secs_f64() > SPAN_WARN_S {
            warnings.push(format!(
                "AP {}: the log starts at {a:.1} s, {:.1} s after the IMU",
                ap.name,
                a - from.as_secs_f64()
            ));
        }
        if to.as_secs_f64() - b > SPAN_WARN_S {
            warnings.push(format!(
                "AP {}: the log ends at {b:.1} s, {:.1} s before the IMU (cut short?): \
                 no bearing after it",
                ap.name,
                to.as_secs_f64() - b
            ));
        }
        if ap.after_imu > 0 && b - to.as_secs_f64() > SPAN_WARN_S {
            warnings.push(format!(
                "AP {}: the IMU ends at {:.1} s, {:.1} s before the log (cut short?): {} \
                 records after it are not used",
                ap.name,
                to.as_secs_f64(),
                b - to.as_secs_f64(),
                ap.after_imu
            ));
        }
    }
    report.warnings.extend(warnings);
    Ok(())
}

/// The report's counts as warning lines (each with the first event's time).
pub fn summarize(report: &mut InputReport) {
    let imu = &report.imu;
    let mut lines = Vec::new();
    for (n, what, kind) in [
        (
            imu.not_finite,
            "IMU samples not finite, dropped",
            Kind::NotFinite,
        ),
        (
            imu.beyond_range,
            "IMU samples at or beyond the sensor's range, dropped",
            Kind::BeyondRange,
        ),
        (
            imu.time_not_increasing,
            "IMU samples with time going back, dropped",
            Kind::TimeBack,
        ),
    ] {
        if n > 0 {
            lines.push(format!("{what}: {n}{}", report.first(kind)));
        }
    }
    if imu.gaps > 0 {
        lines.push(format!(
            "IMU gaps longer than {GAP_PERIODS} sample periods: {} (the longest {:.3} s){}",
            imu.gaps,
            imu.longest_gap_s,
            report.first(Kind::Gap)
        ));
    }
    if imu.cut_last_line {
        lines.push("the IMU file's last line has no line end (cut?): dropped".into());
    }
    for (index, ap) in report.aps.iter().enumerate() {
        if ap.repeated > 0 {
            lines.push(format!(
                "AP {}: {} repeated records dropped (the log written twice?){}",
                ap.name,
                ap.repeated,
                report.first(Kind::Repeated(index))
            ));
        }
        if ap.clock_jumps_back > 0 {
            lines.push(format!(
                "AP {}: the NIC clock jumped back (a NIC restart?): {} times{}; {} records \
                 dropped",
                ap.name,
                ap.clock_jumps_back,
                report.first(Kind::ClockJump(index)),
                ap.after_clock_jump
            ));
        }
    }
    lines.append(&mut report.warnings);
    report.warnings = lines;
}
