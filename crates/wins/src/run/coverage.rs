//! How much of the flight the estimate covers once it has converged: the stretches without a
//! converged pose (the window lost and not accepted again yet, an IMU gap), counted with their
//! times, so that a run whose estimate was lost says so in `stats.json` and its warnings, and a
//! score over the poses it did give is not mistaken for the whole flight's.

use serde::Serialize;

use crate::time::{NANOS_PER_SEC, Timestamp};

/// Converged poses further apart than this leave a gap, s (a frame comes every 20 ms from one
/// AP at 50 packets/s, every 100 ms at 10).
pub const POSE_GAP_S: f64 = 1.0;
/// Gaps listed with their times (the counts are complete).
const MAX_LISTED: usize = 20;

/// `stats.json` → `coverage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Coverage {
    /// Share of the time from the first converged pose to the end of the flight (its last IMU
    /// sample) that lies between converged poses at most [`POSE_GAP_S`] apart; null when the
    /// estimate never converged.
    pub share: Option<f64>,
    /// Gaps longer than [`POSE_GAP_S`] after the first converged pose, the one to the end of
    /// the flight included.
    pub gaps: u64,
    /// The longest, s.
    pub longest_gap_s: f64,
    /// When the estimate was lost for good: the last converged pose, s, when it is more than
    /// [`POSE_GAP_S`] before the end of the flight.
    pub lost_for_good_at_s: Option<f64>,
    /// The first gaps, `[from, to]` s (`to` the next converged pose or the end of the flight).
    pub listed: Vec<(f64, f64)>,
}

impl Coverage {
    /// The warning a run gives about its gaps, if it has any.
    pub fn warning(&self) -> Option<String> {
        let share = self.share?;
        if self.gaps == 0 {
            return None;
        }
        let lost = self.lost_for_good_at_s.map_or(String::new(), |t| {
            format!(" It was lost at {t:.2} s and not accepted again before the end of the flight.")
        });
        let (from, to) = self.listed.first().copied().unwrap_or((0.0, 0.0));
        Some(format!(
            "the estimate has {} gap(s) without a pose longer than {POSE_GAP_S} s after it \
             converged (the first from {from:.2} to {to:.2} s, the longest {:.2} s): its poses \
             cover {:.0} % of the flight after it converged.{lost}",
            self.gaps,
            self.longest_gap_s,
            share * 100.0
        ))
    }
}

/// [`Coverage`] one converged pose at a time.
#[derive(Clone, Debug, Default)]
pub struct CoverageCheck {
    first: Option<Timestamp>,
    last: Option<Timestamp>,
    covered_ns: i64,
    report: Coverage,
}

impl CoverageCheck {
    /// A converged pose at `t` (in time order; an earlier one is ignored).
    pub fn push(&mut self, t: Timestamp) {
        let Some(last) = self.last else {
            self.first = Some(t);
            self.last = Some(t);
            return;
        };
        if t <= last {
            return;
        }
        self.step(last, t);
        self.last = Some(t);
    }

    /// The report, the flight ending at `end` (its last IMU sample).
    pub fn finish(mut self, end: Timestamp) -> Coverage {
        let (Some(first), Some(last)) = (self.first, self.last) else {
            return self.report;
        };
        if end > last && self.step(last, end) {
            self.report.lost_for_good_at_s = Some(last.as_secs_f64());
        }
        let span_ns = end.0.max(last.0) - first.0;
        self.report.share = Some(if span_ns > 0 {
            self.covered_ns as f64 / span_ns as f64
        } else {
            1.0
        });
        self.report
    }

    /// The time from `a` to `b`, covered or a gap; `true` for a gap.
    fn step(&mut self, a: Timestamp, b: Timestamp) -> bool {
        let dt_ns = b.0.saturating_sub(a.0);
        if (dt_ns as f64) <= POSE_GAP_S * NANOS_PER_SEC as f64 {
            self.covered_ns += dt_ns;
            return false;
        }
        let r = &mut self.report;
        r.gaps += 1;
        r.longest_gap_s = r.longest_gap_s.max(dt_ns as f64 / NANOS_PER_SEC as f64);
        if r.listed.len() < MAX_LISTED {
            r.listed.push((a.as_secs_f64(), b.as_secs_f64()));
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> Timestamp {
        Timestamp((s * 1e9).round() as i64)
    }

    fn poses(from: f64, to: f64, check: &mut CoverageCheck) {
        let mut t = from;
        while t <= to + 1e-9 {
            check.push(at(t));
            t += 0.02;
        }
    }

    #[test]
    fn a_continuous_estimate_covers_the_flight_and_warns_nothing() {
        let mut check = CoverageCheck::default();
        poses(10.0, 60.0, &mut check);
        let c = check.finish(at(60.0));
        assert!((c.share.unwrap() - 1.0).abs() < 1e-6, "{c:?}");
        assert_eq!((c.gaps, c.lost_for_good_at_s), (0, None));
        assert!(c.warning().is_none());
    }

    #[test]
    fn a_gap_and_a_loss_for_good_are_counted_timed_and_told() {
        let mut check = CoverageCheck::default();
        poses(10.0, 30.0, &mut check);
        poses(40.0, 50.0, &mut check);
        let c = check.finish(at(60.0));
        // 30 of the 50 s after convergence are covered.
        assert!((c.share.unwrap() - 0.6).abs() < 1e-3, "{c:?}");
        assert_eq!(c.gaps, 2);
        assert!((c.longest_gap_s - 10.0).abs() < 0.03);
        assert!((c.lost_for_good_at_s.unwrap() - 50.0).abs() < 0.03);
        assert!((c.listed[0].0 - 30.0).abs() < 0.03 && (c.listed[0].1 - 40.0).abs() < 0.03);
        let w = c.warning().unwrap();
        assert!(w.contains("2 gap(s)") && w.contains("60 %"), "{w}");
        assert!(w.contains("lost at 50.0"), "{w}");
    }

    #[test]
    fn never_converged_has_no_share_and_no_warning() {
        let c = CoverageCheck::default().finish(at(60.0));
        assert_eq!(c.share, None);
        assert!(c.warning().is_none());
    }
}
