//! The Intel 5300 reader on real captures, against the CSI Tool's MATLAB output and csiread.

use std::path::Path;

use serde::Deserialize;
use wins::csi::intel5300::{
    CsiLog, CsiRecord, Event, ExportFormat, LogReader, SkipReason, SliceDecoder, StreamDecoder,
    export,
};

use super::data::{repo_data, shared_data};

/// One line of a `*_ref.jsonl` file; `[re|im][tx][rx][sc]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RefRecord {
    index: usize,
    timestamp_low: u32,
    bfee_count: u16,
    nrx: u8,
    ntx: u8,
    rssi: [u8; 3],
    noise: i8,
    agc: u8,
    perm: [u8; 3],
    rate: u16,
    csi_re_im: Vec<Vec<Vec<Vec<f64>>>>,
    csi_scaled_re_im: Option<Vec<Vec<Vec<Vec<f64>>>>>,
}

fn parse_jsonl(text: &str) -> Vec<RefRecord> {
    text.lines()
        .enumerate()
        .map(|(i, l)| serde_json::from_str(l).unwrap_or_else(|e| panic!("line {i}: {e}")))
        .collect()
}

/// Largest relative error of scaled CSI seen, so the caller can assert on it.
fn check_record(name: &str, i: usize, ours: &CsiRecord, r: &RefRecord) -> f64 {
    let h = &ours.header;
    let ctx = format!("{name} record {i}");
    assert_eq!(r.index, i, "{ctx}");
    assert_eq!(h.timestamp_low, r.timestamp_low, "{ctx}: timestamp_low");
    assert_eq!(h.bfee_count, r.bfee_count, "{ctx}: bfee_count");
    assert_eq!((h.nrx, h.ntx), (r.nrx, r.ntx), "{ctx}: nrx, ntx");
    assert_eq!(h.rssi, r.rssi, "{ctx}: rssi");
    assert_eq!(h.noise_dbm, r.noise, "{ctx}: noise");
    assert_eq!(h.agc, r.agc, "{ctx}: agc");
    assert_eq!(h.raw_perm().map(|p| p + 1), r.perm, "{ctx}: perm");
    assert_eq!(h.rate.0, r.rate, "{ctx}: rate");
    let scaled = ours.scaled_csi().expect("real records are scalable");
    let mut worst = 0.0f64;
    for tx in 0..usize::from(h.ntx) {
        for rx in 0..usize::from(h.nrx) {
            for sc in 0..30 {
                let c = ours.csi_at(tx, rx, sc).expect("in range");
                let at = |part: &Vec<Vec<Vec<Vec<f64>>>>, k: usize| part[k][tx][rx][sc];
                assert_eq!(
                    (f64::from(c.re), f64::from(c.im)),
                    (at(&r.csi_re_im, 0), at(&r.csi_re_im, 1)),
                    "{ctx}: csi[{tx}][{rx}][{sc}]"
                );
                if let Some(s) = &r.csi_scaled_re_im {
                    let ours = scaled[(tx * usize::from(h.nrx) + rx) * 30 + sc];
                    for (a, b) in [(ours.re, at(s, 0)), (ours.im, at(s, 1))] {
                        let rel = (a - b).abs() / b.abs().max(f64::MIN_POSITIVE);
                        if a != b {
                            worst = worst.max(rel);
                        }
                    }
                }
            }
        }
    }
    worst
}

/// Checks a sample against its reference: every record and field, the skips, the streaming decoder
/// fed one byte at a time, and the JSONL export.
fn check_sample(dir: &Path, stem: &str, reference: &str, expect_non_csi: usize) {
    let bytes = std::fs::read(dir.join(format!("{stem}.dat"))).expect("sample present");
    let refs = parse_jsonl(
        &std::fs::read_to_string(dir.join(format!("{stem}.{reference}.jsonl"))).expect("reference"),
    );
    let log = CsiLog::from_bytes(&bytes);
    assert_eq!(log.records.len(), refs.len(), "{stem}: record count");
    assert_eq!(
        log.skips.len(),
        expect_non_csi,
        "{stem}: skips {:?}",
        log.skips.first()
    );
    assert!(
        log.skips
            .iter()
            .all(|s| s.reason == SkipReason::NonCsi { code: 0xC1 }),
        "{stem}: only 0xC1 frame records are skipped"
    );
    let mut worst = 0.0f64;
    let mut scaled_checked = 0;
    for (i, (ours, r)) in log.records.iter().zip(&refs).enumerate() {
        worst = worst.max(check_record(stem, i, ours, r));
        scaled_checked += usize::from(r.csi_scaled_re_im.is_some());
    }
    assert!(scaled_checked > 0, "{stem}: reference has scaled CSI");
    assert!(
        worst <= 1e-9,
        "{stem}: scaled CSI off by {worst:e} relative"
    );

    // Timestamps: unwrapped µs on the NIC clock, monotonic in these captures.
    for w in log.records.windows(2) {
        assert!(w[1].timestamp >= w[0].timestamp, "{stem}: time goes back");
        let dt_us = i64::from(
            w[1].header
                .timestamp_low
                .wrapping_sub(w[0].header.timestamp_low),
        );
        assert_eq!(w[1].timestamp.0 - w[0].timestamp.0, dt_us * 1000);
    }

    // Streaming, one byte at a time, equals the file reader (records and skips, in order).
    let slice_events: Vec<Event> = SliceDecoder::new(&bytes).collect();
    let mut stream = StreamDecoder::new();
    let mut stream_events = Vec::new();
    for b in &bytes {
        stream.push(std::slice::from_ref(b));
        while let Some(e) = stream.next_event() {
            stream_events.push(e);
        }
    }
    stream.finish();
    while let Some(e) = stream.next_event() {
        stream_events.push(e);
    }
    assert_eq!(stream_events, slice_events, "{stem}: stream ≠ file reader");
    assert_eq!(stream.pending(), 0);
    let pulled: Vec<Event> = LogReader::new(&bytes[..])
        .map(|e| e.expect("in memory"))
        .collect();
    assert_eq!(pulled, slice_events, "{stem}: LogReader ≠ SliceDecoder");

    // The JSONL export has the reference's schema and values.
    let mut out = Vec::new();
    let stats = export(&bytes[..], ExportFormat::Jsonl, &mut out).expect("in memory");
    assert_eq!(stats.records as usize, refs.len());
    assert_eq!(stats.non_csi_records as usize, expect_non_csi);
    let exported = parse_jsonl(std::str::from_utf8(&out).expect("utf-8"));
    for (i, (e, r)) in exported.iter().zip(&refs).enumerate() {
        assert_eq!(e.csi_re_im, r.csi_re_im, "{stem} export {i}");
        assert_eq!(
            (e.timestamp_low, e.perm, e.rate, e.noise),
            (r.timestamp_low, r.perm, r.rate, r.noise)
        );
        if let (Some(a), Some(b)) = (&e.csi_scaled_re_im, &r.csi_scaled_re_im) {
            let flat = |x: &Vec<Vec<Vec<Vec<f64>>>>| {
                x.iter()
                    .flatten()
                    .flatten()
                    .flatten()
                    .copied()
                    .collect::<Vec<_>>()
            };
            for (x, y) in flat(a).iter().zip(flat(b)) {
                assert!(
                    (x - y).abs() <= 1e-9 * y.abs(),
                    "{stem} export {i}: {x} vs {y}"
                );
            }
        }
    }
}

#[test]
fn csikit_example_matches_matlab() {
    check_sample(
        &repo_data().join("intel5300"),
        "csikit_example",
        "matlab_ref",
        0,
    );
}

#[test]
fn csikit_mixed_chains_match_matlab() {
    let dir = repo_data().join("intel5300");
    check_sample(&dir, "csikit_log.all_csi.6.7.6", "matlab_ref", 0);
    let log = CsiLog::from_bytes(
        &std::fs::read(dir.join("csikit_log.all_csi.6.7.6.dat")).expect("sample"),
    );
    let mut shapes: Vec<(u8, u8)> = log
        .records
        .iter()
        .map(|r| (r.header.nrx, r.header.ntx))
        .collect();
    shapes.dedup();
    assert!(
        shapes.len() >= 3,
        "expected 3x1, 3x2 and 3x3 records: {shapes:?}"
    );
}

#[test]
fn csiread_ap_sample_matches_csiread() {
    if let Some(dir) = shared_data() {
        check_sample(
            &dir.join("intel5300"),
            "csiread_sample_0x1_ap",
            "csiread_ref",
            0,
        );
    }
}

#[test]
fn csiread_monitor_sample_matches_csiread_and_skips_frame_records() {
    if let Some(dir) = shared_data() {
        check_sample(
            &dir.join("intel5300"),
            "csiread_sample_0x5_64_3000",
            "csiread_ref",
            2998,
        );
    }
}

/// The monitor-mode sample's 0xC1 frame records name the transmitter of each CSI record (the
/// 802.11 header's `addr2`, 00:16:ea:12:34:56 in that capture), read by the stream decoder in
/// chunks of any size.
#[test]
fn frame_records_name_the_transmitter_of_each_csi_record() {
    let Some(dir) = shared_data() else {
        return;
    };
    let bytes = std::fs::read(dir.join("intel5300/csiread_sample_0x5_64_3000.dat"))
        .expect("the sample is readable");
    let mut decoder = StreamDecoder::new();
    let (mut named, mut csi) = (0, 0);
    for chunk in bytes.chunks(777) {
        decoder.push(chunk);
        while let Some(event) = decoder.next_event() {
            if let Event::Csi(_) = event {
                csi += 1;
                if decoder.transmitter() == Some([0x00, 0x16, 0xea, 0x12, 0x34, 0x56]) {
                    named += 1;
                }
            }
        }
    }
    assert_eq!(csi, 2998);
    assert_eq!(named, 2998);
    // A log without frame records names none.
    let plain = std::fs::read(dir.join("intel5300/csiread_sample_0x1_ap.dat"))
        .expect("the sample is readable");
    let mut decoder = StreamDecoder::new();
    decoder.push(&plain);
    while let Some(event) = decoder.next_event() {
        if let Event::Csi(_) = event {
            assert_eq!(decoder.transmitter(), None);
        }
    }
}
