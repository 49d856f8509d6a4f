//! AoA speed per packet, each beside the straightforward reference in the same run (so the ratio
//! is the figure on a noisy shared machine):
//!
//! - `paoa_*`: one packet from its record to its direct path, IMU-guided (±20° window, all ToFs):
//!   calibration, sanitization, smoothing, forward–backward real EVD, Kronecker spectrum, peaks.
//!   Reference: `reference_window_*`, the same window by complex EVD + n × n quadratic form per
//!   grid point (no peak search at all).
//! - `spectrum_*`: the full-range spectrum (±90° at 1°, ToF −200…595 ns at 5 ns: 181 × 160), from
//!   the sanitized CSI. Reference: `reference_full_*`.
//!
//! HT20 is the simulator's default (16 × 30 smoothed matrix); HT40 is SpotFi's 30 × 32.
//! Run: `cargo bench -p wins --bench aoa`.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::sync::LazyLock;

use divan::{Bencher, black_box};
use num_complex::Complex64;
use wins::aoa::reference::reference_spectrum;
use wins::aoa::{AoaConfig, AoaEstimator, AoaPrediction, AoaWindow};
use wins::csi::Bandwidth;
use wins::csi::intel5300::CsiRecord;
use wins::rig::{ArrayGeometry, ChainCalibration};
use wins::sim::{Scenario, simulate};

fn main() {
    divan::main();
}

struct Case {
    estimator: AoaEstimator,
    records: Vec<(CsiRecord, f64)>,
    prepared: Vec<Vec<Complex64>>,
}

fn case(bw: Bandwidth) -> Case {
    let mut s = Scenario::built_in("paper-circle")
        .expect("built-in")
        .airborne();
    s.duration_s = 1.0;
    s.radio.bandwidth = bw;
    let out = simulate(&s, &mut |_| {}).expect("valid");
    let mut cal = ChainCalibration::identity(3);
    cal.phase_offsets_rad = out.chain_phase_offsets_rad.clone();
    let estimator = AoaEstimator::new(
        &AoaConfig::default(),
        ArrayGeometry::default(),
        s.radio.center_freq_hz,
        Some(cal),
    )
    .expect("default config");
    let records: Vec<(CsiRecord, f64)> = out.aps[0]
        .received()
        .map(|(p, r)| (r.clone(), p.truth.aoa_rad))
        .collect();
    let prepared = records
        .iter()
        .map(|(r, _)| estimator.prepare(r).expect("valid"))
        .collect();
    Case {
        estimator,
        records,
        prepared,
    }
}

static HT20: LazyLock<Case> = LazyLock::new(|| case(Bandwidth::Ht20));
static HT40: LazyLock<Case> = LazyLock::new(|| case(Bandwidth::Ht40));

/// The case and its bandwidth for a bench argument.
fn pick(bw: &str) -> (&'static Case, Bandwidth) {
    if bw == "ht40" {
        (&HT40, Bandwidth::Ht40)
    } else {
        (&HT20, Bandwidth::Ht20)
    }
}

fn prediction(truth_rad: f64) -> AoaPrediction {
    AoaPrediction {
        previous_aoa_rad: truth_rad + 3f64.to_radians(),
        rotation_part_rad: 0.0,
        translation_part_rad: 0.0,
        in_front_after: true,
    }
}

#[divan::bench(args = ["ht20", "ht40"])]
fn paoa(b: Bencher, bw: &str) {
    let (c, _) = pick(bw);
    let mut i = 0;
    b.bench_local(|| {
        let (record, truth) = &c.records[i % c.records.len()];
        i += 1;
        c.estimator.paoa(black_box(record), &prediction(*truth))
    });
}

#[divan::bench(args = ["ht20", "ht40"], sample_count = 20)]
fn reference_window(b: Bencher, bw: &str) {
    let (c, band) = pick(bw);
    let music = c.estimator.music(band);
    let mut i = 0;
    b.bench_local(|| {
        let k = i % c.records.len();
        i += 1;
        let window = AoaWindow::around(
            prediction(c.records[k].1).predicted_aoa_rad(),
            20f64.to_radians(),
        );
        reference_spectrum(music, black_box(&c.prepared[k]), window)
    });
}

#[divan::bench(args = ["ht20", "ht40"])]
fn spectrum(b: Bencher, bw: &str) {
    let (c, band) = pick(bw);
    let music = c.estimator.music(band);
    let mut i = 0;
    b.bench_local(|| {
        let k = i % c.records.len();
        i += 1;
        let subspace = music.subspace(black_box(&c.prepared[k])).expect("valid");
        music.spectrum(&subspace, AoaWindow::FULL)
    });
}

#[divan::bench(args = ["ht20", "ht40"], sample_count = 10)]
fn reference_full(b: Bencher, bw: &str) {
    let (c, band) = pick(bw);
    let music = c.estimator.music(band);
    let mut i = 0;
    b.bench_local(|| {
        let k = i % c.records.len();
        i += 1;
        reference_spectrum(music, black_box(&c.prepared[k]), AoaWindow::FULL)
    });
}

/// Stage breakdown: calibration + sanitization of one record.
#[divan::bench(args = ["ht20", "ht40"])]
fn stage_prepare(b: Bencher, bw: &str) {
    let (c, _) = pick(bw);
    let mut i = 0;
    b.bench_local(|| {
        i += 1;
        c.estimator
            .prepare(black_box(&c.records[i % c.records.len()].0))
    });
}

/// Stage breakdown: smoothing and the signal subspace (forward–backward real EVD).
#[divan::bench(args = ["ht20", "ht40"])]
fn stage_subspace(b: Bencher, bw: &str) {
    let (c, band) = pick(bw);
    let music = c.estimator.music(band);
    let mut i = 0;
    b.bench_local(|| {
        i += 1;
        music.subspace(black_box(&c.prepared[i % c.prepared.len()]))
    });
}
