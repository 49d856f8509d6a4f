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
/// Each new reading is placed on the lap that puts it nearest to the previous reading, so a forward
/// wrap adds a lap and a slightly late (reordered) packet just before a wrap does not. The first
/// reading defines lap 0: timestamps stay on the NIC clock, only made continuous.
#[derive(Clone, Debug, Default)]
pub struct MicrosUnwrapper {
    last_us: Option<i64>,
}

impl MicrosUnwrapper {
    const LAP: i64 = 1 << 32;

    /// A fresh unwrapper (lap 0).
    pub fn new() -> Self {
        Self::default()
    }

    /// Unwrapped microseconds for the raw 32-bit reading.
    pub fn unwrap_micros(&mut self, raw: u32) -> i64 {
        let raw = i64::from(raw);
        let us = match self.last_us {
            None => raw,
            Some(last) => {
                let lap = last.div_euclid(Self::LAP);
                let candidates = [lap - 1, lap, lap + 1].map(|l| l * Self::LAP + raw);
                let mut best = candidates[1];
                for c in candidates {
                    if (c - last).abs() < (best - last).abs() {
                        best = c;
                    }
                }
                best
            }
        };
        self.last_us = Some(us);
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
