//! Writing Nexmon captures as `tcpdump -i eth0 dst port 5500 -w` keeps them: a little-endian
//! microsecond pcap of Ethernet/IPv4/UDP frames to port 5500, each payload the newer 18-byte
//! header (magic 0x1111, RSSI, frame control) and one 32-bit word per FFT bin in the chip's
//! floating point ([`encode_word`], the inverse of [`super::unpack::exact`]). The inverse of the
//! reader, used by the simulator's RT-AC86U rig.

use num_complex::Complex64;

use super::{MAGIC_NEW, NEXMON_PORT, NexmonPacket};

/// pcap's magic for microsecond time stamps.
const PCAP_MAGIC_US: u32 = 0xa1b2_c3d4;
/// pcap's link type of Ethernet.
const LINKTYPE_ETHERNET: u32 = 1;
/// Bits of a part's magnitude.
const MANTISSA_BITS: i32 = 11;
/// The exact reading's exponent offset (the chip's fixed point, [`super::unpack::exact`]).
const EXACT_SHIFT: i32 = 42;
/// The exponent field's range.
const EXPONENT_RANGE: (i32, i32) = (-32, 31);

/// The pcap global header.
pub fn pcap_header(out: &mut Vec<u8>) {
    out.extend(PCAP_MAGIC_US.to_le_bytes());
    out.extend(2u16.to_le_bytes());
    out.extend(4u16.to_le_bytes());
    out.extend(0i32.to_le_bytes());
    out.extend(0u32.to_le_bytes());
    out.extend(65_535u32.to_le_bytes());
    out.extend(LINKTYPE_ETHERNET.to_le_bytes());
}

/// One word holding `v` as the chip's floating point: the smallest shared exponent whose
/// magnitudes fit 11 bits, each part rounded to it. Values beyond the format's range saturate; parts under its smallest
/// step (2¹⁰, the exponent at −32) round to zero.
pub fn encode_word(v: Complex64) -> u32 {
    let largest = v.re.abs().max(v.im.abs());
    let max_mantissa = f64::from((1 << MANTISSA_BITS) - 1);
    let mut e = if largest > 0.0 && largest.is_finite() {
        (largest / max_mantissa).log2().ceil() as i32 - EXACT_SHIFT
    } else {
        EXPONENT_RANGE.0
    };
    e = e.clamp(EXPONENT_RANGE.0, EXPONENT_RANGE.1);
    let scale = 2f64.powi(e + EXACT_SHIFT);
    let part = |x: f64| -> (u32, bool) {
        let m = (x.abs() / scale).round().min(max_mantissa);
        (m as u32, x < 0.0 && m > 0.0)
    };
    let (re, re_negative) = part(v.re);
    let (im, im_negative) = part(v.im);
    let mut w = e.rem_euclid(64) as u32;
    w |= im << 6;
    w |= re << 18;
    if re_negative {
        w |= 1 << 29;
    }
    if im_negative {
        w |= 1 << 17;
    }
    w
}

/// Appends `p`'s UDP payload: the newer header (magic 0x1111, RSSI, frame control, the
/// transmitter, `seq`, `csiconf`, `chanspec`, `chip`) and its words.
pub fn encode_payload(p: &NexmonPacket, out: &mut Vec<u8>) {
    out.extend(MAGIC_NEW.to_le_bytes());
    out.extend(p.rssi_dbm.unwrap_or(0).to_le_bytes());
    out.push(p.frame_control.unwrap_or(0x08));
    out.extend(p.transmitter);
    out.extend(p.seq.to_le_bytes());
    out.extend(p.csiconf.to_le_bytes());
    out.extend(p.chanspec.to_le_bytes());
    out.extend(p.chip.to_le_bytes());
    for w in &p.words {
        out.extend(w.to_le_bytes());
    }
}

/// Appends `p` as one pcap record (its `ts_sec`, `ts_frac` in µs, transmitter, RSSI, frame
/// control, `seq`, `csiconf`, `chanspec`, `chip` and words; the rest is the frame's).
pub fn encode_packet(p: &NexmonPacket, out: &mut Vec<u8>) {
    let mut payload = Vec::with_capacity(18 + 4 * p.words.len());
    encode_payload(p, &mut payload);
    let udp_len = 8 + payload.len();

    let ip_len = 20 + udp_len;
    let mut frame = Vec::with_capacity(14 + ip_len);
    frame.extend([0xff; 6]);
    frame.extend(p.transmitter);
    frame.extend(0x0800u16.to_be_bytes());
    frame.extend([0x45, 0]);
    frame.extend((ip_len as u16).to_be_bytes());
    frame.extend([0, 0, 0x40, 0, 64, 17, 0, 0]);
    frame.extend([10, 10, 10, 10, 255, 255, 255, 255]);
    frame.extend(NEXMON_PORT.to_be_bytes());
    frame.extend(NEXMON_PORT.to_be_bytes());
    frame.extend((udp_len as u16).to_be_bytes());
    frame.extend([0, 0]);
    frame.extend(payload);
    out.extend(p.ts_sec.to_le_bytes());
    out.extend(p.ts_frac.to_le_bytes());
    out.extend((frame.len() as u32).to_le_bytes());
    out.extend((frame.len() as u32).to_le_bytes());
    out.extend(frame);
}

#[cfg(test)]
mod tests {
    use super::super::{parse_nexmon, unpack};
    use super::*;

    #[test]
    fn words_hold_values_to_the_eleven_bit_mantissa() {
        for v in [
            Complex64::new(3.0e7, -1.5e6),
            Complex64::new(-0.0, 12.5e6),
            Complex64::new(-2.0e9, 7.0e8),
            Complex64::new(0.0, 0.0),
        ] {
            let back = unpack::exact(&[encode_word(v)])[0];
            let tolerance = v.re.abs().max(v.im.abs()) / 2047.0;
            assert!((back - v).norm() <= tolerance, "{v} → {back}");
        }
        assert_eq!(
            unpack::exact(&[encode_word(Complex64::new(12.5, -3.0))])[0],
            Complex64::new(0.0, 0.0)
        );
    }

    #[test]
    fn written_packets_read_back_equal() {
        let packets: Vec<NexmonPacket> = (0..3u16)
            .map(|core| NexmonPacket {
                index: usize::from(core),
                offset: 0,
                ts_sec: 1_234,
                ts_frac: 567_890,
                time_ns: 0,
                caplen: 0,
                wirelen: 0,
                magic: u32::from(MAGIC_NEW),
                rssi_dbm: Some(-55 - core as i8),
                frame_control: Some(0x08),
                transmitter: [2, 0, 0, 0, 0, 1],
                seq: 77 << 4,
                csiconf: core << 8,
                chanspec: 0xd040,
                chip: 0x006a,
                words: (0..64)
                    .map(|k| encode_word(Complex64::new(f64::from(k) * 1e6, -1e6)))
                    .collect(),
            })
            .collect();
        let mut bytes = Vec::new();
        pcap_header(&mut bytes);
        for p in &packets {
            encode_packet(p, &mut bytes);
        }
        let read = parse_nexmon(&bytes).unwrap();
        assert_eq!(read.tail, None);
        assert_eq!(
            (read.other_records, read.bytes_accounted()),
            (0, read.bytes)
        );
        for (a, b) in read.packets.iter().zip(&packets) {
            assert_eq!(a.time_ns, 1_234_567_890_000);
            assert_eq!((a.core(), a.seq_num(), a.channel()), (b.core(), 77, 64));
            assert_eq!(
                (a.words.clone(), a.rssi_dbm, a.transmitter),
                (b.words.clone(), b.rssi_dbm, b.transmitter)
            );
        }
    }
}
