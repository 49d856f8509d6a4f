//! Byte layout of the CSI Tool's records, in one place: framing, CSI header, packed CSI.

use crate::csi::subcarriers::NUM_SUBCARRIERS;

/// Record code of CSI ("beamforming feedback") records.
pub const CODE_CSI: u8 = 0xBB;
/// Record code of frame records (MAC header + payload, logged in monitor mode).
pub const CODE_FRAME: u8 = 0xC1;
/// Bytes of the big-endian length field in front of every record.
pub const LEN_FIELD: usize = 2;
/// Bytes of the little-endian header in front of the packed CSI.
pub const HEADER_LEN: usize = 20;
/// Bytes from the start of a CSI record to its packed CSI: length, code, header.
pub const CSI_PREFIX: usize = LEN_FIELD + 1 + HEADER_LEN;
/// Header byte holding `nrx`.
pub(crate) const NRX_AT: usize = 8;
/// Header byte holding `ntx`.
pub(crate) const NTX_AT: usize = 9;
/// Bits the firmware leaves in front of each subcarrier's entries.
pub(crate) const SUBCARRIER_PAD_BITS: usize = 3;
/// Bits per complex entry: signed 8-bit real, then signed 8-bit imaginary.
pub(crate) const ENTRY_BITS: usize = 16;

/// Bytes of packed CSI for `nrx · ntx` entries per subcarrier: ⌈30·(16·nrx·ntx + 3) / 8⌉,
/// which is 60·nrx·ntx + 12 (`calc_len` in `read_bfee.c`).
pub const fn packed_csi_len(nrx: u8, ntx: u8) -> usize {
    let n = nrx as usize * ntx as usize;
    (NUM_SUBCARRIERS * (ENTRY_BITS * n + SUBCARRIER_PAD_BITS)).div_ceil(8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_length_matches_the_design_formula() {
        for nrx in 1..=3u8 {
            for ntx in 1..=3u8 {
                let n = usize::from(nrx) * usize::from(ntx);
                assert_eq!(packed_csi_len(nrx, ntx), 60 * n + 12);
            }
        }
        assert_eq!(CSI_PREFIX, 23);
    }
}
