//! Fuzzes the FeitCSI reader: no panic on any bytes (a plausible record header is put in front
//! of most inputs, so the walk reaches the CSI), and every byte accounted for exactly once (the
//! records and the reported tail); each record's CSI fits its header's shape.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wins::csi::feitcsi::{FEIT_HEADER_LEN, parse_feitcsi};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut bytes = Vec::new();
    if mode % 4 != 0 {
        // A header of 2 chains, 1 stream and `mode` subcarriers with a matching size.
        let tones = u32::from(mode);
        let mut header = vec![0u8; FEIT_HEADER_LEN];
        header[..4].copy_from_slice(&(tones * 2 * 4).to_le_bytes());
        header[46] = 2;
        header[47] = 1;
        header[52..56].copy_from_slice(&tones.to_le_bytes());
        bytes.extend(header);
    }
    bytes.extend(rest);
    let capture = parse_feitcsi(&bytes);
    let records: usize = capture
        .records
        .iter()
        .map(|r| FEIT_HEADER_LEN + r.csi.len() * 4)
        .sum();
    assert_eq!(
        records as u64 + capture.tail.as_ref().map_or(0, |t| t.1),
        bytes.len() as u64
    );
    for r in &capture.records {
        assert_eq!(r.csi.len(), r.header.values());
    }
});
