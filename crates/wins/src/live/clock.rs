//! Relating a remote clock (the flight controller's, the NIC's) to the host's monotonic clock, and
//! unwrapping the NIC's 32-bit microsecond counter.
//!
//! ## The model
//!
//! A reading `r` of the remote clock (ns) taken when a message leaves the remote side reaches the host
//! at host time `h` (ns):
//!
//! ```text
//! h = r + offset + drift · (r − r₀) + delay,      delay ≥ 0
//! ```
//!
//! `delay` is transport and scheduling latency: never negative, usually small, sometimes large
//! (a USB burst, a stalled link). So the difference `d = h − r` is bounded below by the true clock
//! line and scattered only *above* it: the clock relation is the **lower envelope** of the points
//! `(r, d)`, never their mean (a least-squares fit through all points would sit the mean delay
//! too late and be dragged by every spike).
//!
//! ## The estimator ([`ClockSync`])
//!
//! 1. Samples are grouped in blocks of [`ClockSyncConfig::block_ns`] of remote time; each block
//!    keeps only its *minimum* `d` (the least-delayed message) and the remote time of it. With
//!    exponential delays of mean μ and `n` samples per block, the minimum lies on average μ/n above
//!    the true line (2 ms and 50 samples: 40 µs), and a spike can only raise one sample.
//! 2. A straight line (offset + drift) is fitted by weighted least squares through the minima of
//!    the last [`ClockSyncConfig::max_blocks`] blocks (a sliding window, so a slowly changing drift,
//!    e.g. with temperature, is followed). The weight is the number of samples in the block: the
//!    minimum of a block with few samples is a poorer envelope point.
//! 3. Block minima that sit far *above* the line (a block whose every message was delayed, e.g. a
//!    stalled link) are dropped and the line refitted once: more than
//!    `max(6 · 1.4826 · MAD, outlier_floor_ns)` above the median residual.
//! 4. Until there are two blocks the drift is taken as zero and the offset is the smallest `d` seen,
//!    so the first sample already gives an estimate (good to its own delay); the line is refined at
//!    every sample. The drift is clamped to ±[`ClockSyncConfig::max_drift_ppm`], which only acts
//!    while the window is still short.
//!
//! The residual bias is the mean block-minimum delay (tens of µs at 100 Hz with ms-scale jitter).
//!
//! A line alone believes every sample; [`ClockTrack`] (in [`track`]) guards it: a lone sample
//! far from the line is refused, a clock that restarts is re-locked ([`track`]'s module doc).

pub mod track;

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

pub use self::track::{ClockTrack, Pushed, TrackConfig};

/// Parts per million.
const PPM: f64 = 1e6;
/// The MAD of a normal distribution is σ / 1.4826.
const MAD_TO_SIGMA: f64 = 1.4826;
/// How many robust standard deviations above the median a block minimum may sit.
const OUTLIER_SIGMAS: f64 = 6.0;
/// Fewest blocks before block minima are tested for outliers.
const MIN_BLOCKS_FOR_OUTLIERS: usize = 4;

/// Settings of [`ClockSync`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClockSyncConfig {
    /// Length of one block of remote time whose minimum delay is kept, ns. The default (0.5 s)
    /// suits messages at 10–1000 Hz; at rates below ~10 Hz lengthen it so a block holds several.
    pub block_ns: i64,
    /// Number of blocks in the sliding window of the line fit. The default (120, i.e. 60 s) is
    /// long enough to measure a drift to a fraction of a ppm and short enough to follow its
    /// changes with temperature.
    pub max_blocks: usize,
    /// Largest believable drift, ppm (default 1000: crystals are within ~100 ppm).
    pub max_drift_ppm: f64,
    /// Smallest distance above the line for which a block minimum is an outlier, ns (default
    /// 0.5 ms).
    pub outlier_floor_ns: i64,
}

impl Default for ClockSyncConfig {
    fn default() -> Self {
        Self {
            block_ns: 500_000_000,
            max_blocks: 120,
            max_drift_ppm: 1000.0,
            outlier_floor_ns: 500_000,
        }
    }
}

/// One block of remote time: its least-delayed sample.
#[derive(Clone, Copy, Debug)]
struct Block {
    /// Remote time at which the block starts, ns.
    start_remote_ns: i64,
    /// Remote time of the least-delayed sample, ns.
    remote_ns: i64,
    /// Smallest `host − remote` in the block, ns.
    min_diff_ns: i64,
    /// Samples in the block.
    count: u32,
}

/// The fitted line `host − remote = diff_ref + a + b · (remote − remote_ref)`.
#[derive(Clone, Copy, Debug)]
struct Line {
    /// Offset relative to `diff_ref`, ns.
    a_ns: f64,
    /// Drift (dimensionless: ns per ns).
    b: f64,
}

/// An online relation between a remote clock and the host's monotonic clock (see the module
/// documentation for the model and the estimator).
#[derive(Clone, Debug)]
pub struct ClockSync {
    config: ClockSyncConfig,
    blocks: VecDeque<Block>,
    /// Remote time of the first sample: the origin of the fit, ns.
    remote_ref_ns: i64,
    /// `host − remote` of the first sample: subtracted before the fit (keeps it in small floats).
    diff_ref_ns: i64,
    /// Latest remote time accepted, ns.
    last_remote_ns: i64,
    line: Option<Line>,
    samples: u64,
    refused: u64,
}

impl Default for ClockSync {
    fn default() -> Self {
        Self::new(ClockSyncConfig::default())
    }
}

impl ClockSync {
    /// An empty relation with these settings.
    pub fn new(config: ClockSyncConfig) -> Self {
        Self {
            config,
            blocks: VecDeque::new(),
            remote_ref_ns: 0,
            diff_ref_ns: 0,
            last_remote_ns: 0,
            line: None,
            samples: 0,
            refused: 0,
        }
    }

    /// Adds a pair: a remote clock reading and the host time it arrived, both ns. Returns `false`
    /// (and counts it in [`ClockSync::refused`]) when the pair is refused: a remote time before the
    /// current block (the remote clock went back: call [`ClockSync::reset`]), or a difference that
    /// does not fit in an `i64`.
    pub fn push(&mut self, remote_ns: i64, host_ns: i64) -> bool {
        let Some(diff_ns) = host_ns.checked_sub(remote_ns) else {
            self.refused += 1;
            return false;
        };
        if self.blocks.is_empty() {
            self.remote_ref_ns = remote_ns;
            self.diff_ref_ns = diff_ns;
            self.last_remote_ns = remote_ns;
        }
        let block_ns = self.config.block_ns.max(1);
        match self.blocks.back_mut() {
            Some(back) if remote_ns < back.start_remote_ns => {
                self.refused += 1;
                return false;
            }
            Some(back) if remote_ns - back.start_remote_ns < block_ns => {
                back.count = back.count.saturating_add(1);
                if diff_ns < back.min_diff_ns {
                    back.min_diff_ns = diff_ns;
                    back.remote_ns = remote_ns;
                }
            }
            _ => {
                self.blocks.push_back(Block {
                    start_remote_ns: remote_ns,
                    remote_ns,
                    min_diff_ns: diff_ns,
                    count: 1,
                });
                while self.blocks.len() > self.config.max_blocks.max(1) {
                    self.blocks.pop_front();
                }
            }
        }
        self.last_remote_ns = self.last_remote_ns.max(remote_ns);
        self.samples += 1;
        self.line = self.fit();
        true
    }

    /// Host time (ns) at which the remote clock read `remote_ns`, without the transport delay;
    /// `None` before the first sample.
    pub fn to_host(&self, remote_ns: i64) -> Option<i64> {
        let line = self.line?;
        let x = (remote_ns - self.remote_ref_ns) as f64;
        let diff = line.a_ns + line.b * x;
        remote_ns
            .checked_add(self.diff_ref_ns)?
            .checked_add(diff.round() as i64)
    }

    /// Remote clock reading (ns) at host time `host_ns`; `None` before the first sample.
    pub fn to_remote(&self, host_ns: i64) -> Option<i64> {
        let line = self.line?;
        // host = remote_ref + x + diff_ref + a + b·x, solved for x = remote − remote_ref.
        let rest = host_ns
            .checked_sub(self.remote_ref_ns)?
            .checked_sub(self.diff_ref_ns)?;
        let x = (rest as f64 - line.a_ns) / (1.0 + line.b);
        self.remote_ref_ns.checked_add(x.round() as i64)
    }

    /// Current offset `host − remote` (ns) at the latest remote time pushed; `None` before the
    /// first sample.
    pub fn offset_ns(&self) -> Option<i64> {
        let host = self.to_host(self.last_remote_ns)?;
        host.checked_sub(self.last_remote_ns)
    }

    /// Rate of the host clock relative to the remote clock minus one, ppm (positive: the host clock
    /// runs fast); `None` before the first sample.
    pub fn drift_ppm(&self) -> Option<f64> {
        self.line.map(|line| line.b * PPM)
    }

    /// Pairs accepted since the start or the last reset.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Pairs refused since the start or the last reset.
    pub fn refused(&self) -> u64 {
        self.refused
    }

    /// Forgets everything (after a reset of either clock); the settings stay.
    pub fn reset(&mut self) {
        *self = Self::new(self.config);
    }

    /// Line through the block minima (weighted least squares, one pass of outlier removal).
    fn fit(&self) -> Option<Line> {
        let points: Vec<(f64, f64, f64)> = self
            .blocks
            .iter()
            .map(|b| {
                (
                    (b.remote_ns - self.remote_ref_ns) as f64,
                    (b.min_diff_ns - self.diff_ref_ns) as f64,
                    f64::from(b.count),
                )
            })
            .collect();
        let line = self.weighted_line(&points)?;
        if points.len() < MIN_BLOCKS_FOR_OUTLIERS {
            return Some(line);
        }
        let residuals: Vec<f64> = points
            .iter()
            .map(|&(x, y, _)| y - (line.a_ns + line.b * x))
            .collect();
        let mid = median(&residuals)?;
        let deviations: Vec<f64> = residuals.iter().map(|r| (r - mid).abs()).collect();
        let mad = median(&deviations)?;
        let limit =
            mid + (OUTLIER_SIGMAS * MAD_TO_SIGMA * mad).max(self.config.outlier_floor_ns as f64);
        let kept: Vec<(f64, f64, f64)> = points
            .iter()
            .zip(&residuals)
            .filter(|&(_, &r)| r <= limit)
            .map(|(&p, _)| p)
            .collect();
        if kept.len() == points.len() {
            return Some(line);
        }
        self.weighted_line(&kept).or(Some(line))
    }

    /// Weighted least-squares line through `(x, y, weight)`; with one point, or all at one `x`,
    /// a zero drift through the lowest point.
    fn weighted_line(&self, points: &[(f64, f64, f64)]) -> Option<Line> {
        let lowest = points
            .iter()
            .min_by(|p, q| p.1.total_cmp(&q.1))
            .map(|&(_, y, _)| Line { a_ns: y, b: 0.0 })?;
        let sw: f64 = points.iter().map(|p| p.2).sum();
        if points.len() < 2 || sw <= 0.0 {
            return Some(lowest);
        }
        let xm = points.iter().map(|p| p.2 * p.0).sum::<f64>() / sw;
        let ym = points.iter().map(|p| p.2 * p.1).sum::<f64>() / sw;
        let sxx: f64 = points.iter().map(|p| p.2 * (p.0 - xm).powi(2)).sum();
        let sxy: f64 = points.iter().map(|p| p.2 * (p.0 - xm) * (p.1 - ym)).sum();
        if sxx <= 0.0 {
            return Some(lowest);
        }
        let max_b = self.config.max_drift_ppm.abs() / PPM;
        let b = (sxy / sxx).clamp(-max_b, max_b);
        let line = Line {
            a_ns: ym - b * xm,
            b,
        };
        (line.a_ns.is_finite() && line.b.is_finite())
            .then_some(line)
            .or(Some(lowest))
    }
}

/// Median of a non-empty slice (`None` when empty).
fn median(values: &[f64]) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => sorted.get(n / 2).copied(),
        _ => Some((sorted.get(n / 2 - 1)? + sorted.get(n / 2)?) / 2.0),
    }
}

/// One reading of [`Unwrap32`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unwrapped {
    /// Continuous time on the counter's clock, ns.
    pub t_ns: i64,
    /// Whether this reading started a new epoch of the counter (a reset, see [`Unwrap32`]).
    pub reset: bool,
}

/// Turns a free-running 32-bit microsecond counter (the NIC's, wrapping every 2³² µs ≈ 71.6 min)
/// into continuous nanoseconds, and notices when the counter was reset.
///
/// A reading alone cannot tell a wrap from a reset (a counter reset to 0 from 3·10⁹ µs looks like a
/// wrap followed by 21 min), so each reading comes with the host time it arrived: the forward step
/// of the counter, taken modulo 2³² µs on the lap that best matches the host's elapsed time, must
/// agree with it within `tolerance_ns`. Otherwise:
///
/// - a step *back* of at most `tolerance_ns` is a reading that arrived late (reordered): its time
///   is returned as is (earlier than the previous one) and the state is kept;
/// - anything else is a **reset**: counted, and the output goes on from the previous time plus the
///   host's elapsed time, so it stays monotonic. A [`ClockSync`] fed with these times should then be
///   reset too.
#[derive(Clone, Debug)]
pub struct Unwrap32 {
    tolerance_ns: i64,
    /// Last raw reading, its continuous time and its host time.
    last: Option<(u32, i64, i64)>,
    resets: u64,
}

impl Unwrap32 {
    /// Counter period, µs.
    const LAP_US: i64 = 1 << 32;
    /// Nanoseconds per microsecond.
    const NS_PER_US: i64 = 1_000;

    /// An unwrapper that accepts `tolerance_ns` of disagreement between the counter's step and the
    /// host's elapsed time (host arrival jitter plus bursts: 10 s is a safe choice; it must stay well
    /// below the 71.6 min lap).
    pub fn new(tolerance_ns: i64) -> Self {
        Self {
            tolerance_ns: tolerance_ns.max(0),
            last: None,
            resets: 0,
        }
    }

    /// Continuous time for the raw reading `raw_us` that arrived at host time `host_ns`.
    pub fn push(&mut self, raw_us: u32, host_ns: i64) -> Unwrapped {
        let Some((last_raw, last_t, last_host)) = self.last else {
            let t_ns = i64::from(raw_us) * Self::NS_PER_US;
            self.last = Some((raw_us, t_ns, host_ns));
            return Unwrapped { t_ns, reset: false };
        };
        let host_dt_ns = host_ns.saturating_sub(last_host);
        let step_us = i64::from(raw_us.wrapping_sub(last_raw));
        // Laps that bring the counter's step nearest to the host's elapsed time.
        let laps = ((host_dt_ns / Self::NS_PER_US - step_us) as f64 / Self::LAP_US as f64)
            .round()
            .max(0.0) as i64;
        let forward_ns = (step_us + laps * Self::LAP_US) * Self::NS_PER_US;
        if (forward_ns - host_dt_ns).abs() <= self.tolerance_ns {
            let t_ns = last_t + forward_ns;
            self.last = Some((raw_us, t_ns, host_ns));
            return Unwrapped { t_ns, reset: false };
        }
        let back_ns = (Self::LAP_US - step_us) * Self::NS_PER_US;
        if back_ns <= self.tolerance_ns {
            return Unwrapped {
                t_ns: last_t - back_ns,
                reset: false,
            };
        }
        self.resets += 1;
        let t_ns = last_t + host_dt_ns.max(0);
        self.last = Some((raw_us, t_ns, host_ns));
        Unwrapped { t_ns, reset: true }
    }

    /// Resets of the counter seen so far.
    pub fn resets(&self) -> u64 {
        self.resets
    }
}

#[cfg(test)]
mod tests;
