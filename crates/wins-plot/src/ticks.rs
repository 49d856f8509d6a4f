//! Tick label text: enough digits that neighbouring ticks differ, no `-0`.

/// Expected number of ticks per axis; plotters places at most about this many.
const TICKS_PER_AXIS: f64 = 10.0;
/// Above this magnitude (or for steps below [`MIN_FIXED_STEP`]) ticks use scientific notation.
const MAX_FIXED_MAGNITUDE: f64 = 1e5;
const MIN_FIXED_STEP: f64 = 1e-4;
/// f64 carries about 15-17 significant digits; more would print noise.
const MAX_SIGNIFICANT_DIGITS: i32 = 15;

/// How tick values on one axis are printed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TickFormat {
    /// Rust's shortest round-trip text (for a flat range).
    Shortest,
    /// Fixed point with this many decimals.
    Fixed(usize),
    /// Scientific with this many decimals in the mantissa.
    Sci(usize),
}

impl TickFormat {
    /// Format for ticks spanning `lo..=hi` (any finite values, the span may overflow).
    pub(crate) fn for_range(lo: f64, hi: f64) -> Self {
        let magnitude = lo.abs().max(hi.abs());
        // Divide first so that a span near f64::MAX does not overflow.
        let step = (hi / TICKS_PER_AXIS - lo / TICKS_PER_AXIS).abs();
        if !(step > 0.0 && step.is_finite() && magnitude.is_finite()) {
            return Self::Shortest;
        }
        // plotters spaces ticks by 1, 2 or 5 times a power of ten, never closer than `step`, so
        // printing down to the decimal place of `step` tells neighbouring ticks apart.
        let step_place = step.log10().floor() as i32;
        if magnitude < MAX_FIXED_MAGNITUDE && step >= MIN_FIXED_STEP {
            // step >= 1e-4, so at most 4 decimals.
            Self::Fixed((-step_place).max(0) as usize)
        } else {
            let magnitude_place = magnitude.log10().floor() as i32;
            let decimals = (magnitude_place - step_place).clamp(0, MAX_SIGNIFICANT_DIGITS - 1);
            Self::Sci(decimals as usize)
        }
    }

    /// Text of the tick at `v`.
    pub(crate) fn format(self, v: f64) -> String {
        // Adding +0.0 turns -0.0 into +0.0 and leaves every other value unchanged.
        let v = v + 0.0;
        match self {
            Self::Shortest => format!("{v}"),
            Self::Fixed(decimals) => {
                let text = format!("{v:.decimals$}");
                if text
                    .trim_start_matches('-')
                    .bytes()
                    .all(|b| b == b'0' || b == b'.')
                {
                    // A value rounding to zero, e.g. -1e-9 with 2 decimals: print "0...", not "-0...".
                    text.trim_start_matches('-').to_string()
                } else {
                    text
                }
            }
            Self::Sci(decimals) => format!("{v:.decimals$e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choice_follows_the_range() {
        assert_eq!(TickFormat::for_range(2.0, 2.0), TickFormat::Shortest);
        assert_eq!(TickFormat::for_range(-90.0, 90.0), TickFormat::Fixed(0));
        assert_eq!(TickFormat::for_range(0.0, 1.0), TickFormat::Fixed(1));
        assert_eq!(TickFormat::for_range(0.0, 0.5), TickFormat::Fixed(2));
        assert_eq!(TickFormat::for_range(1e-12, 4e-12), TickFormat::Sci(1));
        assert_eq!(TickFormat::for_range(1e9, 1e9 + 1e-3), TickFormat::Sci(13));
        // Below f64 resolution at this magnitude: capped.
        assert_eq!(TickFormat::for_range(1e9, 1e9 + 1e-6), TickFormat::Sci(14));
        assert_eq!(
            TickFormat::for_range(-f64::MAX, f64::MAX),
            TickFormat::Sci(1)
        );
    }

    #[test]
    fn text() {
        assert_eq!(TickFormat::Fixed(1).format(-0.0), "0.0");
        assert_eq!(TickFormat::Fixed(2).format(-1e-9), "0.00");
        assert_eq!(TickFormat::Fixed(0).format(-80.0), "-80");
        assert_eq!(TickFormat::Fixed(1).format(2.5), "2.5");
        assert_eq!(TickFormat::Sci(2).format(1.23456e7), "1.23e7");
        assert_eq!(TickFormat::Sci(1).format(-3.0e-12), "-3.0e-12");
        assert_eq!(TickFormat::Shortest.format(2.0), "2");
        assert_eq!(TickFormat::Shortest.format(-0.0), "0");
    }

    #[test]
    fn neighbouring_ticks_differ() {
        for (lo, hi) in [
            (0.0, 1.0),
            (1e-12, 4e-12),
            (1e9, 1e9 + 1e-3),
            (-17.3, 30.2),
            (0.0, 7e5),
        ] {
            let f = TickFormat::for_range(lo, hi);
            let step = (hi - lo) / TICKS_PER_AXIS;
            let a = f.format(lo + 3.0 * step);
            let b = f.format(lo + 4.0 * step);
            assert_ne!(a, b, "{lo}..{hi} with {f:?}");
        }
    }
}
