//! 802.11n subcarrier index sets as the Intel 5300 reports them (30 groups per packet).

use serde::{Deserialize, Serialize};

/// Number of subcarrier groups the Intel 5300 reports per (tx, rx) pair.
pub const NUM_SUBCARRIERS: usize = 30;

/// OFDM subcarrier spacing of 802.11n, Hz. Subcarrier `k` sits at `k · SUBCARRIER_SPACING_HZ` from
/// the channel centre.
pub const SUBCARRIER_SPACING_HZ: f64 = 312_500.0;

/// HT20 (grouping 2): non-uniform at the centre (−2, −1, 1) and at the edges (27, 28).
const HT20_INDICES: [i32; NUM_SUBCARRIERS] = [
    -28, -26, -24, -22, -20, -18, -16, -14, -12, -10, -8, -6, -4, -2, -1, 1, 3, 5, 7, 9, 11, 13,
    15, 17, 19, 21, 23, 25, 27, 28,
];

/// HT40 (grouping 4): −58, −54, …, −2, 2, …, 58, uniform 1.25 MHz apart but for the gap at DC.
const HT40_INDICES: [i32; NUM_SUBCARRIERS] = [
    -58, -54, -50, -46, -42, -38, -34, -30, -26, -22, -18, -14, -10, -6, -2, 2, 6, 10, 14, 18, 22,
    26, 30, 34, 38, 42, 46, 50, 54, 58,
];

/// Channel bandwidth of a packet.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Bandwidth {
    /// 20 MHz.
    Ht20,
    /// 40 MHz.
    Ht40,
}

impl Bandwidth {
    /// The true 802.11n subcarrier indices of the 30 reported groups, in report order. Popular SpotFi
    /// clones use a uniform spacing instead; that is wrong for HT20 (docs/DESIGN.md §3).
    pub fn subcarrier_indices(self) -> &'static [i32; NUM_SUBCARRIERS] {
        match self {
            Bandwidth::Ht20 => &HT20_INDICES,
            Bandwidth::Ht40 => &HT40_INDICES,
        }
    }

    /// Offsets of the reported subcarriers from the channel centre, Hz.
    pub fn subcarrier_offsets_hz(self) -> [f64; NUM_SUBCARRIERS] {
        self.subcarrier_indices()
            .map(|k| f64::from(k) * SUBCARRIER_SPACING_HZ)
    }

    /// Bandwidth in MHz.
    pub fn mhz(self) -> u32 {
        match self {
            Bandwidth::Ht20 => 20,
            Bandwidth::Ht40 => 40,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_sets_are_sorted_symmetric_and_skip_dc() {
        for bw in [Bandwidth::Ht20, Bandwidth::Ht40] {
            let idx = bw.subcarrier_indices();
            assert!(idx.windows(2).all(|w| w[0] < w[1]), "{bw:?} not increasing");
            assert!(!idx.contains(&0), "{bw:?} contains DC");
            assert_eq!(idx[0], -idx[29], "{bw:?} edges");
        }
        // HT40 is mirror-symmetric; HT20 is even below DC and odd above it.
        let ht40 = Bandwidth::Ht40.subcarrier_indices();
        assert!(ht40.iter().zip(ht40.iter().rev()).all(|(a, b)| *a == -*b));
        let ht20 = Bandwidth::Ht20.subcarrier_indices();
        assert!(ht20[..13].iter().all(|k| k % 2 == 0) && ht20[15..29].iter().all(|k| k % 2 != 0));
        // HT40 is uniform 4 apart, DC included (−2 → 2).
        assert!(ht40.windows(2).all(|w| w[1] - w[0] == 4));
        assert_eq!(
            Bandwidth::Ht40.subcarrier_offsets_hz()[29],
            58.0 * 312_500.0
        );
        // HT20 steps: 2 except around DC (−2, −1, 1) and at the top edge (27, 28).
        let steps: Vec<i32> = Bandwidth::Ht20
            .subcarrier_indices()
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        assert_eq!(steps.iter().filter(|&&s| s == 1).count(), 2);
        assert_eq!(steps[13..16], [1, 2, 2]);
        assert_eq!(steps[28], 1);
    }
}
