//! Fuzzes the Nexmon reader: no panic on any bytes (a pcap header is put in front of most
//! inputs, so the walk reaches the records), and every byte accounted for exactly once: the
//! global header, the CSI packets' records, the other records and the reported tail.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wins::csi::nexmon::frames::frames;
use wins::csi::nexmon::parse_nexmon;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut bytes = Vec::new();
    if mode % 4 != 0 {
        // A little-endian Ethernet capture's header, then the fuzzer's records.
        bytes.extend([0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0]);
        bytes.extend([0u8; 12]);
        bytes.extend(1u32.to_le_bytes());
    }
    bytes.extend(rest);
    let Ok(capture) = parse_nexmon(&bytes) else {
        return;
    };
    assert_eq!(capture.bytes_accounted(), bytes.len() as u64);
    for p in &capture.packets {
        let (values, _) = p.csi_autoscaled();
        assert_eq!(values.len(), p.words.len());
        assert_eq!(p.csi_exact().len(), p.words.len());
    }
    let grouped: usize = frames(&capture.packets).iter().map(|f| f.packets.len()).sum();
    assert_eq!(grouped, capture.packets.len());
});
