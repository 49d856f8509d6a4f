//! Settings that would exhaust memory are refused by the `wins` binary with a failing exit status
//! and a message that states the limit.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::path::PathBuf;

mod common;
use common::{s, stderr, wins};

fn scratch(name: &str) -> PathBuf {
    common::fresh_dir("bounds", name)
}

#[test]
fn config_check_refuses_a_grid_too_fine_and_states_the_limit() {
    let dir = scratch("grid");
    let file = dir.join("fine.toml");
    std::fs::write(
        &file,
        "[aoa.music]\naoa_step_deg = 0.05\ntof_step_s = 5e-10\n",
    )
    .unwrap();
    let out = wins(&["config", "--check", s(&file)]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("aoa.music.aoa_step_deg"), "{err}");
    assert!(
        err.contains("grid points") && err.contains("at most 1e6"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_refuses_an_hour_at_ten_kilohertz_and_states_the_limit() {
    let dir = scratch("sim");
    let out = wins(&["simulate", "--print-scenario", "hover"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let imu = text.find("[imu]").unwrap();
    let rate = imu + text[imu..].find("rate_hz = 200.0").unwrap();
    let spoiled = format!(
        "{}rate_hz = 10000.0{}",
        &text[..rate],
        &text[rate + "rate_hz = 200.0".len()..]
    );
    let file = dir.join("fast.toml");
    std::fs::write(&file, spoiled).unwrap();
    let data = dir.join("data");
    let out = wins(&[
        "simulate",
        "--scenario-file",
        s(&file),
        "--duration",
        "3600",
        "-o",
        s(&data),
    ]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("imu.rate_hz"), "{err}");
    assert!(err.contains("3.6e7 IMU samples; at most 1.44e6"), "{err}");
    assert!(!data.join("imu.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_refuses_a_log_that_is_a_device_at_once() {
    let dir = scratch("devzero");
    let data = dir.join("data");
    let out = wins(&[
        "simulate",
        "--scenario",
        "hover",
        "--airborne",
        "--duration",
        "2",
        "-o",
        s(&data),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let manifest = data.join("dataset.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let at = text.find("log = \"").unwrap();
    let end = at + text[at + 7..].find('"').unwrap() + 8;
    let spoiled = format!("{}log = \"/dev/zero\"{}", &text[..at], &text[end..]);
    std::fs::write(&manifest, spoiled).unwrap();
    let started = std::time::Instant::now();
    let out = wins(&["run", s(&data), "--out", s(&dir.join("run")), "--no-plots"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("/dev/zero") && err.contains("not a regular file"),
        "{err}"
    );
    assert!(
        started.elapsed().as_secs() < 10,
        "took {:?}",
        started.elapsed()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
