//! The CSI record payload: its 20-byte header and the bit-packed CSI that follows
//! (the CSI Tool's `read_bfee.c`), decoded and encoded.

use num_complex::Complex;

use super::layout::{ENTRY_BITS, HEADER_LEN, NRX_AT, NTX_AT, SUBCARRIER_PAD_BITS, packed_csi_len};
use super::rate::RateFlags;
use super::record::{BfeeHeader, MAX_ENTRIES};
use crate::csi::subcarriers::NUM_SUBCARRIERS;

/// Parses the header; `bytes` must hold at least [`HEADER_LEN`] bytes.
pub(crate) fn parse_header(bytes: &[u8; HEADER_LEN]) -> (BfeeHeader, u16) {
    let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
    let header = BfeeHeader {
        timestamp_low: u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        bfee_count: u16_at(4),
        nrx: bytes[NRX_AT],
        ntx: bytes[NTX_AT],
        rssi: [bytes[10], bytes[11], bytes[12]],
        noise_dbm: bytes[13] as i8,
        agc: bytes[14],
        antenna_sel: bytes[15],
        rate: RateFlags(u16_at(18)),
    };
    (header, u16_at(16))
}

/// Serializes the header; `len` is the packed CSI length. Bytes 6–7 (reserved) are written as 0.
pub(crate) fn write_header(header: &BfeeHeader, len: u16) -> [u8; HEADER_LEN] {
    let mut b = [0u8; HEADER_LEN];
    b[0..4].copy_from_slice(&header.timestamp_low.to_le_bytes());
    b[4..6].copy_from_slice(&header.bfee_count.to_le_bytes());
    b[NRX_AT] = header.nrx;
    b[NTX_AT] = header.ntx;
    b[10..13].copy_from_slice(&header.rssi);
    b[13] = header.noise_dbm as u8;
    b[14] = header.agc;
    b[15] = header.antenna_sel;
    b[16..18].copy_from_slice(&len.to_le_bytes());
    b[18..20].copy_from_slice(&header.rate.0.to_le_bytes());
    b
}

/// Where chain-order entry `j` of a subcarrier goes in the `[tx][rx][sc]` output: the CSI Tool
/// packs entries with tx fastest (`j = tx + ntx·chain`), and the permutation, when valid, moves
/// chain `k` to antenna `perm[k]`.
fn destinations(header: &BfeeHeader) -> ([usize; 9], usize) {
    let (nrx, ntx) = (usize::from(header.nrx), usize::from(header.ntx));
    let perm = match header.perm() {
        super::record::Perm::Applied(p) => Some(p),
        _ => None,
    };
    let mut dest = [0usize; 9];
    for (j, d) in dest.iter_mut().enumerate().take(nrx * ntx) {
        let (tx, chain) = (j % ntx, j / ntx);
        let rx = perm.map_or(chain, |p| usize::from(p[chain]));
        *d = (tx * nrx + rx) * NUM_SUBCARRIERS;
    }
    (dest, nrx * ntx)
}

/// Unpacks the CSI of a record whose header has been validated (chains 1–3, `packed` exactly
/// [`packed_csi_len`] bytes) into `[tx][rx][sc]` order after the permutation. `None` if `packed`
/// is too short, which validation rules out.
pub(crate) fn unpack_csi(header: &BfeeHeader, packed: &[u8]) -> Option<[Complex<i8>; MAX_ENTRIES]> {
    let (dest, n) = destinations(header);
    let stride = ENTRY_BITS * n + SUBCARRIER_PAD_BITS;
    let mut out = [Complex::new(0i8, 0); MAX_ENTRIES];
    for sc in 0..NUM_SUBCARRIERS {
        let mut bit = sc * stride + SUBCARRIER_PAD_BITS;
        for &d in &dest[..n] {
            let b = bit / 8;
            let w = packed.get(b..b + 3)?;
            let v = (u32::from(w[0]) | u32::from(w[1]) << 8 | u32::from(w[2]) << 16) >> (bit % 8);
            *out.get_mut(d + sc)? = Complex::new(v as u8 as i8, (v >> 8) as u8 as i8);
            bit += ENTRY_BITS;
        }
    }
    Some(out)
}

/// Packs CSI given in `[tx][rx][sc]` order after the permutation back into the firmware's bit
/// layout (inverse of [`unpack_csi`]); the 3 pad bits of each subcarrier are written as 0.
pub(crate) fn pack_csi(header: &BfeeHeader, csi: &[Complex<i8>]) -> Vec<u8> {
    let (dest, n) = destinations(header);
    let stride = ENTRY_BITS * n + SUBCARRIER_PAD_BITS;
    let mut packed = vec![0u8; packed_csi_len(header.nrx, header.ntx)];
    let mut put = |bit: usize, v: i8| {
        let (b, r) = (bit / 8, bit % 8);
        let v = u16::from(v as u8) << r;
        if let Some(x) = packed.get_mut(b) {
            *x |= v as u8;
        }
        if let Some(x) = packed.get_mut(b + 1) {
            *x |= (v >> 8) as u8;
        }
    };
    for sc in 0..NUM_SUBCARRIERS {
        let mut bit = sc * stride + SUBCARRIER_PAD_BITS;
        for &d in &dest[..n] {
            let c = csi.get(d + sc).copied().unwrap_or_default();
            put(bit, c.re);
            put(bit + 8, c.im);
            bit += ENTRY_BITS;
        }
    }
    packed
}

/// A literal port of the bit extraction in the CSI Tool's `read_bfee.c`, one byte pair at a time,
/// in chain order (entry `j` of subcarrier `sc` at `sc·nrx·ntx + j`). Kept as the oracle for the
/// fast path in tests and as the reference it is benchmarked against.
pub fn unpack_reference(nrx: u8, ntx: u8, payload: &[u8]) -> Option<Vec<Complex<i8>>> {
    let n = usize::from(nrx) * usize::from(ntx);
    let mut out = Vec::with_capacity(n * NUM_SUBCARRIERS);
    let mut index = 0usize;
    for _ in 0..NUM_SUBCARRIERS {
        index += 3;
        let remainder = index % 8;
        for _ in 0..n {
            let byte = |k: usize| payload.get(index / 8 + k).map(|&b| u32::from(b));
            let re = (byte(0)? >> remainder) | (byte(1)? << (8 - remainder));
            let im = (byte(1)? >> remainder) | (byte(2)? << (8 - remainder));
            out.push(Complex::new(re as u8 as i8, im as u8 as i8));
            index += 16;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csi::intel5300::layout::packed_csi_len;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_0001),
            ..ProptestConfig::default()
        })]

        #[test]
        fn fast_unpack_equals_the_literal_port(
            nrx in 1..=3u8, ntx in 1..=3u8, sel in any::<u8>(),
            bytes in proptest::collection::vec(any::<u8>(), 552),
        ) {
            let header = BfeeHeader { nrx, ntx, antenna_sel: sel, ..BfeeHeader::default() };
            let packed = &bytes[..packed_csi_len(nrx, ntx)];
            let fast = unpack_csi(&header, packed).expect("validated length");
            let slow = unpack_reference(nrx, ntx, packed).expect("validated length");
            let (dest, n) = destinations(&header);
            for sc in 0..NUM_SUBCARRIERS {
                for j in 0..n {
                    prop_assert_eq!(fast[dest[j] + sc], slow[sc * n + j]);
                }
            }
        }

        #[test]
        fn pack_inverts_unpack(
            nrx in 1..=3u8, ntx in 1..=3u8, sel in any::<u8>(),
            values in proptest::collection::vec(any::<(i8, i8)>(), 270),
        ) {
            let header = BfeeHeader { nrx, ntx, antenna_sel: sel, ..BfeeHeader::default() };
            let csi: Vec<Complex<i8>> = values[..header.num_entries()]
                .iter().map(|&(re, im)| Complex::new(re, im)).collect();
            let packed = pack_csi(&header, &csi);
            let back = unpack_csi(&header, &packed).expect("packed length");
            prop_assert_eq!(&back[..csi.len()], &csi[..]);
        }

        #[test]
        fn header_round_trip(bytes in proptest::array::uniform20(any::<u8>())) {
            let (h, len) = parse_header(&bytes);
            let mut expected = bytes;
            expected[6] = 0;
            expected[7] = 0;
            prop_assert_eq!(write_header(&h, len), expected);
        }
    }
}
