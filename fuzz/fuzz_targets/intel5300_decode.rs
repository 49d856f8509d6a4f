//! Fuzzes the Intel 5300 decoders: no panic, every byte accounted for exactly once, and the stream
//! decoder (fed in chunks whose sizes come from the input) equal to the slice decoder.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wins::csi::intel5300::{Event, SliceDecoder, StreamDecoder};

fuzz_target!(|data: &[u8]| {
    let Some((&chunk_seed, bytes)) = data.split_first() else {
        return;
    };
    let events: Vec<Event> = SliceDecoder::new(bytes).collect();
    let mut at = 0u64;
    for e in &events {
        let (offset, len) = match e {
            Event::Csi(r) => (r.offset, r.encoded_len() as u64),
            Event::Skipped(s) => (s.offset, s.len),
        };
        assert_eq!(offset, at);
        assert!(len > 0);
        at += len;
    }
    assert_eq!(at, bytes.len() as u64);

    let chunk = usize::from(chunk_seed).max(1);
    let mut d = StreamDecoder::new();
    let mut streamed = Vec::with_capacity(events.len());
    for c in bytes.chunks(chunk) {
        d.push(c);
        while let Some(e) = d.next_event() {
            streamed.push(e);
        }
    }
    d.finish();
    while let Some(e) = d.next_event() {
        streamed.push(e);
    }
    assert_eq!(streamed, events);
});
