//! `wins live` through the faults of a field flight, over real sockets: `wins replay --fault`
//! plays a simulated flight (`paper-circle`, seed 1) in real time with one fault in it, 22 s in
//! (after the chain offsets are decided), and `wins live` must fly through it:
//!
//! - a lone misdated message (an IMU sample 4.5 s ahead, a CSI record's NIC time 1000 s ahead,
//!   64 KiB of garbage in the CSI stream) is refused and counted, and the poses never stop for
//!   more than [`MAX_POSE_GAP_S`];
//! - the IMU stopping, or the flight controller rebooting (its clock restarting at 0), is a gap
//!   in the IMU that the estimator bridges as `wins run` does: the live poses resume no later
//!   than `wins run`'s on the same dataset with the same gap cut out (plus [`RESUME_SLACK_S`]).
//!
//! In each, the ATE of `wins live`'s trajectory is within [`ATE_FACTOR`] of the reference's
//! (`wins run` on the clean flight, or on the flight with the same gap). Each test lasts the
//! flight's length plus a few seconds of wall time; they run in parallel on free ports.

// Tests stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout
)]

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::Value;

mod common;
use common::live::{Trajectory, read_tum, simulate_circle, start_live, start_replay};
use common::s;
use common::wins_ok as wins;

/// When the fault comes, s into the flight.
const FAULT_AT_S: f64 = 22.0;
/// A flight whose fault is a lone message: long enough to converge and fly on after it.
const SHORT_S: f64 = 30.0;
/// A flight with a gap in the IMU: long enough for the estimate to restart after it.
const LONG_S: f64 = 45.0;
/// After a lone misdated message, the poses stop for no longer than this, s.
const MAX_POSE_GAP_S: f64 = 5.0;
/// After a gap in the IMU, the live poses resume at most this long after `wins run`'s, s.
const RESUME_SLACK_S: f64 = 3.0;
/// The live ATE is at most this many times the reference's.
const ATE_FACTOR: f64 = 2.0;
/// `wins live` stops this long after its inputs stop, s.
const IDLE_EXIT_S: &str = "2";

/// A copy of the dataset `ds` without its IMU samples in `(from_s, to_s)`.
fn without_imu(ds: &Path, from_s: f64, to_s: f64) -> PathBuf {
    let out = ds.with_file_name("ds_gap");
    copy_dir(ds, &out);
    let text = fs::read_to_string(ds.join("imu.csv")).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.starts_with('#') || {
                let t_s = l.split(',').next().unwrap().parse::<i64>().unwrap() as f64 * 1e-9;
                t_s <= from_s || t_s >= to_s
            }
        })
        .collect();
    fs::write(out.join("imu.csv"), kept.join("\n") + "\n").unwrap();
    out
}

fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for entry in fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// The longest gap between two IMU samples of `wins live`'s recording in `dir`: (the sample
/// before, the sample after), s.
fn recorded_imu_gap(dir: &Path) -> (f64, f64) {
    let text = fs::read_to_string(dir.join("live/recording/imu.csv")).unwrap();
    let t: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .map(|l| l.split(',').next().unwrap().parse::<i64>().unwrap() as f64 * 1e-9)
        .collect();
    t.windows(2)
        .map(|w| (w[0], w[1]))
        .max_by(|a, b| (a.1 - a.0).total_cmp(&(b.1 - b.0)))
        .unwrap()
}

/// `wins run` on `ds` into `out`: its trajectory.
fn batch(ds: &Path, out: &Path) -> PathBuf {
    wins(&["run", s(ds), "--out", s(out), "--no-plots"]);
    out.join("trajectory.tum")
}

/// ATE RMSE of a TUM file against the truth of `ds`, by `wins eval`, m.
fn ate(tum: &Path, ds: &Path) -> f64 {
    let json: Value = serde_json::from_str(&wins(&["eval", s(tum), s(ds), "--json"])).unwrap();
    json["ate_rmse_m"].as_f64().unwrap()
}

/// `wins live` fed by `wins replay --fault FAULT` with the flight `ds`: its stats.json and
/// what it printed.
fn fly_live(dir: &Path, ds: &Path, fault: &str) -> (Value, String) {
    let (mut live, csi_port, mav_port) = start_live(dir, ds, IDLE_EXIT_S);
    let mut replay = start_replay(dir, ds, csi_port, mav_port, &["--fault", fault]);
    replay.finish(Duration::from_secs(120));
    let said = live.finish(Duration::from_secs(30));
    for line in said
        .lines()
        .filter(|l| l.starts_with("t ") && !l.contains('|'))
    {
        println!("wins live said: {line}");
    }
    let stats =
        serde_json::from_str(&fs::read_to_string(dir.join("live/stats.json")).unwrap()).unwrap();
    (stats, said)
}

/// Times of a trajectory's poses, s.
fn times(poses: &Trajectory) -> Vec<f64> {
    poses.iter().map(|p| p.0 as f64 * 1e-6).collect()
}

/// The longest stretch without a pose from `from_s` to the flight's end `end_s`, s.
fn longest_gap_after(t: &[f64], from_s: f64, end_s: f64) -> f64 {
    let mut last = from_s;
    let mut worst = 0.0f64;
    for &x in t.iter().filter(|&&x| x > from_s) {
        worst = worst.max(x - last);
        last = x;
    }
    worst.max(end_s - last)
}

/// The first pose after `from_s`, s.
fn first_after(t: &[f64], from_s: f64) -> Option<f64> {
    t.iter().copied().find(|&x| x > from_s)
}

fn count(stats: &Value, key: &str) -> u64 {
    stats["live"][key]
        .as_u64()
        .unwrap_or_else(|| panic!("{key} missing in {stats}"))
}

/// Readings refused by the flight controller link's decoder for `why`.
fn refused(stats: &Value, why: &str) -> u64 {
    stats["mavlink_in"]["refused"][why]
        .as_u64()
        .unwrap_or_else(|| panic!("{why} missing in {stats}"))
}

/// A lone misdated message: refused (`outliers` counted once, no re-lock), the poses go on,
/// and the ATE stays within [`ATE_FACTOR`] of the clean `wins run`'s.
fn lone_fault(name: &str, fault: &str, outliers_key: &str) -> (Value, String) {
    let dir = common::fresh_dir("live-faults", name);
    let ds = simulate_circle(&dir.join("ds"), "1", &SHORT_S.to_string());
    let clean = batch(&ds, &dir.join("run"));
    let (stats, said) = fly_live(&dir, &ds, fault);
    let live_tum = dir.join("live/trajectory.tum");
    let t = times(&read_tum(&live_tum));
    let gap = longest_gap_after(&t, FAULT_AT_S, SHORT_S);
    let (live_ate, clean_ate) = (ate(&live_tum, &ds), ate(&clean, &ds));
    println!(
        "{fault}: {} outliers, re-locks fc {} nic {}; longest stretch without a pose after it \
         {gap:.2} s; ATE {live_ate:.3} m (clean wins run {clean_ate:.3} m)",
        count(&stats, outliers_key),
        count(&stats, "fc_clock_relocks"),
        count(&stats, "nic_clock_relocks"),
    );
    assert!(
        count(&stats, "fc_clock_relocks") == 0 && count(&stats, "nic_clock_relocks") == 0,
        "{}",
        stats["live"]
    );
    assert!(
        gap <= MAX_POSE_GAP_S,
        "no pose for {gap:.2} s after {fault}"
    );
    assert!(
        live_ate <= ATE_FACTOR * clean_ate,
        "ATE {live_ate:.3} m, clean {clean_ate:.3} m"
    );
    fs::remove_dir_all(&dir).unwrap();
    (stats, said)
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn one_imu_sample_4_5_s_ahead_is_refused_and_the_poses_go_on() {
    let (stats, _) = lone_fault("imu-ahead", "imu-shift@22:4.5", "fc_clock_outliers");
    assert_eq!(count(&stats, "fc_clock_outliers"), 1, "{}", stats["live"]);
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn one_csi_record_1000_s_ahead_is_refused_and_the_poses_go_on() {
    let (stats, _) = lone_fault("csi-ahead", "csi-shift@22:1000", "nic_clock_outliers");
    assert_eq!(count(&stats, "nic_clock_outliers"), 1, "{}", stats["live"]);
    assert_eq!(count(&stats, "csi_far_from_present"), 0);
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn garbage_in_the_csi_stream_is_skipped_and_the_nic_clock_holds() {
    let (stats, said) = lone_fault("csi-garbage", "csi-garbage@22:65536", "nic_clock_outliers");
    assert!(
        count(&stats, "csi_skipped_bytes") >= 60_000,
        "{}",
        stats["live"]
    );
    // The drift in the last status line that shows the NIC's clock ("nic0 +3600.001 s +0 ppm").
    let drift: f64 = said
        .lines()
        .rev()
        .find_map(|l| l.split(" nic0 ").nth(1))
        .and_then(|rest| rest.split_whitespace().nth(2))
        .unwrap_or_else(|| panic!("no status line with the NIC's clock:\n{said}"))
        .parse()
        .unwrap();
    assert!(drift.abs() < 50.0, "NIC drift {drift} ppm at the end");
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn corrupted_mavlink_messages_are_counted_as_garbage_and_bad_crcs_and_the_poses_go_on() {
    // 200 IMU messages (1 s), each first sent as garbage and a bad CRC in a datagram of its own.
    let (stats, said) = lone_fault("mav-corrupt", "mav-corrupt@22:200", "fc_clock_outliers");
    let link = &stats["mavlink_link"];
    let n = |key: &str| {
        link[key]
            .as_u64()
            .unwrap_or_else(|| panic!("{key} missing in {link}"))
    };
    // Each corrupted message fails its CRC (and a magic byte inside it may look like one more
    // frame that fails too).
    assert!((200..=400).contains(&n("bad_crc")), "{link}");
    assert_eq!(n("garbage_datagrams"), 200, "{link}");
    // Every byte of those datagrams, and no other, is garbage: the 16 bytes before each
    // message and the corrupted message's own.
    let garbage = n("garbage_bytes");
    assert!(garbage % 200 == 0 && garbage > 200 * (16 + 12), "{link}");
    assert!(said.contains("| MAVLink garbage "), "{said}");
}

/// A gap in the IMU from [`FAULT_AT_S`] for `gap_s` (a silence, or a reboot): the live poses
/// resume no later than `wins run`'s on the flight with the gap `wins live` saw (from its
/// recording), with an ATE within [`ATE_FACTOR`] of its; returns the stats and whether the
/// reference resumed.
fn imu_gap(name: &str, fault: &str, gap_s: f64) -> (Value, bool) {
    let dir = common::fresh_dir("live-faults", name);
    let ds = simulate_circle(&dir.join("ds"), "1", &LONG_S.to_string());
    let clean = batch(&ds, &dir.join("run_clean"));
    let (stats, _) = fly_live(&dir, &ds, fault);
    let (from, to) = recorded_imu_gap(&dir);
    assert!(
        (from - FAULT_AT_S).abs() < 0.1 && (to - from - gap_s).abs() < 0.5,
        "the recording's IMU gap is {from:.3}–{to:.3} s"
    );
    let gapped = without_imu(&ds, from, to);
    let reference = batch(&gapped, &dir.join("run"));
    let live_tum = dir.join("live/trajectory.tum");
    let (t_live, t_ref) = (times(&read_tum(&live_tum)), times(&read_tum(&reference)));
    let (live_back, ref_back) = (first_after(&t_live, to), first_after(&t_ref, to));
    let (live_ate, ref_ate, clean_ate) =
        (ate(&live_tum, &ds), ate(&reference, &ds), ate(&clean, &ds));
    println!(
        "{fault}: IMU gap {from:.3}–{to:.3} s; poses back at {live_back:?} s (wins run with \
         that gap: {ref_back:?} s); ATE {live_ate:.3} m (wins run with the gap {ref_ate:.3} m, \
         clean {clean_ate:.3} m); notices {}",
        stats["live"]["notices"]
    );
    let notices = stats["live"]["notices"].as_array().unwrap();
    assert!(
        notices
            .iter()
            .any(|n| n.as_str().unwrap().contains("without IMU")),
        "the gap was not said: {notices:?}"
    );
    assert_eq!(count(&stats, "fc_clock_outliers"), 0, "{}", stats["live"]);
    match (ref_back, live_back) {
        (Some(r), Some(l)) => assert!(
            l <= r + RESUME_SLACK_S && *t_live.last().unwrap() >= LONG_S - 1.0,
            "live poses back at {l:.2} s, wins run's at {r:.2} s"
        ),
        (Some(r), None) => panic!("no live pose after the gap; wins run's came back at {r:.2} s"),
        (None, _) => {}
    }
    assert!(
        live_ate <= ATE_FACTOR * ref_ate,
        "ATE {live_ate:.3} m, wins run with the gap {ref_ate:.3} m"
    );
    fs::remove_dir_all(&dir).unwrap();
    (stats, ref_back.is_some())
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn the_imu_stopping_5_s_is_a_gap_bridged_as_wins_run_bridges_it() {
    let (stats, resumed) = imu_gap("imu-silence", "imu-silence@22:5", 5.0);
    assert!(resumed, "wins run did not resume after a 5 s IMU gap");
    assert_eq!(count(&stats, "fc_clock_relocks"), 0, "{}", stats["live"]);
}

/// After 12 s the estimate does not come back, in `wins run` either (the hole recovery's
/// limit); the IMU is taken again at once, never locked out.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn the_imu_stopping_12_s_is_taken_back_at_once_as_wins_run_takes_the_gap() {
    let (stats, _) = imu_gap("imu-silence-12", "imu-silence@22:12", 12.0);
    assert_eq!(count(&stats, "fc_clock_relocks"), 0, "{}", stats["live"]);
    assert!(
        count(&stats, "imu_clock_locking") <= 20,
        "{}",
        stats["live"]
    );
}

/// A second of NaN readings (a failing driver) is refused, counted, and taken as the 1 s gap
/// it leaves, as `wins run` takes it: not a restart of the clock.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_second_of_nan_imu_is_a_short_gap_bridged_as_wins_run_bridges_it() {
    let (stats, resumed) = imu_gap("imu-nan", "imu-nan@22:1", 1.0);
    assert!(resumed, "wins run did not resume after a 1 s IMU gap");
    assert!(
        refused(&stats, "non_finite") >= 190,
        "{}",
        stats["mavlink_in"]
    );
    assert_eq!(count(&stats, "fc_clock_relocks"), 0, "{}", stats["live"]);
}

/// A second beyond the rig's range (39 g, 45 rad/s against 16 g, 2000 °/s) is refused and
/// counted as `wins run` refuses it, so the recording replays to the same poses.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_second_beyond_the_imu_range_is_refused_as_wins_run_refuses_it() {
    let (stats, resumed) = imu_gap("imu-saturate", "imu-saturate@22:1", 1.0);
    assert!(resumed, "wins run did not resume after a 1 s IMU gap");
    assert!(
        refused(&stats, "out_of_range") >= 190,
        "{}",
        stats["mavlink_in"]
    );
    assert_eq!(count(&stats, "fc_clock_relocks"), 0, "{}", stats["live"]);
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn the_flight_controller_rebooting_relocks_its_clock_and_the_poses_resume() {
    let (stats, resumed) = imu_gap("fc-reboot", "fc-reboot@22:2", 2.0);
    assert!(resumed, "wins run did not resume after a 2 s IMU gap");
    assert_eq!(count(&stats, "fc_clock_relocks"), 1, "{}", stats["live"]);
    // Only the start's lock and the re-lock's few samples were left out.
    assert!(
        count(&stats, "imu_clock_locking") <= 30,
        "{}",
        stats["live"]
    );
}
