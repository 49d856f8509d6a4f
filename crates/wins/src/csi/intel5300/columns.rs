//! A log's records as columns, shaped as csiread's `Intel` reader gives them (what Python's
//! `wins.read_csi` hands to numpy): one value per record for each header field, and the raw CSI
//! of every record in a `count × 30 × nrx × ntx` block after the antenna permutation, zero
//! where a record has fewer chains or streams than the block.

use super::record::CsiRecord;
use crate::csi::subcarriers::NUM_SUBCARRIERS;

/// Columns of CSI records (module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CsiColumns {
    /// Receive chains of the CSI block.
    pub nrx: usize,
    /// Transmit streams of the CSI block.
    pub ntx: usize,
    /// Byte offset of each record in the log.
    pub offset: Vec<u64>,
    /// `timestamp_low`, NIC µs (wraps every ~71.6 min).
    pub timestamp_low: Vec<u32>,
    /// The NIC time unwrapped across `timestamp_low`'s wraps, ns.
    pub timestamp_ns: Vec<i64>,
    /// `bfee_count`.
    pub bfee_count: Vec<i64>,
    /// Receive chains of each record (csiread's `Nrx`).
    pub nrx_of: Vec<i64>,
    /// Transmit streams of each record (csiread's `Ntx`).
    pub ntx_of: Vec<i64>,
    /// RSSI of chains A, B, C, dB relative to the AGC.
    pub rssi: [Vec<i64>; 3],
    /// Noise floor, dBm (−127: unknown).
    pub noise: Vec<i64>,
    /// AGC, dB.
    pub agc: Vec<i64>,
    /// The antenna of each chain, 0-based, three per record.
    pub perm: Vec<[i64; 3]>,
    /// `rate_n_flags`' low 16 bits.
    pub rate: Vec<i64>,
    /// The raw CSI: real and imaginary part of each entry, record by record, then subcarrier,
    /// receive antenna and transmit stream (`count × 30 × nrx × ntx × 2` values).
    pub csi_re_im: Vec<i8>,
}

impl CsiColumns {
    /// Empty columns with a CSI block of `nrx` chains and `ntx` streams (each 1–3).
    pub fn new(nrx: usize, ntx: usize) -> Self {
        Self {
            nrx,
            ntx,
            ..Self::default()
        }
    }

    /// Records so far.
    pub fn count(&self) -> usize {
        self.offset.len()
    }

    /// Appends `record`; its chains and streams beyond the block's are left out.
    pub fn push(&mut self, record: &CsiRecord) {
        let h = &record.header;
        self.offset.push(record.offset);
        self.timestamp_low.push(h.timestamp_low);
        self.timestamp_ns.push(record.timestamp.0);
        self.bfee_count.push(i64::from(h.bfee_count));
        self.nrx_of.push(i64::from(h.nrx));
        self.ntx_of.push(i64::from(h.ntx));
        for (column, rssi) in self.rssi.iter_mut().zip(h.rssi) {
            column.push(i64::from(rssi));
        }
        self.noise.push(i64::from(h.noise_dbm));
        self.agc.push(i64::from(h.agc));
        self.perm.push(h.raw_perm().map(i64::from));
        self.rate.push(i64::from(h.rate.0));
        let start = self.csi_re_im.len();
        self.csi_re_im
            .resize(start + NUM_SUBCARRIERS * self.nrx * self.ntx * 2, 0);
        let block = &mut self.csi_re_im[start..];
        // The record's CSI is [tx][rx][subcarrier]; the block's [subcarrier][rx][tx].
        let nrx = usize::from(h.nrx);
        let per_stream = record.csi().chunks(nrx * NUM_SUBCARRIERS).take(self.ntx);
        for (tx, stream) in per_stream.enumerate() {
            for (rx, chain) in stream.chunks(NUM_SUBCARRIERS).take(self.nrx).enumerate() {
                for (sc, c) in chain.iter().enumerate() {
                    let at = ((sc * self.nrx + rx) * self.ntx + tx) * 2;
                    block[at] = c.re;
                    block[at + 1] = c.im;
                }
            }
        }
    }

    /// The most streams a record pushed so far has (0 with none).
    pub fn most_streams(&self) -> usize {
        self.ntx_of.iter().copied().max().map_or(0, |n| n as usize)
    }

    /// The same columns with a CSI block of `ntx` streams (fewer than the block's: the others
    /// are left out).
    pub fn keep_streams(&mut self, ntx: usize) {
        if ntx >= self.ntx {
            return;
        }
        let (old, rows) = (self.ntx, self.count() * NUM_SUBCARRIERS * self.nrx);
        for row in 0..rows {
            for tx in 0..ntx {
                let (from, to) = ((row * old + tx) * 2, (row * ntx + tx) * 2);
                self.csi_re_im.copy_within(from..from + 2, to);
            }
        }
        self.csi_re_im.truncate(rows * ntx * 2);
        self.ntx = ntx;
    }
}

#[cfg(test)]
mod tests {
    use num_complex::Complex;

    use super::*;
    use crate::csi::intel5300::{BfeeHeader, RateFlags};
    use crate::time::Timestamp;

    #[test]
    fn each_entry_lands_at_its_subcarrier_antenna_and_stream() {
        let header = BfeeHeader {
            nrx: 2,
            ntx: 2,
            rssi: [30, 31, 0],
            noise_dbm: -90,
            agc: 40,
            // Chain 0 on antenna 1, chain 1 on antenna 0.
            antenna_sel: 0b0001,
            rate: RateFlags(0x4101),
            bfee_count: 7,
            timestamp_low: 123,
        };
        // Entry k in [tx][rx][subcarrier] order (after the permutation) carries k.
        let csi: Vec<Complex<i8>> = (0..header.num_entries())
            .map(|k| Complex::new((k % 128) as i8, -((k / 128) as i8)))
            .collect();
        let record = CsiRecord::new(header, &csi, Timestamp(5)).expect("a record");
        let mut columns = CsiColumns::new(3, 3);
        columns.push(&record);
        columns.push(&record);
        assert_eq!(columns.count(), 2);
        assert_eq!(columns.csi_re_im.len(), 2 * 30 * 3 * 3 * 2);
        for sc in 0..30 {
            for rx in 0..3 {
                for tx in 0..3 {
                    let at = ((30 * 3 * 3) + (sc * 3 + rx) * 3 + tx) * 2;
                    let got = Complex::new(columns.csi_re_im[at], columns.csi_re_im[at + 1]);
                    let want = record.csi_at(tx, rx, sc).unwrap_or_default();
                    assert_eq!(got, want, "sc {sc} rx {rx} tx {tx}");
                }
            }
        }
        assert_eq!(columns.perm[0], [1, 0, 0]);
        assert_eq!((columns.bfee_count[1], columns.timestamp_low[0]), (7, 123));
        assert_eq!(
            (columns.nrx_of[0], columns.ntx_of[0], columns.rate[0]),
            (2, 2, 0x4101)
        );
        assert_eq!(
            [columns.rssi[0][0], columns.rssi[1][0], columns.rssi[2][0]],
            [30, 31, 0]
        );
        assert_eq!(
            (columns.noise[0], columns.agc[0], columns.timestamp_ns[0]),
            (-90, 40, 5)
        );
        // A block smaller than the record leaves its extra stream out, made so or narrowed.
        let mut small = CsiColumns::new(2, 1);
        small.push(&record);
        let mut narrowed = CsiColumns::new(2, 3);
        narrowed.push(&record);
        assert_eq!(narrowed.most_streams(), 2);
        narrowed.keep_streams(1);
        assert_eq!(narrowed, small);
        assert_eq!(small.csi_re_im.len(), 30 * 2 * 2);
        let at = (5 * 2 + 1) * 2;
        let want = record.csi_at(0, 1, 5).unwrap_or_default();
        assert_eq!(
            (small.csi_re_im[at], small.csi_re_im[at + 1]),
            (want.re, want.im)
        );
    }
}
