//! A remote clock tracked so that no single sample can break it: [`ClockTrack`], a
//! [`ClockSync`] line guarded against outliers and re-locked when the clock restarts.
//!
//! ## The model
//!
//! A sample is a remote reading `r` and the host time `h` it arrived, `d = h − r`. On the current
//! line `d̂(r)` (the lower envelope of [`ClockSync`]), a good sample sits at or a little above
//! it: its *residual* `e = d − d̂(r)` is the transport delay, never negative. So a sample
//!
//! - **agrees with the line** when `−tolerance ≤ e ≤ max_late`: taken into the line, and its
//!   time used (a sample up to `max_late` late is a slow arrival, which the merger places or
//!   counts late; one ahead of the line by more than the tolerance cannot have been sent at its
//!   time);
//! - otherwise it **disagrees**, and is held as a *candidate*, its time not used. Candidates are
//!   consecutive samples that disagree with the line and agree with each other: their `d` lie
//!   within `tolerance` of one another.
//!
//! What becomes of the candidates:
//!
//! - a sample that agrees with the line again refuses them: each was an **outlier** (a lone time
//!   far from the line: a corrupt or misdated message), counted, and the line is unchanged;
//! - a sample that disagrees with both the line and the candidates refuses the candidates
//!   (outliers) and starts a new set;
//! - once [`TrackConfig::lock_samples`] candidates, spanning at least
//!   [`TrackConfig::lock_span_ns`] of remote time, agree, the clock has moved for good (it
//!   restarted, or the line went stale over a long silence): the line is **re-locked** on them,
//!   counted. The span rules out a burst of messages queued in a stalled link, whose `d` fall
//!   with their remote times at the rate they were queued.
//!
//! The first lock follows the same rule: nothing is placed until `lock_samples` samples agree.
//!
//! ## The timeline
//!
//! A restarted clock reads times the session has already passed. So every placed sample is
//! given a time on the clock's **timeline**: its reading plus an epoch offset, 0 until the first
//! re-lock and, at each re-lock, set so that the timeline goes on through the host's clock (the
//! old line maps the host time of the new epoch's first candidate to the timeline). Across a
//! restart the timeline continues; within an epoch it is the remote clock shifted.

use super::{ClockSync, ClockSyncConfig};

/// Settings of [`ClockTrack`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackConfig {
    /// The line's settings.
    pub sync: ClockSyncConfig,
    /// How far ahead of the line a sample may sit, and how far apart the candidates of a lock
    /// may lie, ns (default 20 ms: the line is a lower envelope, so a good sample sits at most
    /// its fit error below it; a link's jitter is a few ms).
    pub tolerance_ns: i64,
    /// How far behind the line a sample may sit and still be a late arrival rather than a
    /// jump of the clock, ns (default 5 s).
    pub max_late_ns: i64,
    /// Candidates that must agree to lock (default 5).
    pub lock_samples: usize,
    /// Remote time they must span at least, ns (default 50 ms: more than twice the tolerance,
    /// so that a queued burst, whose `d` spread as its span, cannot lock).
    pub lock_span_ns: i64,
}

impl Default for TrackConfig {
    fn default() -> Self {
        Self {
            sync: ClockSyncConfig::default(),
            tolerance_ns: 20_000_000,
            max_late_ns: 5_000_000_000,
            lock_samples: 5,
            lock_span_ns: 50_000_000,
        }
    }
}

/// What became of one sample ([`ClockTrack::push`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Pushed {
    /// The sample's time on the timeline, ns, when it is placed (it agrees with the line, or
    /// completed a lock); `None` when it is held as a candidate.
    pub t_ns: Option<i64>,
    /// Earlier samples refused now as outliers (0 before the first lock: those are
    /// [`Pushed::dropped_unlocked`]).
    pub outliers: u64,
    /// Earlier samples dropped before the first lock (they agreed with no lock).
    pub dropped_unlocked: u64,
    /// Whether this sample re-locked the line (not the first lock).
    pub relocked: bool,
    /// Earlier samples the lock (or re-lock) this sample completed was made on: held, their
    /// times not used.
    pub locked_on: u64,
}

/// A remote clock tracked robustly (module doc).
#[derive(Clone, Debug)]
pub struct ClockTrack {
    config: TrackConfig,
    /// The current epoch's line, `None` before the first lock.
    sync: Option<ClockSync>,
    /// Samples that disagree with the line and agree with each other: (remote, host), ns.
    candidates: Vec<(i64, i64)>,
    /// Timeline minus remote reading in the current epoch, ns.
    epoch_offset_ns: i64,
    outliers: u64,
    relocks: u64,
}

impl Default for ClockTrack {
    fn default() -> Self {
        Self::new(TrackConfig::default())
    }
}

impl ClockTrack {
    /// An unlocked clock with these settings.
    pub fn new(config: TrackConfig) -> Self {
        Self {
            config,
            sync: None,
            candidates: Vec::new(),
            epoch_offset_ns: 0,
            outliers: 0,
            relocks: 0,
        }
    }

    /// Takes a sample: remote reading `remote_ns`, arrived at host time `host_ns` (module doc).
    pub fn push(&mut self, remote_ns: i64, host_ns: i64) -> Pushed {
        let mut out = Pushed::default();
        let Some(d) = host_ns.checked_sub(remote_ns) else {
            // Not even a difference: refused at once.
            self.refuse_one(&mut out);
            return out;
        };
        if let Some(e) = self.residual(remote_ns, d).filter(|e| self.agrees(*e)) {
            let n = self.candidates.len() as u64;
            self.candidates.clear();
            self.outliers += n;
            out.outliers = n;
            // Only a sample near the line shapes it: the line is a lower envelope, so a late
            // arrival tells nothing of it, and a misdated time that passes as late (read
            // earlier than it was sent) must not tilt it. A reordered sample older than the
            // line's newest block is not taken into it either, but its time is good.
            if e <= self.config.tolerance_ns
                && let Some(sync) = &mut self.sync
            {
                sync.push(remote_ns, host_ns);
            }
            out.t_ns = remote_ns.checked_add(self.epoch_offset_ns);
            return out;
        }
        if !self.agrees_with_candidates(d) {
            let n = self.candidates.len() as u64;
            self.candidates.clear();
            match self.sync {
                Some(_) => {
                    self.outliers += n;
                    out.outliers = n;
                }
                None => out.dropped_unlocked = n,
            }
        }
        self.candidates.push((remote_ns, host_ns));
        if self.lock_is_due() {
            out.relocked = self.sync.is_some();
            out.locked_on = self.candidates.len().saturating_sub(1) as u64;
            self.lock();
            out.t_ns = remote_ns.checked_add(self.epoch_offset_ns);
        }
        out
    }

    /// A sample that cannot even be held.
    fn refuse_one(&mut self, out: &mut Pushed) {
        match self.sync {
            Some(_) => {
                self.outliers += 1;
                out.outliers += 1;
            }
            None => out.dropped_unlocked += 1,
        }
    }

    /// The residual `e = d − d̂(r)` of a sample on the line; `None` before the first lock.
    fn residual(&self, remote_ns: i64, d: i64) -> Option<i64> {
        let line_host = self.sync.as_ref().and_then(|s| s.to_host(remote_ns))?;
        line_host
            .checked_sub(remote_ns)
            .and_then(|line_d| d.checked_sub(line_d))
    }

    /// Whether a residual agrees with the line (module doc).
    fn agrees(&self, e: i64) -> bool {
        (-self.config.tolerance_ns..=self.config.max_late_ns).contains(&e)
    }

    fn agrees_with_candidates(&self, d: i64) -> bool {
        self.candidates.iter().all(|&(r, h)| {
            (h - r)
                .checked_sub(d)
                .is_some_and(|x| x.abs() <= self.config.tolerance_ns)
        })
    }

    fn lock_is_due(&self) -> bool {
        let (Some(first), Some(last)) = (self.candidates.first(), self.candidates.last()) else {
            return false;
        };
        self.candidates.len() >= self.config.lock_samples.max(1)
            && last.0.saturating_sub(first.0) >= self.config.lock_span_ns
    }

    /// Adopts the line through the candidates, the timeline carried on through the host's clock.
    fn lock(&mut self) {
        let mut sync = ClockSync::new(self.config.sync);
        for &(r, h) in &self.candidates {
            sync.push(r, h);
        }
        if let (Some(old), Some(&(r0, _))) = (&self.sync, self.candidates.first()) {
            // The timeline at the host time the new line gives r0, by the old line.
            let continued = sync
                .to_host(r0)
                .and_then(|h| old.to_remote(h))
                .and_then(|t| t.checked_add(self.epoch_offset_ns));
            if let Some(offset) = continued.and_then(|t| t.checked_sub(r0)) {
                self.epoch_offset_ns = offset;
            }
            self.relocks += 1;
        }
        self.sync = Some(sync);
        self.candidates.clear();
    }

    /// Host time (ns) of timeline time `t_ns`, without the transport delay; `None` before the
    /// first lock.
    pub fn to_host(&self, t_ns: i64) -> Option<i64> {
        self.sync
            .as_ref()?
            .to_host(t_ns.checked_sub(self.epoch_offset_ns)?)
    }

    /// Timeline time (ns) at host time `host_ns`; `None` before the first lock.
    pub fn to_timeline(&self, host_ns: i64) -> Option<i64> {
        self.sync
            .as_ref()?
            .to_remote(host_ns)?
            .checked_add(self.epoch_offset_ns)
    }

    /// Timeline minus the remote clock's reading in the current epoch, ns (0 until a re-lock).
    pub fn epoch_offset_ns(&self) -> i64 {
        self.epoch_offset_ns
    }

    /// The current epoch's offset `host − remote`, ns ([`ClockSync::offset_ns`]).
    pub fn offset_ns(&self) -> Option<i64> {
        self.sync.as_ref()?.offset_ns()
    }

    /// The current epoch's drift, ppm ([`ClockSync::drift_ppm`]).
    pub fn drift_ppm(&self) -> Option<f64> {
        self.sync.as_ref()?.drift_ppm()
    }

    /// Samples refused as outliers so far.
    pub fn outliers(&self) -> u64 {
        self.outliers
    }

    /// Re-locks so far.
    pub fn relocks(&self) -> u64 {
        self.relocks
    }

    /// Candidates held now.
    pub fn held(&self) -> usize {
        self.candidates.len()
    }
}

#[cfg(test)]
mod tests;
