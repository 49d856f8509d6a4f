//! The checks a dataset's inputs pass as it is loaded ([`super::incremental::ImuCheck`],
//! [`super::incremental::ApCheck`], `judge_spans`): what can be used is used, what cannot is
//! dropped and counted, each event is reported with the time it happened, and inputs that cannot
//! give a meaningful estimate are an error that says why.
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

use crate::csi::Received;
use crate::time::Timestamp;

/// A gap between IMU samples longer than this many nominal periods is an event.
pub const GAP_PERIODS: f64 = 5.0;
/// The IMU and the CSI ending (or starting) more than this apart is a warning, s.
const SPAN_WARN_S: f64 = 2.0;
/// An AP without a kept record for longer than this is silent (an outage), s: ten times a busy
/// AP's 10 packets/s spacing.
pub const SILENCE_S: f64 = 1.0;
/// Events listed with their times (the counts go on).
pub(crate) const MAX_LISTED: usize = 20;

/// One packet with its time on the IMU clock.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiPacket {
    /// Reception time on the IMU clock (the NIC time shifted by the manifest's offset).
    pub t: Timestamp,
    /// The packet as logged (its own time stays on the NIC clock).
    pub record: Received,
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
         imu_minus_nic_ns and the IMU's time unit. {suggestion}"
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
        /// The offsets that would make the recordings start together, in words.
        suggestion: String,
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
    /// Silences: no record kept for longer than [`SILENCE_S`] (an outage, or the NIC off).
    pub silences: u64,
    /// The longest time between two kept records, s.
    pub longest_silence_s: f64,
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
pub(crate) enum Kind {
    NotFinite,
    BeyondRange,
    TimeBack,
    CutLine,
    Gap,
    Repeated(usize),
    ClockJump(usize),
    Silence(usize),
}

impl InputReport {
    pub(crate) fn event(&mut self, kind: Kind, t: Timestamp, what: String) {
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

/// The IMU's span against every AP's, from what the reader counted: the IMU's span, the packets
/// inside it (every AP's `before_imu` and `after_imu` set) and the packets' span. No overlap is
/// an error, ends far apart a warning.
/// The offsets that would make the packets' first time on the IMU clock the IMU's first (each
/// AP's `imu_minus_nic_ns` in `offsets` shifted alike), and how sure that is: if the recordings
/// also ended together, their lengths' difference bounds how far off it is.
fn suggest_offsets(
    (from, to): (Timestamp, Timestamp),
    (csi_from, csi_to): (Timestamp, Timestamp),
    offsets: &[(&str, i64)],
) -> String {
    let shift = from.0 - csi_from.0;
    let proposed: Vec<String> = offsets
        .iter()
        .map(|(name, offset)| {
            format!(
                "{name}: imu_minus_nic_ns = {}",
                offset.saturating_add(shift)
            )
        })
        .collect();
    let lengths = ((to.0 - from.0) - (csi_to.0 - csi_from.0)).abs() as f64 * 1e-9;
    format!(
        "If the two recordings started together: {} (the packets moved by {:+.3} s; the \
         recordings' lengths differ by {lengths:.3} s, which bounds how far off that is if they \
         also ended together)",
        proposed.join(", "),
        shift as f64 * 1e-9
    )
}

pub(crate) fn judge_spans(
    (from, to): (Timestamp, Timestamp),
    inside: u64,
    csi_span: Option<(Timestamp, Timestamp)>,
    offsets: &[(&str, i64)],
    report: &mut InputReport,
) -> Result<(), InputError> {
    report.imu.span_s = Some((from.as_secs_f64(), to.as_secs_f64()));
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
            suggestion: suggest_offsets((from, to), (csi_from, csi_to), offsets),
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
        if ap.silences > 0 {
            lines.push(format!(
                "AP {}: silent for longer than {SILENCE_S} s (an outage?): {} times (the longest \
                 {:.3} s){}",
                ap.name,
                ap.silences,
                ap.longest_silence_s,
                report.first(Kind::Silence(index))
            ));
        }
    }
    lines.append(&mut report.warnings);
    report.warnings = lines;
}
