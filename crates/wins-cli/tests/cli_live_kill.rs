//! `wins live` killed while it streams, over real sockets: `wins replay` plays a simulated
//! flight (`paper-circle`, seed 1) in real time, and once `wins live` has written poses for
//! [`STREAMING_S`] it is sent SIGKILL (no handler runs, nothing is flushed). What it leaves must
//! be readable as it is (docs/LIVE.md, "Crash-safe outputs"):
//!
//! - `trajectory.tum` ends with a line end and every line is a comment or a whole pose, and
//!   `wins eval` scores it against the flight's truth;
//! - `stats.json` is a whole interim file (`"complete": false`) with the counts so far;
//! - the recording is read by `wins run` (with the run's `config.toml`), and replays to the
//!   trajectory: every pose `wins live` wrote is `wins run`'s, line for line.
//!
//! About 30 s of wall time.

// Tests stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout
)]

use std::fs;
use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use serde_json::Value;

mod common;
use common::live::{Running, run_recording, simulate_circle, start_live, start_replay};
use common::s;
use common::wins_ok as wins;

/// The flight, s: long enough to converge (the chain-offset resolution decides about 20 s in)
/// and stream poses past [`STREAMING_S`]; the kill comes before its end.
const DURATION_S: &str = "30";
/// How long `wins live` writes poses before it is killed, s: past the burst of the frames held
/// until the chain offsets are decided, into the poses streamed one by one.
const STREAMING_S: f64 = 3.0;
/// The first poses must come within this long of the start, s.
const FIRST_POSES_WITHIN_S: u64 = 40;
/// Poses on disk before the kill, at least.
const MIN_POSES: usize = 100;

/// The pose lines of a TUM file that are whole so far (those before its last line end).
fn poses_on_disk(tum: &Path) -> usize {
    let text = fs::read(tum).unwrap_or_default();
    let whole = text
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(&[][..], |k| &text[..=k]);
    whole
        .split(|&b| b == b'\n')
        .filter(|l| !l.is_empty() && l[0] != b'#')
        .count()
}

/// Checks every line of a TUM file (a comment or 8 finite numbers) and its last line end; the
/// pose lines.
fn whole_pose_lines(tum: &Path) -> Vec<String> {
    let text = fs::read_to_string(tum).unwrap();
    assert!(
        text.ends_with('\n'),
        "{} ends mid-line: {:?}",
        tum.display(),
        &text[text.len().saturating_sub(80)..]
    );
    let poses: Vec<String> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(str::to_string)
        .collect();
    for line in &poses {
        let fields: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse::<f64>().unwrap_or(f64::NAN))
            .collect();
        assert!(
            fields.len() == 8 && fields.iter().all(|x| x.is_finite()),
            "not a whole pose in {}: {line:?}",
            tum.display()
        );
    }
    poses
}

/// Waits until `wins live` has had poses on disk for [`STREAMING_S`] and an interim
/// `stats.json`; returns the poses on disk then.
fn wait_for_streaming(out: &Path, live: &Running) -> usize {
    let start = Instant::now();
    let mut first_poses: Option<Instant> = None;
    loop {
        let poses = poses_on_disk(&out.join("trajectory.tum"));
        if poses > 0 && first_poses.is_none() {
            first_poses = Some(Instant::now());
        }
        let streamed = first_poses.is_some_and(|t| t.elapsed().as_secs_f64() >= STREAMING_S);
        if streamed && poses >= MIN_POSES && out.join("stats.json").exists() {
            return poses;
        }
        assert!(
            start.elapsed() < Duration::from_secs(FIRST_POSES_WITHIN_S + STREAMING_S as u64),
            "wins live wrote {poses} poses in {:?}:\n{}",
            start.elapsed(),
            live.output()
        );
        thread::sleep(Duration::from_millis(20));
    }
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_killed_live_run_leaves_whole_lines_interim_stats_and_a_recording_that_replays() {
    let dir = common::fresh_dir("live-kill", "sigkill");
    let ds = simulate_circle(&dir.join("ds"), "1", DURATION_S);
    let (mut live, csi_port, mav_port) = start_live(&dir, &ds, "2");
    let mut replay = start_replay(&dir, &ds, csi_port, mav_port, &[]);
    let out = dir.join("live");
    let seen = wait_for_streaming(&out, &live);
    live.kill();
    replay.kill();

    // The trajectory: whole lines only, and at least what was seen on disk before the kill.
    let tum = out.join("trajectory.tum");
    let poses = whole_pose_lines(&tum);
    assert!(poses.len() >= seen, "{} poses, {seen} seen", poses.len());
    let eval: Value = serde_json::from_str(&wins(&["eval", s(&tum), s(&ds), "--json"])).unwrap();
    let ate = eval["ate_rmse_m"].as_f64().unwrap();
    assert!(ate.is_finite(), "{eval}");

    // The interim statistics.
    let stats: Value =
        serde_json::from_str(&fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["complete"], Value::Bool(false), "{stats}");
    assert!(
        stats["live"]["imu_received"].as_u64().unwrap() > 0,
        "{stats}"
    );

    // The recording replays to the trajectory, as far as the trajectory goes.
    let again = dir.join("again");
    run_recording(&out, &again);
    let replayed = whole_pose_lines(&again.join("trajectory.tum"));
    let differ = poses
        .iter()
        .zip(&replayed)
        .position(|(a, b)| a != b)
        .or((replayed.len() < poses.len()).then_some(replayed.len()));
    assert!(
        differ.is_none(),
        "the recording replays to another trajectory from pose {differ:?} on: compare {} and {}",
        tum.display(),
        again.join("trajectory.tum").display()
    );
    println!(
        "killed after {} poses on disk ({seen} seen before the kill, {} sent by the last \
         stats.json); ATE {ate:.3} m; the recording replays to {} poses, the first {} those of \
         wins live",
        poses.len(),
        stats["poses_sent"],
        replayed.len(),
        poses.len()
    );
    fs::remove_dir_all(&dir).unwrap();
}
