//! The PicoScenes reader on the real AX200 file in `../shared/data/picoscenes/`, field by field
//! against the folder's reference (CSIKit 2.5, and a walk of the vendor's layouts where CSIKit
//! does not expose a field); a segment version it does not know refused by name; damaged copies
//! read without a panic with every byte accounted for.

use std::collections::BTreeMap;

use serde::Deserialize;
use serde_json::Value;
use wins::csi::picoscenes::{PicoCapture, parse_picoscenes, read_picoscenes};

use super::data::{flipped_copies, shared_data};

/// One line of the `*.csikit_ref.jsonl`; `csi` is [tone][rx][stream] of [re, im].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Row {
    index: usize,
    frame_version: u16,
    segments: Vec<(String, u16)>,
    rxs_basic: BTreeMap<String, i64>,
    csi_header: BTreeMap<String, i64>,
    mvm_extra: BTreeMap<String, Value>,
    mpdu: BTreeMap<String, Value>,
    #[allow(dead_code)]
    csikit_timestamp_s: f64,
    #[allow(dead_code)]
    csikit_source_mac: String,
    csi: Vec<Vec<Vec<[i16; 2]>>>,
}

const FILE: &str = "picoscenes/csikit_picoscenes_ax200_example";

fn mac(b: &[u8]) -> String {
    let parts: Vec<String> = b.iter().map(|x| format!("{x:02x}")).collect();
    parts.join(":")
}

#[test]
fn every_frame_equals_the_reference_field_by_field() {
    let Some(shared) = shared_data() else { return };
    let capture = read_picoscenes(&shared.join(format!("{FILE}.csi"))).unwrap();
    assert_eq!(capture.tail, None);
    let text = std::fs::read_to_string(shared.join(format!("{FILE}.csikit_ref.jsonl"))).unwrap();
    let refs: Vec<Row> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!((capture.frames.len(), refs.len()), (885, 885));
    for (f, x) in capture.frames.iter().zip(&refs) {
        let at = format!("frame {}", x.index);
        assert_eq!(
            (f.frame_version, &f.segments),
            (x.frame_version, &x.segments),
            "{at}"
        );
        let b = f.rxs_basic.as_ref().unwrap();
        let basic = [
            ("deviceType", i64::from(b.device_type)),
            ("tstamp", b.tstamp as i64),
            ("centerFreq", i64::from(b.center_freq_mhz)),
            ("controlFreq", i64::from(b.control_freq_mhz)),
            ("cbw", i64::from(b.cbw_mhz)),
            ("packetFormat", i64::from(b.packet_format)),
            ("pkt_cbw", i64::from(b.pkt_cbw_mhz)),
            ("guardInterval", i64::from(b.guard_interval_ns)),
            ("mcs", i64::from(b.mcs)),
            ("numSTS", i64::from(b.num_sts)),
            ("numESS", i64::from(b.num_ess)),
            ("numRx", i64::from(b.num_rx)),
            ("numUser", i64::from(b.num_user)),
            ("userIndex", i64::from(b.user_index)),
            ("noiseFloor", i64::from(b.noise_floor)),
            ("rssi", i64::from(b.rssi)),
            ("rssi_ctl0", i64::from(b.rssi_chains[0])),
            ("rssi_ctl1", i64::from(b.rssi_chains[1])),
            ("rssi_ctl2", i64::from(b.rssi_chains[2])),
        ];
        assert_eq!(
            BTreeMap::from(basic.map(|(k, v)| (k.to_string(), v))),
            x.rxs_basic,
            "{at}"
        );
        let c = f.csi.as_ref().unwrap();
        let header = [
            ("deviceType", i64::from(c.device_type)),
            ("firmwareVersion", i64::from(c.firmware_version)),
            ("packetFormat", i64::from(c.packet_format)),
            ("cbw", i64::from(c.cbw_mhz)),
            ("carrierFreq", c.carrier_freq_hz as i64),
            ("samplingRate", c.sampling_rate_hz as i64),
            ("subcarrierBandwidth", i64::from(c.subcarrier_bandwidth_hz)),
            ("numTone", i64::from(c.num_tone)),
            ("numSTS", i64::from(c.num_sts)),
            ("numRx", i64::from(c.num_rx)),
            ("numESS", i64::from(c.num_ess)),
            ("numCSI", i64::from(c.num_csi)),
            ("antSelByte", i64::from(c.ant_sel)),
            (
                "subcarrierIndexOffset",
                i64::from(c.subcarrier_index_offset),
            ),
            ("CSIBufferLength", c.values.len() as i64 * 4),
        ];
        assert_eq!(
            BTreeMap::from(header.map(|(k, v)| (k.to_string(), v))),
            x.csi_header,
            "{at}"
        );
        let m = f.mvm_extra.as_ref().unwrap();
        let e = &x.mvm_extra;
        assert_eq!(e["header_len"], 272, "{at}");
        for (key, ours) in [
            ("iq_data_size", i64::from(m.csi_size)),
            ("ftm_clock", i64::from(m.ftm_clock)),
            ("num_rx", i64::from(m.num_rx)),
            ("num_tx", i64::from(m.num_tx)),
            ("num_tones", i64::from(m.num_subcarriers)),
            ("rssi1", i64::from(m.rssi[0])),
            ("rssi2", i64::from(m.rssi[1])),
            ("mu_clock", i64::from(m.mu_clock)),
            ("rate_n_flags", i64::from(m.rate_flags)),
        ] {
            assert_eq!(e[key].as_i64(), Some(ours), "{at} {key}");
        }
        assert_eq!(e["source_mac"], mac(&m.source_mac), "{at}");
        let p = &x.mpdu;
        assert_eq!(p["length"].as_u64(), Some(f.mpdu.len() as u64), "{at}");
        assert_eq!(
            p["frame_control"].as_u64(),
            f.frame_control().map(u64::from),
            "{at}"
        );
        let fc = f.frame_control().unwrap();
        assert_eq!(
            (p["type"].as_u64(), p["subtype"].as_u64()),
            (Some(u64::from(fc >> 2 & 3)), Some(u64::from(fc >> 4 & 0xf)))
        );
        assert_eq!(
            p["addr1"].as_str(),
            f.receiver().map(|m| mac(&m)).as_deref(),
            "{at}"
        );
        assert_eq!(
            p["addr2"].as_str(),
            f.transmitter().map(|m| mac(&m)).as_deref(),
            "{at}"
        );
        assert_eq!(p["seq_ctl"].as_u64(), f.seq_ctl().map(u64::from), "{at}");
        assert_eq!(x.csi.len(), usize::from(c.num_tone), "{at}");
        for (tone, per_rx) in x.csi.iter().enumerate() {
            for (rx, per_sts) in per_rx.iter().enumerate() {
                for (sts, &[re, im]) in per_sts.iter().enumerate() {
                    let ours = c.at(rx, sts, tone).unwrap();
                    assert_eq!((ours.re, ours.im), (re, im), "{at} tone {tone} rx {rx}");
                }
            }
        }
    }
}

#[test]
fn a_segment_version_the_reader_does_not_know_is_refused_by_name() {
    let Some(shared) = shared_data() else { return };
    let mut bytes = std::fs::read(shared.join(format!("{FILE}.csi"))).unwrap();
    let whole = parse_picoscenes(&bytes);
    // The third frame's RxSBasic version: after its length, magic, version, count, the
    // segment's length, name length and 9-byte name.
    let third = whole.frames[2].offset as usize;
    let at = third + 11 + 4 + 1 + 9;
    assert_eq!(&bytes[at..at + 2], &[3, 0]);
    bytes[at] = 4;
    let c = parse_picoscenes(&bytes);
    assert_eq!(c.frames.len(), 2);
    let (offset, _, why) = c.tail.clone().unwrap();
    assert_eq!(offset, third as u64);
    assert!(
        why.contains("RxSBasic segment of version 4") && why.contains("knows [3]"),
        "{why}"
    );
    assert_eq!(c.bytes_accounted(), bytes.len() as u64);
}

fn accounted(c: &PicoCapture, len: usize) -> bool {
    c.bytes_accounted() == len as u64
}

#[test]
fn damaged_copies_are_read_without_a_panic_and_every_byte_is_accounted_for() {
    let Some(shared) = shared_data() else { return };
    let bytes = std::fs::read(shared.join(format!("{FILE}.csi"))).unwrap();
    for cut in [1, 10, 11, 60, 988, 990, bytes.len() - 1] {
        let c = parse_picoscenes(&bytes[..cut]);
        assert!(accounted(&c, cut), "cut at {cut}");
        assert!(
            c.tail.as_ref().is_some_and(|t| t.2.contains("cut")),
            "cut at {cut}: {:?}",
            c.tail
        );
    }
    for copy in flipped_copies(&bytes, 0x2545_f491_4f6c_dd1du64, 300, 8, 0) {
        let c = parse_picoscenes(&copy);
        assert!(accounted(&c, copy.len()));
    }
    let text = parse_picoscenes(&[b'x'; 600]);
    assert!(text.frames.is_empty());
    assert!(
        text.tail
            .is_some_and(|t| t.1 == 600 && t.2.contains("not a PicoScenes frame"))
    );
}
