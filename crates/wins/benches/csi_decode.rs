//! Intel 5300 log decoding speed: records per second on the csiread 3000-record sample
//! (`shared/data/intel5300/csiread_sample_0x5_64_3000.dat`, 2998 CSI + 2998 frame records, 1 MB),
//! beside two references measured in the same run: a literal port of the CSI Tool's
//! `read_bf_file.m` + `read_bfee.c` (allocating per record, bit by bit), and a plain byte sum of the
//! file (the memory-bandwidth floor).
//!
//! Run: `cargo bench -p wins --bench csi_decode`.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::path::PathBuf;
use std::sync::LazyLock;

use divan::counter::{BytesCount, ItemsCount};
use divan::{Bencher, black_box};
use num_complex::Complex;
use wins::csi::intel5300::{Event, SliceDecoder, StreamDecoder, unpack_reference};

fn main() {
    divan::main();
}

/// The sample log, or the repository's small sample repeated to about 1 MB if `shared/` is absent.
static LOG: LazyLock<Vec<u8>> = LazyLock::new(|| {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let shared = root.join("../shared/data/intel5300/csiread_sample_0x5_64_3000.dat");
    if let Ok(bytes) = std::fs::read(&shared) {
        return bytes;
    }
    eprintln!(
        "{} not found: benchmarking the repository sample repeated",
        shared.display()
    );
    let small = std::fs::read(root.join("data/intel5300/csikit_log.all_csi.6.7.6.dat"))
        .expect("repository sample");
    small.repeat(1_000_000 / small.len())
});

static CSI_RECORDS: LazyLock<u64> = LazyLock::new(|| {
    SliceDecoder::new(&LOG)
        .filter(|e| matches!(e, Event::Csi(_)))
        .count() as u64
});

#[divan::bench]
fn slice_decoder(bencher: Bencher) {
    bencher.counter(ItemsCount::new(*CSI_RECORDS)).bench(|| {
        let mut csi_entries = 0usize;
        for event in SliceDecoder::new(black_box(&LOG)) {
            if let Event::Csi(r) = event {
                csi_entries += r.csi().len();
            }
        }
        csi_entries
    });
}

#[divan::bench]
fn stream_decoder_4k_chunks(bencher: Bencher) {
    bencher.counter(ItemsCount::new(*CSI_RECORDS)).bench(|| {
        let mut decoder = StreamDecoder::new();
        let mut n = 0usize;
        for chunk in black_box(&LOG).chunks(4096) {
            decoder.push(chunk);
            while let Some(e) = decoder.next_event() {
                n += usize::from(matches!(e, Event::Csi(_)));
            }
        }
        decoder.finish();
        while let Some(e) = decoder.next_event() {
            n += usize::from(matches!(e, Event::Csi(_)));
        }
        n
    });
}

/// What `read_bf_file.m` does: framing by the length field alone, the header by hand, the CSI bit
/// by bit into a fresh allocation, then the permutation.
#[divan::bench]
fn reference_literal_port(bencher: Bencher) {
    bencher.counter(ItemsCount::new(*CSI_RECORDS)).bench(|| {
        let bytes: &[u8] = black_box(&LOG);
        let mut pos = 0;
        let mut records = Vec::new();
        while pos + 3 <= bytes.len() {
            let field_len = usize::from(u16::from_be_bytes([bytes[pos], bytes[pos + 1]]));
            let code = bytes[pos + 2];
            let body = &bytes[pos + 3..(pos + 2 + field_len).min(bytes.len())];
            pos += 2 + field_len;
            if code != 0xBB || body.len() < 20 {
                continue;
            }
            let (nrx, ntx, sel) = (body[8], body[9], body[15]);
            let Some(chain_order) = unpack_reference(nrx, ntx, &body[20..]) else {
                continue;
            };
            let perm = [sel & 3, (sel >> 2) & 3, (sel >> 4) & 3];
            let (nrx, ntx) = (usize::from(nrx), usize::from(ntx));
            let mut csi = vec![Complex::new(0i8, 0); chain_order.len()];
            for sc in 0..30 {
                for j in 0..nrx * ntx {
                    let (tx, chain) = (j % ntx, j / ntx);
                    let rx = if nrx > 1 {
                        usize::from(perm[chain])
                    } else {
                        chain
                    };
                    csi[(tx * nrx + rx.min(nrx - 1)) * 30 + sc] = chain_order[sc * nrx * ntx + j];
                }
            }
            records.push(csi);
        }
        records.len()
    });
}

/// Summing every byte of the log: no decoder can beat this by much.
#[divan::bench]
fn baseline_byte_sum(bencher: Bencher) {
    bencher.counter(BytesCount::new(LOG.len())).bench(|| {
        black_box(&LOG)
            .iter()
            .fold(0u64, |acc, &b| acc.wrapping_add(u64::from(b)))
    });
}
