//! Time: integer nanoseconds everywhere, and the unwrapping of sensor clocks that wrap.

use serde::{Deserialize, Serialize};

/// Nanoseconds per microsecond.
pub const NANOS_PER_MICRO: i64 = 1_000;
/// Nanoseconds per second.
pub const NANOS_PER_SEC: i64 = 1_000_000_000;

/// The farthest a time read from a file may be from its clock's origin, ns (2⁶², 146 years):
/// the difference of any two such times, and a time moved by a second, fit in an `i64`. The
/// readers refuse a time beyond it ([`Timestamp::is_in_range`]).
pub const MAX_ABS_NANOS: i64 = 1 << 62;

/// A point in time in integer nanoseconds on some clock (which clock is said where it is used).
#[derive(
    Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct Timestamp(pub i64);

impl Timestamp {
    /// From integer microseconds.
    pub const fn from_micros(us: i64) -> Self {
        Self(us * NANOS_PER_MICRO)
    }

    /// Nanoseconds.
    pub const fn as_nanos(self) -> i64 {
        self.0
    }

    /// Seconds as a float (for printing and for maths, never for storage).
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 / NANOS_PER_SEC as f64
    }

    /// Whether the time is less than [`MAX_ABS_NANOS`] from its clock's origin.
    pub const fn is_in_range(self) -> bool {
        -MAX_ABS_NANOS < self.0 && self.0 < MAX_ABS_NANOS
    }

    /// Signed difference `self − earlier` in seconds.
    pub fn secs_since(self, earlier: Timestamp) -> f64 {
        (self.0 - earlier.0) as f64 / NANOS_PER_SEC as f64
    }
}

/// Unwraps a free-running 32-bit microsecond counter (the Intel 5300's `timestamp_low` wraps every
/// 2³² µs ≈ 71.6 min) into a continuous count.
///
/// Each new reading is placed on the lap that puts it nearest to the reference (the last
/// reading that belonged to the stream), so a forward wrap adds a lap and a slightly late
/// (reordered) packet just before a wrap does not. The first reading defines lap 0: timestamps
/// stay on the NIC clock, only made continuous.
///
/// A lone reading far from the reference (more than [`Self::NEAR_US`]: a corrupt or misdated
/// record) is placed the same way but does not become the reference until the next reading
/// confirms it (lies nearer to it than the far reading lies to the reference): a glitch half a
/// lap off cannot move every later reading onto another lap, while a stream that really moved
/// on (a long silence, a clock that restarted) is followed from its second reading.
#[derive(Clone, Debug, Default)]
pub struct MicrosUnwrapper {
    /// The reference: the last reading that belonged to the stream, unwrapped.
    last_us: Option<i64>,
    /// A far reading waiting for the next to confirm it, unwrapped.
    candidate_us: Option<i64>,
}

impl MicrosUnwrapper {
    const LAP: i64 = 1 << 32;
    /// Readings within this of the reference belong to the stream, µs (67 s: far beyond a
    /// packet's reordering, far below half a lap).
    pub const NEAR_US: i64 = 1 << 26;

    /// A fresh unwrapper (lap 0).
    pub fn new() -> Self {
        Self::default()
    }

    /// `raw` on the lap nearest to `reference`.
    fn nearest(raw: i64, reference: i64) -> i64 {
        let lap = reference.div_euclid(Self::LAP);
        let mut best = lap * Self::LAP + raw;
        for l in [lap - 1, lap + 1] {
            let c = l * Self::LAP + raw;
            if (c - reference).abs() < (best - reference).abs() {
                best = c;
            }
        }
        best
    }

    /// Unwrapped microseconds for the raw 32-bit reading.
    pub fn unwrap_micros(&mut self, raw: u32) -> i64 {
        let raw = i64::from(raw);
        let Some(reference) = self.last_us else {
            self.last_us = Some(raw);
            return raw;
        };
        let us = Self::nearest(raw, reference);
        let off = (us - reference).abs();
        if off <= Self::NEAR_US {
            self.last_us = Some(us);
            self.candidate_us = None;
            return us;
        }
        if let Some(c) = self.candidate_us.take() {
            let moved = Self::nearest(raw, c);
            if (moved - c).abs() < off {
                // The stream moved on: the far reading was its first.
                self.last_us = Some(moved);
                return moved;
            }
        }
        self.candidate_us = Some(us);
        us
    }

    /// Unwrapped time for the raw 32-bit microsecond reading.
    pub fn unwrap(&mut self, raw: u32) -> Timestamp {
        Timestamp::from_micros(self.unwrap_micros(raw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unwraps_forward_wraps_and_keeps_reordered_packets_on_their_lap() {
        let mut u = MicrosUnwrapper::new();
        assert_eq!(u.unwrap_micros(u32::MAX - 10), i64::from(u32::MAX - 10));
        // Wrap: 11 µs later.
        assert_eq!(u.unwrap_micros(0), 1 << 32);
        // A reordered packet from just before the wrap stays on lap 0.
        assert_eq!(u.unwrap_micros(u32::MAX - 5), i64::from(u32::MAX - 5));
        assert_eq!(u.unwrap_micros(100), (1 << 32) + 100);
        // Two more laps, in steps of a quarter lap.
        let mut t = (1i64 << 32) + 100;
        for _ in 0..8 {
            t += 1 << 30;
            assert_eq!(u.unwrap_micros((t & 0xFFFF_FFFF) as u32), t);
        }
    }

    #[test]
    fn a_lone_reading_half_a_lap_off_moves_no_later_reading_to_another_lap() {
        let mut u = MicrosUnwrapper::new();
        let t0 = 1_000_000_i64;
        assert_eq!(u.unwrap_micros(t0 as u32), t0);
        // A corrupt reading just over half a lap ahead: placed on lap −1 (nearest) ...
        let glitch = (t0 + (1 << 31) + 5) as u32;
        assert_eq!(u.unwrap_micros(glitch), i64::from(glitch) - (1 << 32));
        // ... and the stream goes on on lap 0.
        for k in 1..5 {
            let t = t0 + k * 20_000;
            assert_eq!(u.unwrap_micros(t as u32), t);
        }
        // A clock that restarted (a driver reload) is followed from its second reading.
        // (3e9 µs lies nearest on lap −1.)
        let restarted = 3_000_000_000_i64 - (1 << 32);
        assert_eq!(u.unwrap_micros(3_000_000_000), restarted);
        for k in 1..4 {
            let raw = (3_000_000_000 + k * 20_000) as u32;
            assert_eq!(u.unwrap_micros(raw), restarted + k * 20_000);
        }
    }

    #[test]
    fn timestamp_conversions() {
        let t = Timestamp::from_micros(1_500_000);
        assert_eq!(t.as_nanos(), 1_500_000_000);
        assert!((t.as_secs_f64() - 1.5).abs() < 1e-15);
        assert!((t.secs_since(Timestamp(500_000_000)) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn times_in_range_differ_by_what_an_i64_holds() {
        let (lo, hi) = (Timestamp(1 - MAX_ABS_NANOS), Timestamp(MAX_ABS_NANOS - 1));
        assert!(lo.is_in_range() && hi.is_in_range());
        assert!(hi.0.checked_sub(lo.0).is_some() && lo.0.checked_sub(hi.0).is_some());
        // A Unix-epoch time in ns (EuRoC's) is in range until 2116.
        assert!(Timestamp(1_760_000_000_000_000_000).is_in_range());
        for t in [MAX_ABS_NANOS, -MAX_ABS_NANOS, i64::MAX, i64::MIN] {
            assert!(!Timestamp(t).is_in_range(), "{t}");
        }
    }
}
