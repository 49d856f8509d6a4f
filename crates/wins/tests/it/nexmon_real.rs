//! The Nexmon reader on the real BCM4366c0 captures in `../shared/data/nexmon/`, field by field
//! against csiread 1.4.1 (autoscaled CSI, with its shift) and nexcsi 0.5.2 (exact CSI), the
//! frames against the capture's documented make-up, and damaged copies read without a panic
//! with every byte accounted for.

use std::path::Path;

use serde::Deserialize;
use wins::csi::nexmon::frames::frames;
use wins::csi::nexmon::{NexmonCapture, parse_nexmon, read_nexmon};

use super::data::{flipped_copies, shared_data};

/// One line of a `*.csiread_ref.jsonl`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CsireadRow {
    index: usize,
    ts_sec: u32,
    ts_usec: u32,
    caplen: u32,
    wirelen: u32,
    magic: u32,
    src_mac: String,
    seq: u16,
    seq_num: u16,
    frag: u16,
    csiconf: u16,
    core: u8,
    spatial_stream: u8,
    chanspec: u16,
    channel: u8,
    bandwidth_mhz: u32,
    band: String,
    chip: u16,
    float_shift: i32,
    csi: Option<Vec<[i64; 2]>>,
}

/// One line of the `*.nexcsi_ref.jsonl`: exact values.
#[derive(Debug, Deserialize)]
struct NexcsiRow {
    index: usize,
    csi: Vec<[f64; 2]>,
}

fn lines<T: serde::de::DeserializeOwned>(path: &Path) -> Vec<T> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .enumerate()
        .map(|(i, l)| serde_json::from_str(l).unwrap_or_else(|e| panic!("line {i}: {e}")))
        .collect()
}

fn mac(m: &[u8; 6]) -> String {
    m.iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(":")
}

const CAPTURES: [&str; 3] = [
    "mutrack_D2_CSI_2G_20M_AP3_tr2",
    "mutrack_D4_CSI_2G_20M_AP2_tr1",
    "mutrack_tx1_rx1rx4_tr3",
];

#[test]
fn every_packet_equals_csiread_field_by_field() {
    let Some(shared) = shared_data() else { return };
    for name in CAPTURES {
        let dir = shared.join("nexmon");
        let capture = read_nexmon(&dir.join(format!("{name}.pcap"))).unwrap();
        let refs: Vec<CsireadRow> = lines(&dir.join(format!("{name}.csiread_ref.jsonl")));
        assert_eq!(capture.packets.len(), refs.len(), "{name}");
        assert_eq!(capture.other_records, 0, "{name}");
        assert!(capture.tail.is_none(), "{name}");
        let mut compared = 0;
        for (p, r) in capture.packets.iter().zip(&refs) {
            let at = format!("{name} packet {}", r.index);
            assert_eq!(p.index, r.index, "{at}");
            assert_eq!((p.ts_sec, p.ts_frac), (r.ts_sec, r.ts_usec), "{at}");
            assert_eq!((p.caplen, p.wirelen), (r.caplen, r.wirelen), "{at}");
            assert_eq!(p.magic, r.magic, "{at}");
            assert_eq!(mac(&p.transmitter), r.src_mac, "{at}");
            assert_eq!(
                (p.seq, p.seq_num(), p.fragment()),
                (r.seq, r.seq_num, r.frag),
                "{at}"
            );
            assert_eq!(
                (p.csiconf, p.core(), p.spatial_stream()),
                (r.csiconf, r.core, r.spatial_stream),
                "{at}"
            );
            assert_eq!(
                (p.chanspec, p.channel(), p.chip),
                (r.chanspec, r.channel, r.chip),
                "{at}"
            );
            assert_eq!(p.bandwidth_mhz(), r.bandwidth_mhz, "{at}");
            let band = if r.channel <= 14 { "2.4GHz" } else { "5GHz" };
            assert_eq!(band, r.band, "{at}");
            let (csi, shift) = p.csi_autoscaled();
            assert_eq!(shift, r.float_shift, "{at}");
            if let Some(values) = &r.csi {
                let ours: Vec<[i64; 2]> = csi.iter().map(|c| [c.re, c.im]).collect();
                assert_eq!(&ours, values, "{at}");
                compared += 1;
            }
        }
        assert!(compared >= 534.min(refs.len()), "{name}: {compared}");
    }
}

#[test]
fn the_exact_values_equal_nexcsi() {
    let Some(shared) = shared_data() else { return };
    let dir = shared.join("nexmon");
    let name = "mutrack_D2_CSI_2G_20M_AP3_tr2";
    let capture = read_nexmon(&dir.join(format!("{name}.pcap"))).unwrap();
    let refs: Vec<NexcsiRow> = lines(&dir.join(format!("{name}.nexcsi_ref.jsonl")));
    assert_eq!(refs.len(), 100);
    for r in &refs {
        let ours: Vec<[f64; 2]> = capture.packets[r.index]
            .csi_exact()
            .iter()
            .map(|c| [c.re, c.im])
            .collect();
        assert_eq!(ours, r.csi, "packet {}", r.index);
    }
}

#[test]
fn frames_are_made_of_their_cores_and_a_lost_packet_leaves_one_short() {
    let Some(shared) = shared_data() else { return };
    let dir = shared.join("nexmon");
    let read = |name: &str| read_nexmon(&dir.join(format!("{name}.pcap"))).unwrap();
    let count = |capture: &NexmonCapture, cores: &[u8]| {
        frames(&capture.packets)
            .iter()
            .filter(|f| f.cores() == cores)
            .count()
    };
    // D2: 534 packets = 178 whole frames of cores 0, 1, 3.
    let d2 = read("mutrack_D2_CSI_2G_20M_AP3_tr2");
    assert_eq!(frames(&d2.packets).len(), 178);
    assert_eq!(count(&d2, &[0, 1, 3]), 178);
    // D4: 241 whole, 4 × (0, 1), 1 × (1, 3), 1 × (0).
    let d4 = read("mutrack_D4_CSI_2G_20M_AP2_tr1");
    assert_eq!(count(&d4, &[0, 1, 3]), 241);
    assert_eq!(count(&d4, &[0, 1]), 4);
    assert_eq!(count(&d4, &[1, 3]), 1);
    assert_eq!(count(&d4, &[0]), 1);
    assert_eq!(frames(&d4.packets).len(), 247);
    // The 5 GHz capture: cores 0 and 3 only, channel 157.
    let tx1 = read("mutrack_tx1_rx1rx4_tr3");
    assert!(
        frames(&tx1.packets)
            .iter()
            .all(|f| f.cores().iter().all(|c| [0, 3].contains(c)))
    );
    assert!(tx1.packets.iter().all(|p| p.channel() == 157));
}

/// Every byte of `capture` (of `len` bytes) is in a packet, another record, or the tail.
fn accounted(capture: &NexmonCapture, len: usize) -> bool {
    capture.bytes_accounted() == len as u64 && capture.bytes == len as u64
}

#[test]
fn damaged_copies_are_read_without_a_panic_and_every_byte_is_accounted_for() {
    let Some(shared) = shared_data() else { return };
    let bytes = std::fs::read(shared.join("nexmon/mutrack_D2_CSI_2G_20M_AP3_tr2.pcap")).unwrap();
    let whole = parse_nexmon(&bytes).unwrap();
    assert!(accounted(&whole, bytes.len()));
    // Cut anywhere: the packets before the cut, the cut record reported.
    for cut in [25, 40, 1000, bytes.len() / 2, bytes.len() - 1] {
        let c = parse_nexmon(&bytes[..cut]).unwrap();
        assert!(accounted(&c, cut), "cut at {cut}");
        assert!(c.packets.len() <= whole.packets.len());
    }
    // Bytes flipped: records still framed by the pcap headers, the damaged ones counted.
    for copy in flipped_copies(&bytes, 0x9e37_79b9_7f4a_7c15u64, 200, 20, 24) {
        let c = parse_nexmon(&copy).unwrap();
        assert!(accounted(&c, copy.len()));
        for p in &c.packets {
            let _ = (
                p.csi_autoscaled(),
                p.csi_exact(),
                p.core(),
                p.bandwidth_mhz(),
            );
        }
    }
    // Not a pcap: named.
    assert!(parse_nexmon(b"not a capture at all, just text").is_err());
}
