//! The Atheros CSI Tool reader on the real log in `../shared/data/atheros/`, field by field
//! against csiread 1.4.1 (its CSI re-laid out to the vendor's order, as the folder's README
//! says), the same log with its fields byte-swapped (a big-endian host's log) read the same, and
//! damaged copies read without a panic with every byte accounted for.

use serde::Deserialize;
use wins::csi::atheros::{ATHEROS_HEADER_LEN, ByteOrder, parse_atheros, read_atheros};

use super::data::{flipped_copies, shared_data};

/// One line of the `*.csiread_ref.jsonl`; `csi` is [tone][rx][tx] of [re, im].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Row {
    index: usize,
    block_len: usize,
    timestamp: u64,
    csi_len: u16,
    channel: u16,
    err_info: u8,
    noise_floor: u8,
    rate: u8,
    bandwidth: u8,
    num_tones: u8,
    nr: u8,
    nc: u8,
    rssi: u8,
    rssi1: u8,
    rssi2: u8,
    rssi3: u8,
    payload_len: usize,
    payload_frame_control: u16,
    payload_addr1: String,
    payload_addr2: String,
    payload_addr3: String,
    payload_seq_ctl: u16,
    csi: Vec<Vec<Vec<[i16; 2]>>>,
}

fn mac(b: &[u8]) -> String {
    let parts: Vec<String> = b.iter().map(|x| format!("{x:02x}")).collect();
    parts.join(":")
}

const LOG: &str = "atheros/csiread_ath_csi_1";

#[test]
fn every_record_equals_csiread_field_by_field() {
    let Some(shared) = shared_data() else { return };
    let capture = read_atheros(&shared.join(format!("{LOG}.dat")), None).unwrap();
    assert_eq!(
        (capture.order, capture.leading_byte, capture.tail.clone()),
        (ByteOrder::Little, false, None)
    );
    let text = std::fs::read_to_string(shared.join(format!("{LOG}.csiread_ref.jsonl"))).unwrap();
    let refs: Vec<Row> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!((capture.records.len(), refs.len()), (401, 401));
    for (r, x) in capture.records.iter().zip(&refs) {
        let at = format!("record {}", x.index);
        assert_eq!(r.bytes_in_file(), x.block_len + 2, "{at}");
        assert_eq!(
            (r.timestamp_us, r.csi_len, r.channel_mhz),
            (x.timestamp, x.csi_len, x.channel),
            "{at}"
        );
        assert_eq!(
            [
                r.err_info,
                r.noise_floor,
                r.rate,
                r.bandwidth,
                r.num_tones,
                r.nr,
                r.nc
            ],
            [
                x.err_info,
                x.noise_floor,
                x.rate,
                x.bandwidth,
                x.num_tones,
                x.nr,
                x.nc
            ],
            "{at}"
        );
        assert_eq!(
            (r.rssi, r.rssi_chains),
            (x.rssi, [x.rssi1, x.rssi2, x.rssi3]),
            "{at}"
        );
        let p = &r.payload;
        assert_eq!(p.len(), x.payload_len, "{at}");
        assert_eq!(u16::from_le_bytes([p[0], p[1]]), x.payload_frame_control);
        assert_eq!(
            (mac(&p[4..10]), mac(&p[10..16]), mac(&p[16..22])),
            (
                x.payload_addr1.clone(),
                x.payload_addr2.clone(),
                x.payload_addr3.clone()
            ),
            "{at}"
        );
        assert_eq!(
            r.transmitter().map(|m| mac(&m)),
            Some(x.payload_addr2.clone())
        );
        assert_eq!(
            u16::from_le_bytes([p[22], p[23]]),
            x.payload_seq_ctl,
            "{at}"
        );
        assert_eq!(x.csi.len(), usize::from(r.num_tones), "{at}");
        for (tone, per_rx) in x.csi.iter().enumerate() {
            for (rx, per_tx) in per_rx.iter().enumerate() {
                for (tx, &[re, im]) in per_tx.iter().enumerate() {
                    let ours = r.csi_at(rx, tx, tone).unwrap();
                    assert_eq!(
                        (ours.re, ours.im),
                        (re, im),
                        "{at} tone {tone} rx {rx} tx {tx}"
                    );
                }
            }
        }
    }
}

/// The log with each record's multi-byte header fields byte-swapped, as a big-endian host
/// writes it (the CSI and the payload are the card's bytes and stay as they are).
fn big_endian_copy(bytes: &[u8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    let mut at = 0;
    while at + ATHEROS_HEADER_LEN <= out.len() {
        let block = usize::from(u16::from_le_bytes([out[at], out[at + 1]]));
        for (field, len) in [(0, 2), (2, 8), (10, 2), (12, 2), (25, 2)] {
            out[at + field..at + field + len].reverse();
        }
        at += 2 + block;
    }
    out
}

#[test]
fn a_big_endian_hosts_log_reads_the_same() {
    let Some(shared) = shared_data() else { return };
    let bytes = std::fs::read(shared.join(format!("{LOG}.dat"))).unwrap();
    let little = parse_atheros(&bytes, None);
    let mut flagged = vec![0xff];
    flagged.extend(big_endian_copy(&bytes));
    for (copy, lead) in [(big_endian_copy(&bytes), false), (flagged, true)] {
        let big = parse_atheros(&copy, None);
        assert_eq!((big.order, big.leading_byte), (ByteOrder::Big, lead));
        assert_eq!(big.tail, None);
        assert_eq!(big.records.len(), little.records.len());
        for (b, l) in big.records.iter().zip(&little.records) {
            assert_eq!(b.offset, l.offset + u64::from(lead));
            assert_eq!(
                (b.timestamp_us, b.channel_mhz, &b.csi, &b.payload),
                (l.timestamp_us, l.channel_mhz, &l.csi, &l.payload)
            );
        }
        // Forced to the wrong order, the first record does not agree: nothing is read, and
        // every byte is in the tail with the reason.
        let wrong = parse_atheros(&copy, Some(ByteOrder::Little));
        assert!(wrong.records.is_empty());
        assert_eq!(wrong.bytes_accounted(), copy.len() as u64);
    }
}

#[test]
fn damaged_copies_are_read_without_a_panic_and_every_byte_is_accounted_for() {
    let Some(shared) = shared_data() else { return };
    let bytes = std::fs::read(shared.join(format!("{LOG}.dat"))).unwrap();
    for cut in [1, 26, 27, 1000, 1908, bytes.len() - 1] {
        let c = parse_atheros(&bytes[..cut], None);
        assert_eq!(c.bytes_accounted(), cut as u64, "cut at {cut}");
        assert!(
            c.tail.as_ref().is_some_and(|t| t.2.contains("cut")),
            "cut at {cut}: {:?}",
            c.tail
        );
    }
    for copy in flipped_copies(&bytes, 0x9e37_79b9_7f4a_7c15u64, 300, 8, 0) {
        let c = parse_atheros(&copy, None);
        assert_eq!(c.bytes_accounted(), copy.len() as u64);
    }
}
