//! A slice of a sweep for a batch system: shard K of N.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::SweepError;

/// Part `index` of `count` of a sweep: it keeps the runs whose canonical index `i` (from 0)
/// has `i % count == index − 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shard {
    /// K, from 1.
    pub index: usize,
    /// N ≥ 1.
    pub count: usize,
}

impl Shard {
    /// Parses `K/N` with 1 ≤ K ≤ N.
    pub fn parse(text: &str) -> Result<Self, SweepError> {
        let fail = |reason: &str| SweepError::Shard {
            text: text.to_string(),
            reason: reason.to_string(),
        };
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| fail("expected K/N, e.g. 2/8 (the second of 8 shards)"))?;
        let parse = |s: &str| s.trim().parse::<usize>().ok();
        let (Some(index), Some(count)) = (parse(k), parse(n)) else {
            return Err(fail("K and N must be whole numbers"));
        };
        if count == 0 || index == 0 || index > count {
            return Err(fail("needs 1 ≤ K ≤ N (shards count from 1)"));
        }
        Ok(Self { index, count })
    }

    /// Whether the run with canonical index `run_index` is this shard's.
    pub fn keeps(&self, run_index: usize) -> bool {
        run_index % self.count == self.index - 1
    }
}

impl FromStr for Shard {
    type Err = SweepError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}
