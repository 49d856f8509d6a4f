//! SpotFi over a group of records: MUSIC peaks per packet, then [`super::spotfi::direct_path`].

use super::estimator::{AoaError, AoaEstimator};
use super::music::AoaWindow;
use super::peak::Peak;
use super::spotfi::{DirectPath, SpotfiConfig, SpotfiError, direct_path};
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
        spotfi_over(records, &self.config().spotfi, |r| {
            self.peaks(r, AoaWindow::FULL)
        })
    }
}

/// SpotFi's direct path over `packets`, each one's credible peaks over the full range from
/// `peaks` (a packet it cannot process gives none, and is listed with why).
pub(crate) fn spotfi_over<T>(
    packets: impl IntoIterator<Item = T>,
    config: &SpotfiConfig,
    mut peaks: impl FnMut(T) -> Result<Vec<Peak>, AoaError>,
) -> GroupResult {
    let mut all = Vec::new();
    let mut skipped = Vec::new();
    for (i, packet) in packets.into_iter().enumerate() {
        match peaks(packet) {
            Ok(p) => all.push(p),
            Err(e) => {
                skipped.push((i, e.to_string()));
                all.push(Vec::new());
            }
        }
    }
    GroupResult {
        direct: direct_path(&all, config),
        peaks: all,
        skipped,
    }
}
