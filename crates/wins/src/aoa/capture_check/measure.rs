//! What the check measures on every CSI record, streaming: each receive chain's power and
//! RSSI, the CSI entries at the 8-bit limits, the phase between neighbouring chains, the chains'
//! curvature, and the gaps between records.

use num_complex::{Complex, Complex64};

use crate::aoa::ChainCurvature;
use crate::csi::intel5300::CsiRecord;
use crate::csi::subcarriers::NUM_SUBCARRIERS;
use crate::time::Timestamp;

/// Receive chains a 5300 reports.
pub(super) const CHAINS: usize = 3;

/// A gap between records longer than this is counted, s.
pub(super) const GAP_S: f64 = 0.5;

/// The running measurements of a capture.
#[derive(Clone, Debug, Default)]
pub(super) struct Measurements {
    /// CSI records with three receive chains (the only ones the phase measurements use).
    pub three_chain_records: u64,
    /// Per receive chain (after the permutation): summed `Σ_k |H_k|²` of the first stream.
    pub chain_power: [f64; CHAINS],
    /// Records each chain's power was summed over.
    pub chain_power_records: [u64; CHAINS],
    /// Per chain, the records whose RSSI reading is 0 (no signal on that chain).
    pub rssi_zero: [u64; CHAINS],
    /// CSI entries read, and those with a part at −128 or +127 (the 8-bit limits).
    pub entries: u64,
    pub clipped_entries: u64,
    /// Records with at least one clipped entry.
    pub clipped_records: u64,
    /// Per packet, the phase of chain `m + 1` against chain `m` (`m` = 0, 1), rad: the argument
    /// of `Σ_k H_{m+1,k} H̄_{m,k}` (the timing offset's slope, common to the chains, cancels).
    pub pair_phases_rad: [Vec<f64>; 2],
    /// The chains' curvature `φ₀ − 2φ₁ + φ₂`, over the packets.
    pub curvature: ChainCurvature,
    /// Time of the previous record, and the gaps: the longest, s, and how many exceed [`GAP_S`].
    last_t: Option<Timestamp>,
    pub longest_gap_s: f64,
    pub gaps: u64,
    /// AGC values seen, and how often it changed from one record to the next.
    last_agc: Option<u8>,
    pub agc_changes: u64,
}

impl Measurements {
    /// Adds one record.
    pub fn add(&mut self, r: &CsiRecord) {
        let h = &r.header;
        if let Some(last) = self.last_t {
            let gap = r.timestamp.secs_since(last);
            if gap > self.longest_gap_s {
                self.longest_gap_s = gap;
            }
            if gap > GAP_S {
                self.gaps += 1;
            }
        }
        self.last_t = Some(r.timestamp);
        if self.last_agc.is_some_and(|a| a != h.agc) {
            self.agc_changes += 1;
        }
        self.last_agc = Some(h.agc);
        for (zero, rssi) in self.rssi_zero.iter_mut().zip(h.rssi) {
            if rssi == 0 {
                *zero += 1;
            }
        }
        let limit = |x: i8| x == i8::MIN || x == i8::MAX;
        let clipped = r
            .csi()
            .iter()
            .filter(|c| limit(c.re) || limit(c.im))
            .count() as u64;
        self.entries += r.csi().len() as u64;
        self.clipped_entries += clipped;
        self.clipped_records += u64::from(clipped > 0);

        // The first stream, per receive chain.
        let nrx = usize::from(h.nrx).min(CHAINS);
        let chain: Vec<Vec<Complex64>> = (0..nrx)
            .map(|rx| {
                (0..NUM_SUBCARRIERS)
                    .map(|k| to_f64(r.csi_at(0, rx, k).unwrap_or_default()))
                    .collect()
            })
            .collect();
        for (rx, h) in chain.iter().enumerate() {
            self.chain_power[rx] += h.iter().map(Complex64::norm_sqr).sum::<f64>();
            self.chain_power_records[rx] += 1;
        }
        if nrx < CHAINS {
            return;
        }
        self.three_chain_records += 1;
        for m in 0..2 {
            let z: Complex64 = chain[m + 1]
                .iter()
                .zip(&chain[m])
                .map(|(b, a)| b * a.conj())
                .sum();
            if z.norm() > 0.0 {
                self.pair_phases_rad[m].push(z.arg());
            }
        }
        let flat: Vec<Complex64> = chain.concat();
        self.curvature.push(&flat, CHAINS);
    }

    /// Each chain's mean power relative to the strongest, dB (`None` for a chain never seen, or
    /// `-inf` for one with no power).
    pub fn chain_power_db(&self) -> [Option<f64>; CHAINS] {
        let mean: [Option<f64>; CHAINS] = std::array::from_fn(|rx| {
            (self.chain_power_records[rx] > 0)
                .then(|| self.chain_power[rx] / self.chain_power_records[rx] as f64)
        });
        let strongest = mean.iter().flatten().copied().fold(0.0, f64::max);
        mean.map(|m| m.map(|p| 10.0 * (p / strongest).log10()))
    }
}

fn to_f64(c: Complex<i8>) -> Complex64 {
    Complex64::new(f64::from(c.re), f64::from(c.im))
}

/// The 5300's chains can step by multiples of π/2 (at 2.4 GHz, packet to packet on some
/// captures) or π (at 5 GHz, when the NIC restarts): the phase between two chains is read modulo
/// this quantum, rad.
const QUANTUM_RAD: f64 = std::f64::consts::FRAC_PI_2;

/// The phases between two chains over a capture: the value most packets share, the scatter
/// about it, and the packets that sit a whole number of quarter turns away from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Spread {
    /// The phase most packets share, rad.
    pub mean_rad: f64,
    /// Interquartile range of each packet's phase about its nearest quarter turn from the mean, rad.
    pub iqr_rad: f64,
    /// Share of the packets a quarter, half or three quarters of a turn off the mean.
    pub stepped: f64,
    /// Whether any packet is a quarter turn off (else only half turns).
    pub quarter_steps: bool,
    /// Share of the packets an odd number of quarter turns off the mean.
    pub quarter_share: f64,
    /// Index of the first packet off the mean by a step.
    pub first_step: Option<usize>,
}

/// The [`Spread`] of `angles` (`None` when empty). The quarter-turn grid is placed by the mean
/// of the quadrupled angles (which steps of π/2 do not move); each packet then sits on one of
/// the grid's four values, and the one most packets share is the mean.
pub(super) fn spread(angles: &[f64]) -> Option<Spread> {
    if angles.is_empty() {
        return None;
    }
    let n = 4.0;
    let grid: Complex64 = angles
        .iter()
        .map(|a| Complex64::from_polar(1.0, n * a))
        .sum();
    let base = grid.arg() / n;
    let mut counts = [0usize; 4];
    let mut residuals = Vec::with_capacity(angles.len());
    let mut steps = Vec::with_capacity(angles.len());
    for a in angles {
        let off = crate::csi::sanitize::wrap(a - base);
        let k = (off / QUANTUM_RAD).round();
        residuals.push(off - k * QUANTUM_RAD);
        let k = (k as i64).rem_euclid(4) as usize;
        counts[k] += 1;
        steps.push(k);
    }
    let main = (0..4).max_by_key(|&k| counts[k]).unwrap_or(0);
    let off_main = |k: usize| k != main;
    residuals.sort_by(f64::total_cmp);
    let last = residuals.len() - 1;
    let q = |p: f64| residuals[(last as f64 * p).round() as usize];
    Some(Spread {
        mean_rad: crate::csi::sanitize::wrap(base + main as f64 * QUANTUM_RAD),
        iqr_rad: q(0.75) - q(0.25),
        stepped: steps.iter().filter(|&&k| off_main(k)).count() as f64 / angles.len() as f64,
        quarter_steps: (0..4).any(|k| counts[k] > 0 && (k + 4 - main) % 2 == 1),
        quarter_share: steps.iter().filter(|&&k| (k + 4 - main) % 2 == 1).count() as f64
            / angles.len() as f64,
        first_step: steps.iter().position(|&k| off_main(k)),
    })
}
