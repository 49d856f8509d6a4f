//! Fuzzes a whole dataset run, the library path `wins run` takes (`wins::run_dataset`): the input
//! is split into a dataset folder's files, and the run must end without a panic in a refusal that
//! says why or in a run whose counts account for every IMU row, log byte, CSI record and packet
//! (the identity of `crates/wins/tests/it/dataset_fuzz/accounting.rs`, shared with the
//! dataset-level property test).
//!
//! Input: sections, each a little-endian `u32` length then that many bytes (a length past the
//! end takes the rest): `dataset.toml`, `imu.csv`, `ap0.dat`, `truth/poses.tum` (no truth folder
//! when the last section is absent). The manifest names the other files; a seed from a simulated
//! flight names these. Run with `cargo-fuzz` (on stable with `-s none`, as `intel5300_decode`;
//! `cargo +nightly fuzz run dataset_run` with the sanitizers):
//!
//! ```text
//! wins simulate --scenario paper-circle --seed 1 --duration 20 -o /tmp/seed-flight
//! mkdir -p fuzz/corpus/dataset_run
//! python3 -c 'import struct,sys; d=sys.argv[1]; sys.stdout.buffer.write(b"".join(
//!   struct.pack("<I", len(b)) + b for b in (open(d + "/" + n, "rb").read() for n in
//!   ("dataset.toml", "imu.csv", "ap0.dat", "truth/poses.tum"))))' /tmp/seed-flight \
//!   > fuzz/corpus/dataset_run/seed
//! cd fuzz && cargo fuzz run -s none dataset_run -- -max_len=2000000
//! ```
//!
//! Each input is a whole run (about a second for the 20 s seed): a slow target, for long
//! unattended campaigns.
#![no_main]

use std::path::PathBuf;

use libfuzzer_sys::fuzz_target;

#[path = "../../crates/wins/tests/it/dataset_fuzz/accounting.rs"]
mod accounting;

/// Splits off the next length-prefixed section.
fn section<'a>(data: &mut &'a [u8]) -> Option<&'a [u8]> {
    let (len, rest) = data.split_first_chunk::<4>()?;
    let len = (u32::from_le_bytes(*len) as usize).min(rest.len());
    let (section, rest) = rest.split_at(len);
    *data = rest;
    Some(section)
}

/// This process's dataset folder, written afresh for each input.
fn folder() -> PathBuf {
    std::env::temp_dir().join(format!("wins-fuzz-dataset-{}", std::process::id()))
}

fuzz_target!(|data: &[u8]| {
    let mut data = data;
    let (Some(manifest), Some(imu), Some(log)) =
        (section(&mut data), section(&mut data), section(&mut data))
    else {
        return;
    };
    let poses = section(&mut data);
    let dir = folder();
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("creating the dataset folder");
    std::fs::write(dir.join("dataset.toml"), manifest).expect("writing dataset.toml");
    std::fs::write(dir.join("imu.csv"), imu).expect("writing imu.csv");
    std::fs::write(dir.join("ap0.dat"), log).expect("writing ap0.dat");
    if let Some(poses) = poses {
        std::fs::create_dir_all(dir.join("truth")).expect("creating truth/");
        std::fs::write(dir.join("truth").join("poses.tum"), poses).expect("writing poses.tum");
    }
    let outcome = wins::run_dataset(&dir, &wins::Config::default());
    if let Err(why) = accounting::check_outcome(&dir, &outcome) {
        panic!("{why}");
    }
});
