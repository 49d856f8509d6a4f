//! One decoded CSI record (code 0xBB, "beamforming feedback" or *bfee*) and its scaling to an
//! absolute channel, as the CSI Tool's `get_scaled_csi.m` and `get_total_rss.m` compute it.

use num_complex::{Complex, Complex64};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::csi::subcarriers::NUM_SUBCARRIERS;
use crate::time::Timestamp;

use super::layout::{CSI_PREFIX, packed_csi_len};
use super::rate::RateFlags;

/// Most receive or transmit chains the Intel 5300 reports.
pub const MAX_CHAINS: usize = 3;
/// Most complex CSI entries in one record (3 × 3 × 30).
pub const MAX_ENTRIES: usize = MAX_CHAINS * MAX_CHAINS * NUM_SUBCARRIERS;
/// The noise value the firmware reports when it has no noise reading.
pub const NOISE_UNKNOWN_DBM: i8 = -127;
/// The noise floor `get_scaled_csi.m` assumes when the firmware reports none.
pub const DEFAULT_NOISE_DBM: f64 = -92.0;
/// `get_total_rss.m`: RSSI (dB) − 44 − AGC = received power in dBm.
pub const RSSI_TO_DBM_OFFSET: f64 = 44.0;

/// The 20-byte little-endian header of a CSI record, as the firmware wrote it.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BfeeHeader {
    /// Low 32 bits of the NIC's 1 MHz clock, µs; wraps every ~71.6 min.
    pub timestamp_low: u32,
    /// Count of beamforming reports the driver has sent to user space (wraps at 2¹⁶).
    pub bfee_count: u16,
    /// Receive chains in the CSI (1–3).
    pub nrx: u8,
    /// Transmit streams in the CSI (1–3).
    pub ntx: u8,
    /// RSSI of receive chains A, B, C in dB relative to the AGC; 0 means no reading.
    pub rssi: [u8; 3],
    /// Noise floor, dBm; −127 means unknown.
    pub noise_dbm: i8,
    /// Automatic gain control setting, dB.
    pub agc: u8,
    /// Antenna selection: 2 bits per receive chain giving the antenna it is wired to.
    pub antenna_sel: u8,
    /// Low 16 bits of the packet's `rate_n_flags`.
    pub rate: RateFlags,
}

impl BfeeHeader {
    /// Number of complex CSI entries: `ntx · nrx · 30`.
    pub fn num_entries(&self) -> usize {
        usize::from(self.nrx) * usize::from(self.ntx) * NUM_SUBCARRIERS
    }

    /// The antenna of each receive chain, 0-based (MATLAB prints these plus one as `perm`).
    pub fn raw_perm(&self) -> [u8; 3] {
        let s = self.antenna_sel;
        [s & 3, (s >> 2) & 3, (s >> 4) & 3]
    }

    /// Whether the antenna permutation can be applied, and to what.
    pub fn perm(&self) -> Perm {
        let raw = self.raw_perm();
        let n = usize::from(self.nrx);
        if n <= 1 {
            return Perm::SingleChain;
        }
        let mut seen = [false; MAX_CHAINS];
        for &p in &raw[..n.min(MAX_CHAINS)] {
            match seen.get_mut(usize::from(p)) {
                Some(s) if !*s && usize::from(p) < n => *s = true,
                _ => return Perm::Invalid(raw),
            }
        }
        Perm::Applied(raw)
    }
}

/// The antenna permutation of a record (MATLAB `read_bf_file.m` semantics, stricter validity).
///
/// MATLAB applies `perm` when `sum(perm(1:Nrx))` equals 1, 3 or 6; that accepts non-permutations such
/// as (2, 2, 2). Here it is applied only when the first `nrx` entries are a permutation of
/// `0..nrx`; on every real log we have, the two rules agree. csiread differs from both: it moves
/// every chain to `perm[k]`, even with one chain or an invalid permutation
/// (`scripts/csiread_crosscheck.py` shows where). When the permutation is not applied,
/// [`BfeeHeader::raw_perm`] still says which antenna each chain is wired to: with two chains on
/// antennas A and C, for example, the array geometry needs it.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "status", content = "perm")]
pub enum Perm {
    /// One receive chain: nothing to permute.
    SingleChain,
    /// Applied: chain `k` was moved to antenna `perm[k]` (0-based).
    Applied([u8; 3]),
    /// Not a permutation of the receive chains: CSI left in chain order.
    Invalid([u8; 3]),
}

/// Why a record's CSI cannot be scaled to an absolute channel.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Error, Serialize, Deserialize)]
pub enum ScaleError {
    /// All three RSSI readings are 0: there is no received power to scale to.
    #[error("no RSSI reading on any chain")]
    NoRssi,
    /// Every CSI entry is zero: there is no shape to scale.
    #[error("all CSI entries are zero")]
    ZeroCsi,
}

/// A decoded CSI record.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiRecord {
    /// Byte offset of the record's length field in the log or stream.
    pub offset: u64,
    /// `timestamp_low` unwrapped across its 32-bit wraps, on the NIC clock.
    pub timestamp: Timestamp,
    /// The header as logged.
    pub header: BfeeHeader,
    /// The antenna permutation and whether it was applied.
    pub perm: Perm,
    csi: [Complex<i8>; MAX_ENTRIES],
}

impl CsiRecord {
    /// A record from its header and CSI in `[tx][rx][subcarrier]` order *after* the antenna
    /// permutation (the layout of `read_bf_file.m`). Fails if the sizes disagree.
    pub fn new(
        header: BfeeHeader,
        csi: &[Complex<i8>],
        timestamp: Timestamp,
    ) -> Result<Self, ShapeError> {
        if !(1..=3).contains(&header.nrx) || !(1..=3).contains(&header.ntx) {
            return Err(ShapeError::Chains {
                nrx: header.nrx,
                ntx: header.ntx,
            });
        }
        if csi.len() != header.num_entries() {
            return Err(ShapeError::Entries {
                expected: header.num_entries(),
                got: csi.len(),
            });
        }
        let mut all = [Complex::new(0, 0); MAX_ENTRIES];
        all[..csi.len()].copy_from_slice(csi);
        Ok(Self::from_parts(0, timestamp, header, all))
    }

    pub(crate) fn from_parts(
        offset: u64,
        timestamp: Timestamp,
        header: BfeeHeader,
        csi: [Complex<i8>; MAX_ENTRIES],
    ) -> Self {
        Self {
            offset,
            timestamp,
            perm: header.perm(),
            header,
            csi,
        }
    }

    /// The true 802.11n indices of the 30 reported subcarriers, from the bandwidth bit of the rate.
    pub fn subcarrier_indices(&self) -> &'static [i32; NUM_SUBCARRIERS] {
        self.header.rate.bandwidth().subcarrier_indices()
    }

    /// Bytes this record takes in a log: framing, header and packed CSI.
    pub fn encoded_len(&self) -> usize {
        CSI_PREFIX + packed_csi_len(self.header.nrx, self.header.ntx)
    }

    /// Raw CSI, `[tx][rx][subcarrier]` (index `(tx·nrx + rx)·30 + sc`), after the permutation.
    pub fn csi(&self) -> &[Complex<i8>] {
        &self.csi[..self.header.num_entries()]
    }

    /// One raw CSI entry. `rx` is the antenna after the permutation (the chain if it is invalid).
    pub fn csi_at(&self, tx: usize, rx: usize, subcarrier: usize) -> Option<Complex<i8>> {
        let (nrx, ntx) = (usize::from(self.header.nrx), usize::from(self.header.ntx));
        if tx >= ntx || rx >= nrx || subcarrier >= NUM_SUBCARRIERS {
            return None;
        }
        self.csi
            .get((tx * nrx + rx) * NUM_SUBCARRIERS + subcarrier)
            .copied()
    }

    /// Total received power in dBm (`get_total_rss.m`): the chains' RSSI summed in linear power,
    /// minus 44 dB and the AGC. −∞ when no chain has a reading.
    pub fn total_rss_dbm(&self) -> f64 {
        let mag: f64 = self
            .header
            .rssi
            .iter()
            .filter(|&&r| r != 0)
            .map(|&r| db_inv(f64::from(r)))
            .sum();
        10.0 * mag.log10() - RSSI_TO_DBM_OFFSET - f64::from(self.header.agc)
    }

    /// CSI scaled to an absolute channel in units of √(SNR) per entry, exactly as `get_scaled_csi.m`:
    /// CSI power is matched to the RSSI, divided by thermal noise (`noise`, or −92 dBm when unknown)
    /// plus the quantization error, and raised by √2 or √(4.5 dB) for 2 or 3 transmit streams.
    /// Same layout as [`Self::csi`].
    pub fn scaled_csi(&self) -> Result<Vec<Complex64>, ScaleError> {
        let factor = self.scale_factor()?;
        Ok(self
            .csi()
            .iter()
            .map(|c| Complex64::new(f64::from(c.re) * factor, f64::from(c.im) * factor))
            .collect())
    }

    /// The factor [`Self::scaled_csi`] multiplies the raw CSI by.
    pub fn scale_factor(&self) -> Result<f64, ScaleError> {
        if self.header.rssi.iter().all(|&r| r == 0) {
            return Err(ScaleError::NoRssi);
        }
        let csi_pwr: f64 = self
            .csi()
            .iter()
            .map(|c| f64::from(c.re).powi(2) + f64::from(c.im).powi(2))
            .sum();
        if csi_pwr == 0.0 {
            return Err(ScaleError::ZeroCsi);
        }
        let rssi_pwr = db_inv(self.total_rss_dbm());
        let scale = rssi_pwr / (csi_pwr / NUM_SUBCARRIERS as f64);
        let noise_db = if self.header.noise_dbm == NOISE_UNKNOWN_DBM {
            DEFAULT_NOISE_DBM
        } else {
            f64::from(self.header.noise_dbm)
        };
        let thermal_noise_pwr = db_inv(noise_db);
        let quant_error_pwr = scale * f64::from(self.header.nrx) * f64::from(self.header.ntx);
        let total_noise_pwr = thermal_noise_pwr + quant_error_pwr;
        let mut factor = (scale / total_noise_pwr).sqrt();
        match self.header.ntx {
            2 => factor *= std::f64::consts::SQRT_2,
            3 => factor *= db_inv(4.5).sqrt(),
            _ => {}
        }
        Ok(factor)
    }
}

/// Why CSI does not fit a header.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Error)]
pub enum ShapeError {
    /// Chain counts outside 1–3.
    #[error("nrx = {nrx}, ntx = {ntx}: the Intel 5300 reports 1 to 3 of each")]
    Chains {
        /// Receive chains.
        nrx: u8,
        /// Transmit streams.
        ntx: u8,
    },
    /// The CSI slice does not have `ntx · nrx · 30` entries.
    #[error("CSI has {got} entries, the header needs {expected}")]
    Entries {
        /// `ntx · nrx · 30`.
        expected: usize,
        /// Entries given.
        got: usize,
    },
}

/// `dbinv.m`: 10^(x/10).
fn db_inv(x: f64) -> f64 {
    10f64.powf(x / 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(nrx: u8, ntx: u8, sel: u8) -> BfeeHeader {
        BfeeHeader {
            nrx,
            ntx,
            antenna_sel: sel,
            rssi: [30, 0, 20],
            agc: 40,
            noise_dbm: NOISE_UNKNOWN_DBM,
            ..BfeeHeader::default()
        }
    }

    #[test]
    fn perm_validity() {
        // sel = 0b10_01_00 -> (0, 1, 2).
        assert_eq!(header(3, 1, 0b10_01_00).perm(), Perm::Applied([0, 1, 2]));
        assert_eq!(header(3, 1, 0b00_01_10).perm(), Perm::Applied([2, 1, 0]));
        // (1, 1, 1) sums to 3, not a permutation of 3 chains.
        assert_eq!(header(3, 1, 0b01_01_01).perm(), Perm::Invalid([1, 1, 1]));
        // (2, 2, 2) would pass MATLAB's sum test (6); it is not a permutation.
        assert_eq!(header(3, 1, 0b10_10_10).perm(), Perm::Invalid([2, 2, 2]));
        // Two chains wired to antennas 1 and 0.
        assert_eq!(header(2, 1, 0b00_01).perm(), Perm::Applied([1, 0, 0]));
        // Two chains, one of them on antenna 2 (outside 0..2): invalid.
        assert_eq!(header(2, 1, 0b10_00).perm(), Perm::Invalid([0, 2, 0]));
        assert_eq!(header(1, 1, 0xFF).perm(), Perm::SingleChain);
    }

    #[test]
    fn scaling_refuses_degenerate_records_and_follows_the_formula() {
        let h = header(1, 1, 0);
        let mut csi = vec![Complex::new(0i8, 0); 30];
        let r = CsiRecord::new(h, &csi, Timestamp(0)).expect("shape");
        assert_eq!(r.scaled_csi(), Err(ScaleError::ZeroCsi));
        csi[0] = Complex::new(3, 4);
        let r =
            CsiRecord::new(BfeeHeader { rssi: [0; 3], ..h }, &csi, Timestamp(0)).expect("shape");
        assert_eq!(r.scaled_csi(), Err(ScaleError::NoRssi));
        // One entry of power 25: scale = rssi_pwr · 30 / 25, quantization = scale.
        let r = CsiRecord::new(h, &csi, Timestamp(0)).expect("shape");
        let rss = 10.0 * (db_inv(30.0) + db_inv(20.0)).log10() - 44.0 - 40.0;
        assert!((r.total_rss_dbm() - rss).abs() < 1e-12);
        let scale = db_inv(rss) * 30.0 / 25.0;
        let k = (scale / (db_inv(-92.0) + scale)).sqrt();
        let s = r.scaled_csi().expect("scalable");
        assert!((s[0].re - 3.0 * k).abs() < 1e-12 && (s[0].im - 4.0 * k).abs() < 1e-12);
    }

    #[test]
    fn shape_errors() {
        let csi = vec![Complex::new(1i8, 1); 60];
        assert_eq!(
            CsiRecord::new(header(3, 1, 0), &csi, Timestamp(0)),
            Err(ShapeError::Entries {
                expected: 90,
                got: 60
            })
        );
        assert!(matches!(
            CsiRecord::new(header(4, 1, 0), &csi, Timestamp(0)),
            Err(ShapeError::Chains { nrx: 4, ntx: 1 })
        ));
        let r = CsiRecord::new(header(2, 1, 0b0100), &csi, Timestamp(0)).expect("shape");
        assert_eq!(r.csi_at(0, 1, 29), Some(Complex::new(1, 1)));
        assert_eq!(r.csi_at(1, 0, 0), None);
    }
}
