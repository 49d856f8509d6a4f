//! The draws a family makes, from one named random stream, with arithmetic alone (no `sin`,
//! `exp` or `powf`, whose last bit may differ between platforms' maths libraries): the same seed
//! draws the same flight on any machine.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// 2⁻⁵³: a 53-bit integer times this is a uniform number in [0, 1) with every bit exact.
const UNIT_STEP: f64 = 1.0 / 9_007_199_254_740_992.0;

/// Uniform numbers, choices and coin flips from one ChaCha8 stream.
#[derive(Clone, Debug)]
pub(super) struct Sampler(ChaCha8Rng);

impl Sampler {
    /// The stream `family/<name>` of `seed` (see [`crate::sim::rng`]).
    pub(super) fn new(seed: u64, family: &str) -> Self {
        Self(crate::sim::rng::stream(seed, &format!("family/{family}")))
    }

    /// Uniform in [0, 1): the top 53 bits of the next 64-bit word.
    pub(super) fn unit(&mut self) -> f64 {
        (self.0.random::<u64>() >> 11) as f64 * UNIT_STEP
    }

    /// Uniform in [`lo`, `hi`) (`lo` when `hi ≤ lo`).
    pub(super) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = self.unit();
        if hi > lo { lo + (hi - lo) * u } else { lo }
    }

    /// Uniform in [`lo`, `hi`], rounded to a multiple of `1/per_unit` (`per_unit = 100`: to the
    /// centimetre) and kept in [`lo`, `hi`]; readable in a TOML file and exact through it.
    pub(super) fn uniform_rounded(&mut self, lo: f64, hi: f64, per_unit: f64) -> f64 {
        round_to(self.uniform(lo, hi), per_unit).clamp(lo, hi.max(lo))
    }

    /// An index in `0..n` (`n ≥ 1`), each equally likely.
    pub(super) fn index(&mut self, n: usize) -> usize {
        ((self.unit() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// An integer in `lo..=hi`, each equally likely.
    pub(super) fn int(&mut self, lo: usize, hi: usize) -> usize {
        lo + self.index(hi.saturating_sub(lo) + 1)
    }

    /// True with probability `p`.
    pub(super) fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// One of `items` (not empty), each equally likely.
    pub(super) fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.index(items.len())]
    }
}

/// `x` rounded to the nearest multiple of `1/per_unit` (the closest `f64` to that decimal when
/// `per_unit` is a power of ten).
pub(super) fn round_to(x: f64, per_unit: f64) -> f64 {
    (x * per_unit).round() / per_unit
}

/// `x` rounded down to a multiple of `1/per_unit`.
pub(super) fn floor_to(x: f64, per_unit: f64) -> f64 {
    (x * per_unit).floor() / per_unit
}

/// `x` rounded up to a multiple of `1/per_unit`.
pub(super) fn ceil_to(x: f64, per_unit: f64) -> f64 {
    (x * per_unit).ceil() / per_unit
}
