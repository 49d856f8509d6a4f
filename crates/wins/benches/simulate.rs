//! Simulator speed: 60 s of the `paper-circle-3ap` scenario (3 APs × 50 packets/s, 200 Hz IMU,
//! first-order image method) in memory, and the same plus writing the dataset. The reference in
//! the same run is decoding the three `.dat` logs it writes (the project's slice decoder), so the
//! ratio "simulating ÷ reading back" is comparable across noisy machines; the real-time factor is
//! 60 s ÷ the simulate time. The `warehouse` scenario (30 × 12 × 8 m, racks, the AP 6 m up on
//! the end wall, a 5 m circle) is timed too, with the first-order and the second-order image
//! method: it must simulate 60 s in under 1 s on one core (the simulator runs on one thread).
//!
//! Run: `cargo bench -p wins --bench simulate`.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::sync::LazyLock;

use divan::counter::ItemsCount;
use divan::{Bencher, black_box};
use wins::csi::intel5300::{Event, SliceDecoder, encode_record};
use wins::sim::{Scenario, SimOutput, simulate, write_dataset};

fn main() {
    divan::main();
}

static SCENARIO: LazyLock<Scenario> = LazyLock::new(|| {
    let mut s = Scenario::built_in("paper-circle-3ap").expect("built-in scenario");
    s.duration_s = 60.0;
    s
});

/// The warehouse flight, 60 s, with reflections up to `max_order`.
fn warehouse(max_order: u8) -> Scenario {
    let mut s = Scenario::built_in("warehouse").expect("built-in scenario");
    s.duration_s = 60.0;
    s.room.max_order = max_order;
    s
}

static OUTPUT: LazyLock<SimOutput> =
    LazyLock::new(|| simulate(&SCENARIO, &mut |_| {}).expect("valid scenario"));

static LOGS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(|| {
    OUTPUT
        .aps
        .iter()
        .map(|ap| {
            let mut bytes = Vec::new();
            for (_, r) in ap.received() {
                encode_record(r, &mut bytes);
            }
            bytes
        })
        .collect()
});

fn packets() -> u64 {
    OUTPUT.aps.iter().map(|a| a.packets.len() as u64).sum()
}

#[divan::bench(sample_count = 20)]
fn simulate_60s_3ap(b: Bencher) {
    b.counter(ItemsCount::new(packets()))
        .bench(|| simulate(black_box(&SCENARIO), &mut |_| {}));
}

#[divan::bench(sample_count = 10, args = [1, 2])]
fn simulate_60s_warehouse(b: Bencher, max_order: u8) {
    let s = warehouse(max_order);
    b.bench(|| simulate(black_box(&s), &mut |_| {}));
}

#[divan::bench(sample_count = 10)]
fn simulate_and_write_60s_3ap(b: Bencher) {
    let dir = std::env::temp_dir().join(format!("wins-bench-sim-{}", std::process::id()));
    b.counter(ItemsCount::new(packets())).bench(|| {
        let out = simulate(black_box(&SCENARIO), &mut |_| {}).expect("valid");
        write_dataset(&dir, &SCENARIO, &out).expect("writable temp dir")
    });
    let _ = std::fs::remove_dir_all(&dir);
}

/// Reference: decoding the logs the simulation writes.
#[divan::bench(sample_count = 20)]
fn reference_decode_the_3_logs(b: Bencher) {
    let logs = &*LOGS;
    b.counter(ItemsCount::new(packets())).bench(|| {
        logs.iter()
            .map(|l| {
                SliceDecoder::new(black_box(l))
                    .filter(|e| matches!(e, Event::Csi(_)))
                    .count()
            })
            .sum::<usize>()
    });
}
