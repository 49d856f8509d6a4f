//! Fuzzes the PicoScenes reader: no panic on any bytes (a frame header is put in front of most
//! inputs, so the walk reaches the segments), and every byte accounted for exactly once (the
//! frames and the reported tail).
#![no_main]

use libfuzzer_sys::fuzz_target;
use wins::csi::picoscenes::{FRAME_MAGIC, parse_picoscenes};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut bytes = Vec::new();
    if mode % 4 != 0 {
        // A frame of version 1 around the fuzzer's segments, `mode` of them.
        bytes.extend((rest.len() as u32 + 7).to_le_bytes());
        bytes.extend(FRAME_MAGIC.to_le_bytes());
        bytes.extend(1u16.to_le_bytes());
        bytes.push(mode / 4);
    }
    bytes.extend(rest);
    let capture = parse_picoscenes(&bytes);
    assert_eq!(capture.bytes_accounted(), bytes.len() as u64);
    for f in &capture.frames {
        if let Some(c) = &f.csi {
            let shape = usize::from(c.num_rx) * usize::from(c.num_sts) * usize::from(c.num_tone);
            assert_eq!(c.values.len(), shape);
        }
    }
});
