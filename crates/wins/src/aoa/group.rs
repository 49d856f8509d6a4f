//! SpotFi over a group of records: MUSIC peaks per packet, then [`super::spotfi::direct_path`].

use super::estimator::AoaEstimator;
use super::music::AoaWindow;
use super::peak::Peak;
use super::spotfi::{DirectPath, SpotfiError, direct_path};
use crate::csi::intel5300::CsiRecord;

/// SpotFi's answer for a group of packets.
#[derive(Clone, Debug)]
pub struct GroupResult {
    /// The direct path of the group, or why there is none.
    pub direct: Result<DirectPath, SpotfiError>,
    /// Each record's credible peaks (empty for skipped records), in input order.
    pub peaks: Vec<Vec<Peak>>,
    /// Records that gave no peaks because they could not be processed: index and reason.
    pub skipped: Vec<(usize, String)>,
}

impl AoaEstimator {
    /// SpotFi's direct path over `records` (e.g. 10 consecutive packets; the paper's
    /// initialization of Algorithm 1).
    pub fn spotfi<'a>(&self, records: impl IntoIterator<Item = &'a CsiRecord>) -> GroupResult {
        let mut peaks = Vec::new();
        let mut skipped = Vec::new();
        for (i, record) in records.into_iter().enumerate() {
            match self.peaks(record, AoaWindow::FULL) {
                Ok(p) => peaks.push(p),
                Err(e) => {
                    skipped.push((i, e.to_string()));
                    peaks.push(Vec::new());
                }
            }
        }
        GroupResult {
            direct: direct_path(&peaks, &self.config().spotfi),
            peaks,
            skipped,
        }
    }
}
