//! The FeitCSI reader on the real AX200/AX210 files in `../shared/data/feitcsi/`, field by field
//! against CSIKit 2.5 (`interpolate=False`, its rate-flag bits corrected as the folder's README
//! says), and damaged copies read without a panic with every byte accounted for.

use serde::Deserialize;
use wins::csi::feitcsi::{FEIT_HEADER_LEN, FeitCapture, parse_feitcsi, read_feitcsi};

use super::data::{flipped_copies, shared_data};

/// One line of a `*.csikit_ref.jsonl`; `csi` is [subcarrier][rx][tx] of [re, im].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Row {
    index: usize,
    csi_size: u32,
    ftm_clock: u32,
    num_rx: u8,
    num_tx: u8,
    num_subcarriers: u32,
    rssi1: u32,
    rssi2: u32,
    source_mac: String,
    mu_clock: u32,
    rate_flags: u32,
    rate_format: String,
    channel_width_mhz: u32,
    mcs: u8,
    antenna_a: bool,
    antenna_b: bool,
    ldpc: bool,
    spatial_streams: u8,
    beamforming: bool,
    #[allow(dead_code)]
    csikit_timestamp_s: f64,
    csi: Vec<Vec<Vec<[i16; 2]>>>,
}

#[test]
fn every_record_equals_csikit_field_by_field() {
    let Some(shared) = shared_data() else { return };
    for (name, records) in [("csikit_HT20_2452", 48), ("csikit_HESU80_5500", 28)] {
        let dir = shared.join("feitcsi");
        let capture = read_feitcsi(&dir.join(format!("{name}.csi"))).unwrap();
        assert!(capture.tail.is_none(), "{name}: {:?}", capture.tail);
        let text = std::fs::read_to_string(dir.join(format!("{name}.csikit_ref.jsonl"))).unwrap();
        let refs: Vec<Row> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(
            (capture.records.len(), refs.len()),
            (records, records),
            "{name}"
        );
        for (rec, x) in capture.records.iter().zip(&refs) {
            let r = &rec.header;
            let at = format!("{name} record {}", x.index);
            let values = u32::from(r.num_rx) * u32::from(r.num_tx) * r.num_subcarriers;
            assert_eq!(values * 4, x.csi_size, "{at}");
            assert_eq!(
                (r.ftm_clock, r.mu_clock, r.rate_flags),
                (x.ftm_clock, x.mu_clock, x.rate_flags),
                "{at}"
            );
            assert_eq!(
                (r.num_rx, r.num_tx, r.num_subcarriers),
                (x.num_rx, x.num_tx, x.num_subcarriers),
                "{at}"
            );
            assert_eq!(r.rssi, [x.rssi1, x.rssi2], "{at}");
            let mac: Vec<String> = r.source_mac.iter().map(|b| format!("{b:02x}")).collect();
            assert_eq!(mac.join(":"), x.source_mac, "{at}");
            assert_eq!(
                (r.format().name(), r.width_mhz(), r.mcs()),
                (x.rate_format.as_str(), x.channel_width_mhz, x.mcs),
                "{at}"
            );
            assert_eq!(r.antennas(), (x.antenna_a, x.antenna_b), "{at}");
            assert_eq!(
                (r.ldpc(), r.spatial_streams(), r.beamforming()),
                (x.ldpc, x.spatial_streams, x.beamforming),
                "{at}"
            );
            for (sc, per_rx) in x.csi.iter().enumerate() {
                for (rx, per_tx) in per_rx.iter().enumerate() {
                    for (tx, &[re, im]) in per_tx.iter().enumerate() {
                        let ours = rec.csi_at(rx, tx, sc).unwrap();
                        assert_eq!((ours.re, ours.im), (re, im), "{at} sc {sc} rx {rx} tx {tx}");
                    }
                }
            }
        }
    }
}

/// Every byte of `c` (of `len` bytes) is in a record or the tail.
fn accounted(c: &FeitCapture, len: usize) -> bool {
    let records: u64 = c
        .records
        .iter()
        .map(|r| (FEIT_HEADER_LEN + r.csi.len() * 4) as u64)
        .sum();
    records + c.tail.as_ref().map_or(0, |t| t.1) == len as u64
}

#[test]
fn damaged_copies_are_read_without_a_panic_and_every_byte_is_accounted_for() {
    let Some(shared) = shared_data() else { return };
    let bytes = std::fs::read(shared.join("feitcsi/csikit_HT20_2452.csi")).unwrap();
    let whole = parse_feitcsi(&bytes);
    assert!(accounted(&whole, bytes.len()) && whole.tail.is_none());
    for cut in [1, 271, 272, 700, bytes.len() - 1] {
        let c = parse_feitcsi(&bytes[..cut]);
        assert!(accounted(&c, cut), "cut at {cut}");
        assert!(
            c.tail.as_ref().is_some_and(|t| t.2.contains("cut")),
            "cut at {cut}: {:?}",
            c.tail
        );
    }
    for copy in flipped_copies(&bytes, 0x2545_f491_4f6c_dd1du64, 300, 8, 0) {
        let c = parse_feitcsi(&copy);
        assert!(accounted(&c, copy.len()));
    }
    // Not FeitCSI at all: nothing read, every byte in the tail, and why.
    let text = parse_feitcsi(&[b'x'; 600]);
    assert!(text.records.is_empty());
    assert!(
        text.tail
            .as_ref()
            .is_some_and(|t| t.1 == 600 && t.2.contains("not a FeitCSI header"))
    );
}
