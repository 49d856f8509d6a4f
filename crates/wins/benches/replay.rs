//! Replay speed of the whole pipeline (target: ≥ 100× real time on a 60 s, 3-AP flight, one
//! core): `paper-circle-3ap` simulated once, written as a dataset and loaded, then replayed from
//! memory (PAoA per packet, the sliding window per frame, the pose at every IMU sample). The
//! real-time factor is 60 s ÷ the median. Reference in the same run, so the ratio is comparable
//! across noisy machines: simulating the same flight in memory (`benches/simulate.rs`).
//!
//! Run: `cargo bench -p wins --bench replay`.

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
use wins::Config;
use wins::dataset::Dataset;
use wins::pipeline::replay::{replay, rig_of};
use wins::sim::{Scenario, simulate, write_dataset};

fn main() {
    divan::main();
}

static SCENARIO: LazyLock<Scenario> = LazyLock::new(|| {
    let mut s = Scenario::built_in("paper-circle-3ap")
        .expect("built-in scenario")
        .airborne();
    s.duration_s = 60.0;
    s
});

static DATASET: LazyLock<Dataset> = LazyLock::new(|| {
    let dir = std::env::temp_dir().join(format!("wins-bench-replay-{}", std::process::id()));
    let out = simulate(&SCENARIO, &mut |_| {}).expect("valid scenario");
    write_dataset(&dir, &SCENARIO, &out).expect("writable temp dir");
    let data = Dataset::load(&dir).expect("the dataset just written");
    let _ = std::fs::remove_dir_all(&dir);
    data
});

fn packets() -> u64 {
    DATASET.aps.iter().map(|a| a.packets.len() as u64).sum()
}

#[divan::bench(sample_count = 10)]
fn replay_60s_3ap(b: Bencher) {
    let data = &*DATASET;
    let rig = rig_of(data, None, None).expect("the dataset has its IMU noise");
    b.counter(ItemsCount::new(packets())).bench(|| {
        let run = replay(black_box(data), rig.clone(), &Config::default()).expect("replayable");
        assert!(run.converged_at.is_some(), "the bench flight must converge");
        run
    });
}

/// Reference: simulating the same flight in memory.
#[divan::bench(sample_count = 10)]
fn reference_simulate_60s_3ap(b: Bencher) {
    b.counter(ItemsCount::new(packets()))
        .bench(|| simulate(black_box(&SCENARIO), &mut |_| {}));
}
