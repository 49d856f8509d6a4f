//! Corrupt Intel 5300 logs: every byte is accounted for, neighbours of a bad record survive, and
//! nothing panics (property tests over random and mutated byte strings stand in for a fuzzer).

use num_complex::Complex;
use proptest::prelude::*;
use wins::csi::intel5300::{
    BfeeHeader, CsiLog, CsiRecord, Event, FramingError, MAX_UNFRAMED, RateFlags, Skip, SkipReason,
    SliceDecoder, StreamDecoder, encode_record,
};
use wins::time::Timestamp;

/// A deterministic record `i` with the given chains.
fn record(i: u32, nrx: u8, ntx: u8) -> CsiRecord {
    let header = BfeeHeader {
        timestamp_low: 1_000_000 + 20_000 * i,
        bfee_count: i as u16,
        nrx,
        ntx,
        rssi: [40, 38, 36],
        noise_dbm: -90,
        agc: 30,
        antenna_sel: 0b00_10_01, // chains -> antennas (1, 2, 0)
        rate: RateFlags(0x101),
    };
    let csi: Vec<Complex<i8>> = (0..header.num_entries())
        .map(|k| Complex::new((k as i32 * 7 + i as i32) as i8, (k as i32 * 13 - 50) as i8))
        .collect();
    CsiRecord::new(header, &csi, Timestamp(0)).expect("valid shape")
}

/// Three records of different shapes, their bytes and start offsets.
fn three() -> (Vec<CsiRecord>, Vec<u8>, Vec<usize>) {
    let recs = vec![record(0, 3, 1), record(1, 3, 2), record(2, 2, 3)];
    let mut bytes = Vec::new();
    let mut starts = Vec::new();
    for r in &recs {
        starts.push(bytes.len());
        encode_record(r, &mut bytes);
    }
    (recs, bytes, starts)
}

fn same(a: &CsiRecord, b: &CsiRecord) -> bool {
    a.header == b.header && a.csi() == b.csi() && a.perm == b.perm
}

fn unframed(offset: usize, len: usize, cause: FramingError) -> Skip {
    Skip {
        offset: offset as u64,
        len: len as u64,
        reason: SkipReason::Unframed { cause },
    }
}

/// Every byte is in exactly one event, in order, from offset 0.
fn assert_tiles(bytes: &[u8], events: &[Event]) {
    let mut at = 0u64;
    for e in events {
        let (offset, len) = match e {
            Event::Csi(r) => (r.offset, r.encoded_len() as u64),
            Event::Skipped(s) => (s.offset, s.len),
        };
        assert_eq!(offset, at, "gap or overlap before {e:?}");
        assert!(len > 0, "empty event {e:?}");
        at += len;
    }
    assert_eq!(at, bytes.len() as u64, "events do not cover the input");
}

fn stream_in_chunks(bytes: &[u8], chunks: &[usize]) -> Vec<Event> {
    let mut d = StreamDecoder::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    for &c in chunks.iter().cycle() {
        if rest.is_empty() {
            break;
        }
        let (now, later) = rest.split_at(c.clamp(1, rest.len()));
        d.push(now);
        rest = later;
        while let Some(e) = d.next_event() {
            out.push(e);
        }
    }
    d.finish();
    while let Some(e) = d.next_event() {
        out.push(e);
    }
    out
}

#[test]
fn clean_log_decodes_with_offsets_and_no_skips() {
    let (recs, bytes, starts) = three();
    let log = CsiLog::from_bytes(&bytes);
    assert!(log.skips.is_empty());
    assert_eq!(log.records.len(), 3);
    for ((ours, orig), start) in log.records.iter().zip(&recs).zip(&starts) {
        assert!(same(ours, orig));
        assert_eq!(ours.offset, *start as u64);
    }
    assert!(CsiLog::from_bytes(&[]).records.is_empty() && CsiLog::from_bytes(&[]).skips.is_empty());
}

#[test]
fn truncated_tail_is_reported_at_every_cut() {
    let (recs, bytes, starts) = three();
    let last = starts[2];
    let total = bytes.len() - last;
    for keep in 1..total {
        let cut = &bytes[..last + keep];
        let log = CsiLog::from_bytes(cut);
        assert_eq!(log.records.len(), 2, "cut at {keep}");
        assert!(same(&log.records[1], &recs[1]));
        let needed = if keep < 3 { 3 } else { total as u64 };
        assert_eq!(
            log.skips,
            vec![Skip {
                offset: last as u64,
                len: keep as u64,
                reason: SkipReason::TruncatedTail { needed }
            }],
            "cut at {keep}"
        );
    }
}

#[test]
fn record_length_that_disagrees_with_the_chains_is_skipped_and_neighbours_survive() {
    let (recs, mut bytes, starts) = three();
    let s = starts[1];
    let field_len = u16::from_be_bytes([bytes[s], bytes[s + 1]]);
    bytes[s..s + 2].copy_from_slice(&(field_len + 4).to_be_bytes());
    let log = CsiLog::from_bytes(&bytes);
    assert_eq!(log.records.len(), 2);
    assert!(same(&log.records[0], &recs[0]) && same(&log.records[1], &recs[2]));
    assert_eq!(
        log.skips,
        vec![unframed(
            s,
            starts[2] - s,
            FramingError::RecordLenMismatch {
                field_len: field_len + 4,
                expected: field_len
            }
        )]
    );
}

#[test]
fn header_csi_length_and_chain_count_are_checked() {
    let (_, bytes, starts) = three();
    let s = starts[1];
    // The header's own CSI length (bytes 16-17 of the header, after length and code).
    let mut b = bytes.clone();
    b[s + 3 + 16] ^= 1;
    let log = CsiLog::from_bytes(&b);
    assert_eq!(log.records.len(), 2);
    assert!(matches!(
        log.skips[0].reason,
        SkipReason::Unframed {
            cause: FramingError::CsiLenMismatch { expected: 372, .. }
        }
    ));
    // nrx = 4.
    let mut b = bytes.clone();
    b[s + 3 + 8] = 4;
    let log = CsiLog::from_bytes(&b);
    assert_eq!(log.records.len(), 2);
    assert_eq!(
        log.skips,
        vec![unframed(
            s,
            starts[2] - s,
            FramingError::BadChains { nrx: 4, ntx: 2 }
        )]
    );
}

#[test]
fn garbage_between_records_is_one_reported_region() {
    let (recs, bytes, starts) = three();
    for garbage in [
        vec![0xAB; 37],
        vec![0x00, 0x07, 0xBB, 1, 2, 3, 4, 5, 6],
        vec![0xFF; 1],
    ] {
        let mut b = bytes[..starts[1]].to_vec();
        b.extend_from_slice(&garbage);
        b.extend_from_slice(&bytes[starts[1]..]);
        let log = CsiLog::from_bytes(&b);
        assert_eq!(log.records.len(), 3, "garbage {garbage:?}");
        assert!(log.records.iter().zip(&recs).all(|(a, b)| same(a, b)));
        assert_eq!(log.skips.len(), 1, "{:?}", log.skips);
        assert_eq!(
            (log.skips[0].offset, log.skips[0].len),
            (starts[1] as u64, garbage.len() as u64)
        );
        assert!(matches!(log.skips[0].reason, SkipReason::Unframed { .. }));
    }
}

#[test]
fn zero_length_unknown_code_and_frame_records() {
    let (recs, bytes, starts) = three();
    let insert = |extra: &[u8]| {
        let mut b = bytes[..starts[1]].to_vec();
        b.extend_from_slice(extra);
        b.extend_from_slice(&bytes[starts[1]..]);
        CsiLog::from_bytes(&b)
    };
    let log = insert(&[0, 0]);
    assert_eq!(log.records.len(), 3);
    assert_eq!(
        log.skips,
        vec![unframed(starts[1], 2, FramingError::ZeroLength)]
    );
    // A well-framed record of an unknown code, followed by a valid record: skipped and counted.
    let log = insert(&[0, 5, 0x42, 1, 2, 3, 4]);
    assert_eq!(log.records.len(), 3);
    assert_eq!(
        log.skips,
        vec![Skip {
            offset: starts[1] as u64,
            len: 7,
            reason: SkipReason::NonCsi { code: 0x42 }
        }]
    );
    // Two 0xC1 frame records in a row.
    let log = insert(&[0, 3, 0xC1, 9, 9, 0, 2, 0xC1, 7]);
    assert_eq!(log.records.len(), 3);
    assert!(same(&log.records[2], &recs[2]));
    assert_eq!(
        log.skips
            .iter()
            .map(|s| (s.offset, s.len))
            .collect::<Vec<_>>(),
        vec![(starts[1] as u64, 5), (starts[1] as u64 + 5, 4)]
    );
    // Trailing garbage claiming a long record: a truncated tail, nothing before it lost.
    let mut b = bytes.clone();
    b.extend_from_slice(&[0x7F, 0xFF, 0x42, 1]);
    let log = CsiLog::from_bytes(&b);
    assert_eq!(log.records.len(), 3);
    assert_eq!(
        log.skips[0].reason,
        SkipReason::TruncatedTail { needed: 0x7FFF + 2 }
    );
}

#[test]
fn a_cut_record_followed_by_a_restarted_log_loses_only_the_cut_record() {
    let (recs, bytes, starts) = three();
    let mut b = bytes[..starts[1] + 50].to_vec();
    b.extend_from_slice(&bytes[starts[2]..]);
    let log = CsiLog::from_bytes(&b);
    assert_eq!(log.records.len(), 2);
    assert!(same(&log.records[1], &recs[2]));
    assert_eq!(
        log.skips,
        vec![unframed(
            starts[1],
            50,
            FramingError::OverlapsCsi { next_at: 50 }
        )]
    );
}

#[test]
fn timestamps_unwrap_across_the_32_bit_wrap() {
    let mut bytes = Vec::new();
    // 20 ms apart, wrapping between the second and the third.
    for (k, t) in [u32::MAX - 30_000, u32::MAX - 10_000, 9_999, 29_999]
        .into_iter()
        .enumerate()
    {
        let mut r = record(k as u32, 3, 1);
        r.header.timestamp_low = t;
        encode_record(&r, &mut bytes);
    }
    let log = CsiLog::from_bytes(&bytes);
    let us: Vec<i64> = log.records.iter().map(|r| r.timestamp.0 / 1000).collect();
    let first = i64::from(u32::MAX - 30_000);
    assert_eq!(
        us,
        vec![first, first + 20_000, first + 40_000, first + 60_000]
    );
}

#[test]
fn a_stream_of_garbage_keeps_memory_bounded_and_is_reported_in_pieces() {
    // 300 KB of pseudo-random bytes (no valid CSI header by construction: nrx bytes are never 1-3).
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    let mut bytes: Vec<u8> = (0..300_000)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 56) as u8 | 0x40
        })
        .collect();
    let (recs, good, _) = three();
    bytes.extend_from_slice(&good);
    let mut d = StreamDecoder::new();
    let mut events = Vec::new();
    let mut max_pending = 0;
    for chunk in bytes.chunks(1000) {
        d.push(chunk);
        while let Some(e) = d.next_event() {
            events.push(e);
        }
        max_pending = max_pending.max(d.pending());
    }
    d.finish();
    while let Some(e) = d.next_event() {
        events.push(e);
    }
    assert_tiles(&bytes, &events);
    assert_eq!(events, SliceDecoder::new(&bytes).collect::<Vec<_>>());
    assert!(
        max_pending <= StreamDecoder::MAX_PENDING + 1000,
        "decoder held {max_pending} bytes"
    );
    let skips: Vec<&Skip> = events
        .iter()
        .filter_map(|e| match e {
            Event::Skipped(s) => Some(s),
            Event::Csi(_) => None,
        })
        .collect();
    assert_eq!(skips.len(), 300_000usize.div_ceil(MAX_UNFRAMED));
    assert!(skips.iter().all(|s| s.len <= MAX_UNFRAMED as u64));
    let decoded: Vec<&CsiRecord> = events
        .iter()
        .filter_map(|e| match e {
            Event::Csi(r) => Some(&**r),
            Event::Skipped(_) => None,
        })
        .collect();
    assert_eq!(decoded.len(), 3);
    assert!(decoded.iter().zip(&recs).all(|(a, b)| same(a, b)));
}

proptest! {
    #![proptest_config(crate::proptest_config(256))]

    #[test]
    fn random_bytes_never_panic_and_are_fully_accounted(
        bytes in proptest::collection::vec(any::<u8>(), 0..3000),
        chunks in proptest::collection::vec(1usize..200, 1..8),
    ) {
        let events: Vec<Event> = SliceDecoder::new(&bytes).collect();
        assert_tiles(&bytes, &events);
        prop_assert_eq!(stream_in_chunks(&bytes, &chunks), events);
    }

    #[test]
    fn mutated_logs_never_panic_and_stream_equals_file(
        shapes in proptest::collection::vec((1u8..=3, 1u8..=3), 1..6),
        edits in proptest::collection::vec((any::<prop::sample::Index>(), 0u8..4, any::<u8>(), 1usize..40), 1..5),
        chunks in proptest::collection::vec(1usize..300, 1..8),
    ) {
        let mut bytes = Vec::new();
        for (i, &(nrx, ntx)) in shapes.iter().enumerate() {
            encode_record(&record(i as u32, nrx, ntx), &mut bytes);
        }
        for (at, op, byte, n) in edits {
            let i = at.index(bytes.len().max(1));
            match op {
                0 if !bytes.is_empty() => bytes[i] ^= byte | 1,
                1 => bytes.splice(i..i, std::iter::repeat_n(byte, n)).for_each(drop),
                2 => { bytes.drain(i..(i + n).min(bytes.len())); }
                _ => bytes.truncate(i),
            }
        }
        let events: Vec<Event> = SliceDecoder::new(&bytes).collect();
        assert_tiles(&bytes, &events);
        prop_assert_eq!(stream_in_chunks(&bytes, &chunks), events);
    }

    #[test]
    fn garbage_inserted_between_records_loses_no_record(
        shapes in proptest::collection::vec((1u8..=3, 1u8..=3), 2..6),
        at in any::<prop::sample::Index>(),
        garbage in proptest::collection::vec(any::<u8>(), 1..64),
    ) {
        let recs: Vec<CsiRecord> = shapes.iter().enumerate().map(|(i, &(r, t))| record(i as u32, r, t)).collect();
        let k = at.index(recs.len() + 1);
        let mut bytes = Vec::new();
        for (i, r) in recs.iter().enumerate() {
            if i == k { bytes.extend_from_slice(&garbage); }
            encode_record(r, &mut bytes);
        }
        if k == recs.len() { bytes.extend_from_slice(&garbage); }
        let log = CsiLog::from_bytes(&bytes);
        prop_assert_eq!(log.records.len(), recs.len());
        for (a, b) in log.records.iter().zip(&recs) {
            prop_assert!(same(a, b));
        }
        let lost: u64 = log.skips.iter().map(|s| s.len).sum();
        prop_assert_eq!(lost, garbage.len() as u64);
    }
}

/// A garbage length field claiming 64 KiB (a non-CSI code, or a 0xC1 frame record as the resync
/// meets it) holds no later record back in a live stream: each record comes out once its own
/// bytes are in, as in a clean stream, and the whole stream decodes as the whole file does.
#[test]
fn a_garbage_length_field_holds_no_later_record_back() {
    for garbage in [[0xFF, 0xFF, 0x42], [0xFF, 0xF0, 0xC1]] {
        let records: Vec<CsiRecord> = (0..6).map(|i| record(i, 3, 1)).collect();
        let mut bytes = Vec::new();
        encode_record(&records[0], &mut bytes);
        bytes.extend(garbage);
        let mut ends = Vec::new();
        for r in &records[1..] {
            encode_record(r, &mut bytes);
            ends.push(bytes.len());
        }
        // Fed up to the end of each record in turn (no end of stream): that record is out.
        let mut d = StreamDecoder::new();
        let mut fed = 0;
        let mut out = 0;
        for (i, &end) in ends.iter().enumerate() {
            d.push(&bytes[fed..end]);
            fed = end;
            while let Some(e) = d.next_event() {
                out += usize::from(matches!(e, Event::Csi(_)));
            }
            // The last record is taken once a record could follow it (a CSI record needs
            // nothing after it).
            assert_eq!(out, i + 2, "{garbage:02X?}: record {} held back", i + 1);
        }
        let streamed = stream_in_chunks(&bytes, &[7, 300, 1]);
        assert_eq!(streamed, SliceDecoder::new(&bytes).collect::<Vec<_>>());
        assert_tiles(&bytes, &streamed);
    }
}
