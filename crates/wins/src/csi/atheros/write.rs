//! Writing Atheros CSI Tool records, as the tool's `record_csi` writes them ([`encode_record`]):
//! the inverse of the reader, used by the simulator's Atheros rig.

use super::{ATHEROS_HEADER_LEN, AtherosRecord, BITS_PER_VALUE, ByteOrder};

/// Why a record cannot be written.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum WriteError {
    /// The CSI does not hold `num_tones × nr × nc` values.
    #[error("{got} CSI values for {tones} tones × {nr} × {nc} chains")]
    Shape {
        /// Values given.
        got: usize,
        /// Tones.
        tones: u8,
        /// Receive chains.
        nr: u8,
        /// Transmit chains.
        nc: u8,
    },
    /// A part outside the 10-bit range, or a record longer than its `u16` block length holds.
    #[error("{0}")]
    Range(String),
}

/// Appends `r` to `out` in the byte order `order` (its `offset` and `csi_len` are not used: the
/// CSI length is the packed values').
pub fn encode_record(
    r: &AtherosRecord,
    order: ByteOrder,
    out: &mut Vec<u8>,
) -> Result<(), WriteError> {
    let values = usize::from(r.num_tones) * usize::from(r.nr) * usize::from(r.nc);
    if r.csi.len() != values {
        return Err(WriteError::Shape {
            got: r.csi.len(),
            tones: r.num_tones,
            nr: r.nr,
            nc: r.nc,
        });
    }
    let limit = 1i16 << (BITS_PER_VALUE - 1);
    if let Some(v) = r
        .csi
        .iter()
        .find(|v| !(-limit..limit).contains(&v.re) || !(-limit..limit).contains(&v.im))
    {
        return Err(WriteError::Range(format!(
            "CSI value {v} outside the 10-bit range [{}, {}]",
            -limit,
            limit - 1
        )));
    }
    let csi_len = (values * 2 * BITS_PER_VALUE).div_ceil(8);
    let block_len = ATHEROS_HEADER_LEN - 2 + csi_len + r.payload.len();
    let block_len = u16::try_from(block_len)
        .map_err(|_| WriteError::Range(format!("a record of {block_len} bytes")))?;
    let payload_len = r.payload.len() as u16;
    let put = |out: &mut Vec<u8>, v: u64, len: usize| {
        let le = v.to_le_bytes();
        match order {
            ByteOrder::Little => out.extend(&le[..len]),
            ByteOrder::Big => out.extend(le[..len].iter().rev()),
        }
    };
    put(out, u64::from(block_len), 2);
    put(out, r.timestamp_us, 8);
    put(out, csi_len as u64, 2);
    put(out, u64::from(r.channel_mhz), 2);
    out.extend([
        r.err_info,
        r.noise_floor,
        r.rate,
        r.bandwidth,
        r.num_tones,
        r.nr,
        r.nc,
        r.rssi,
        r.rssi_chains[0],
        r.rssi_chains[1],
        r.rssi_chains[2],
    ]);
    put(out, u64::from(payload_len), 2);
    let start = out.len();
    out.resize(start + csi_len, 0);
    let packed = &mut out[start..];
    // Each value: its imaginary part, then its real, 10 bits each, least significant bit first.
    let parts = r.csi.iter().flat_map(|v| [v.im, v.re]);
    for (index, part) in parts.enumerate() {
        let bits = (part as u16) & ((1 << BITS_PER_VALUE) - 1);
        for bit in 0..BITS_PER_VALUE {
            if bits >> bit & 1 == 1 {
                let at = index * BITS_PER_VALUE + bit;
                packed[at / 8] |= 1 << (at % 8);
            }
        }
    }
    out.extend(&r.payload);
    Ok(())
}

#[cfg(test)]
mod tests {
    use num_complex::Complex;

    use super::super::parse_atheros;
    use super::*;

    fn record(nr: u8, tones: u8, seed: i16) -> AtherosRecord {
        let csi = (0..i16::from(tones) * i16::from(nr))
            .map(|i| Complex::new((i * 37 + seed) % 1024 - 512, (i * 91 - seed) % 1024 - 511))
            .map(|v: Complex<i16>| Complex::new(v.re.clamp(-512, 511), v.im.clamp(-512, 511)))
            .collect::<Vec<_>>();
        AtherosRecord {
            offset: 0,
            timestamp_us: 987_654_321,
            channel_mhz: 5320,
            err_info: 0,
            noise_floor: 0,
            rate: 0x80,
            bandwidth: 0,
            num_tones: tones,
            nr,
            nc: 1,
            rssi: 40,
            rssi_chains: [38, 39, 40],
            csi_len: 0,
            csi,
            payload: vec![0x08, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
        }
    }

    #[test]
    fn written_records_read_back_equal_in_either_byte_order() {
        for order in [ByteOrder::Little, ByteOrder::Big] {
            let records = [record(3, 56, 5), record(2, 114, -7)];
            let mut bytes = Vec::new();
            for r in &records {
                encode_record(r, order, &mut bytes).unwrap();
            }
            let read = parse_atheros(&bytes, Some(order));
            assert_eq!(read.records.len(), 2);
            assert_eq!(read.lost(), None);
            for (a, b) in read.records.iter().zip(&records) {
                assert_eq!(a.csi, b.csi);
                assert_eq!(
                    (a.timestamp_us, a.channel_mhz),
                    (b.timestamp_us, b.channel_mhz)
                );
                assert_eq!(
                    (a.nr, a.num_tones, a.rssi_chains),
                    (b.nr, b.num_tones, b.rssi_chains)
                );
                assert_eq!(a.payload, b.payload);
            }
        }
    }

    #[test]
    fn a_value_out_of_range_or_a_wrong_shape_is_refused() {
        let mut r = record(3, 56, 1);
        r.csi[3].re = 512;
        assert!(matches!(
            encode_record(&r, ByteOrder::Little, &mut Vec::new()),
            Err(WriteError::Range(_))
        ));
        r.csi.pop();
        assert!(matches!(
            encode_record(&r, ByteOrder::Little, &mut Vec::new()),
            Err(WriteError::Shape { .. })
        ));
    }
}
