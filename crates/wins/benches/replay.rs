//! Replay speed of the whole pipeline (target: ≥ 100× real time on a 60 s, 3-AP flight, one
//! core): `paper-circle-3ap` simulated once, written as a dataset and loaded, then replayed from
//! memory (PAoA per packet, the estimator per frame, the pose at every IMU sample), with the
//! default settings. Two flights: as the scenario flies it (3 s on the ground, a take-off, the
//! circle: the static start), and airborne from t = 0 (no rest: the start is found from the
//! motion alone, with more attempts). The real-time factor is 60 s ÷ the median. Reference in the
//! same run, so the ratio is comparable across noisy machines: simulating the same flight in
//! memory (`benches/simulate.rs`).
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
use wins::run::replay::{replay, rig_of};
use wins::sim::{Scenario, simulate, write_dataset};

fn main() {
    divan::main();
}

fn scenario(airborne: bool) -> Scenario {
    let s = Scenario::built_in("paper-circle-3ap").expect("built-in scenario");
    let mut s = if airborne { s.airborne() } else { s };
    s.duration_s = 60.0;
    s
}

static SCENARIO: LazyLock<Scenario> = LazyLock::new(|| scenario(false));
static AIRBORNE: LazyLock<Scenario> = LazyLock::new(|| scenario(true));

fn dataset(scenario: &Scenario, name: &str) -> Dataset {
    let dir = std::env::temp_dir().join(format!("wins-bench-{name}-{}", std::process::id()));
    let out = simulate(scenario, &mut |_| {}).expect("valid scenario");
    write_dataset(&dir, scenario, &out).expect("writable temp dir");
    let data = Dataset::load(&dir).expect("the dataset just written");
    let _ = std::fs::remove_dir_all(&dir);
    data
}

static DATASET: LazyLock<Dataset> = LazyLock::new(|| dataset(&SCENARIO, "replay"));
static AIRBORNE_DATASET: LazyLock<Dataset> =
    LazyLock::new(|| dataset(&AIRBORNE, "replay-airborne"));

fn packets(data: &Dataset) -> u64 {
    data.aps.iter().map(|a| a.packets.len() as u64).sum()
}

fn bench_replay(b: Bencher, data: &Dataset) {
    let rig = rig_of(data, None, None).expect("the dataset has its IMU noise");
    b.counter(ItemsCount::new(packets(data))).bench(|| {
        let run = replay(black_box(data), rig.clone(), &Config::default()).expect("replayable");
        assert!(run.converged_at.is_some(), "the bench flight must converge");
        run
    });
}

/// The flight as flown: rest, take-off, circle.
#[divan::bench(sample_count = 10)]
fn replay_60s_3ap(b: Bencher) {
    bench_replay(b, &DATASET);
}

/// The same circle airborne from t = 0.
#[divan::bench(sample_count = 5)]
fn replay_60s_3ap_airborne(b: Bencher) {
    bench_replay(b, &AIRBORNE_DATASET);
}

/// Reference: simulating the flight as flown in memory.
#[divan::bench(sample_count = 10)]
fn reference_simulate_60s_3ap(b: Bencher) {
    b.counter(ItemsCount::new(packets(&DATASET)))
        .bench(|| simulate(black_box(&SCENARIO), &mut |_| {}));
}
