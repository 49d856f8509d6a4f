//! Fuzzes the Atheros CSI Tool reader: no panic on any bytes, in either forced byte order or
//! told from the file, and every byte accounted for exactly once (the leading byte, the
//! records and the reported tail).
#![no_main]

use libfuzzer_sys::fuzz_target;
use wins::csi::atheros::{ByteOrder, parse_atheros};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let order = match mode % 3 {
        0 => None,
        1 => Some(ByteOrder::Little),
        _ => Some(ByteOrder::Big),
    };
    let capture = parse_atheros(rest, order);
    assert_eq!(capture.bytes_accounted(), rest.len() as u64);
    for r in &capture.records {
        let shape = usize::from(r.nr) * usize::from(r.nc) * usize::from(r.num_tones);
        assert!(r.csi.is_empty() || r.csi.len() == shape);
    }
});
