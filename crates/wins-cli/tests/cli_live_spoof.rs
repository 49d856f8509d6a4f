//! `wins live` with a stranger on the network, over real sockets: while `wins replay` plays the
//! flight controller (system 1) and the NIC's logger, a second `wins replay` of another flight
//! plays a stranger 3 s later, sending its IMU from system 7 to the same MAVLink port and its CSI
//! records, for the same AP, on a second TCP connection. None of it may reach the estimate:
//!
//! - every stranger's IMU message is counted (`mavlink_in.other_sender`) and left out: the
//!   recording holds no more IMU samples than the flight controller sent;
//! - the stranger's CSI connection is refused as a second stream of the AP (`csi_second_stream`);
//! - no pose is sent to the stranger (its capture of what came back is empty);
//! - the live ATE is within [`ATE_FACTOR`] of `wins run`'s on the flight alone.

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
use std::time::Duration;

use serde_json::Value;

mod common;
use common::live::{read_tum, simulate_circle, start_live, start_replay};
use common::s;
use common::wins_ok as wins;

/// The flight's length, s.
const FLIGHT_S: &str = "30";
/// The live ATE is at most this many times `wins run`'s.
const ATE_FACTOR: f64 = 2.0;

fn ate(tum: &Path, ds: &Path) -> f64 {
    let json: Value = serde_json::from_str(&wins(&["eval", s(tum), s(ds), "--json"])).unwrap();
    json["ate_rmse_m"].as_f64().unwrap()
}

fn data_lines(path: &Path) -> usize {
    fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .count()
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_stranger_on_both_ports_is_counted_and_moves_no_pose() {
    let dir = common::fresh_dir("live-spoof", "stranger");
    let (ds, other) = (dir.join("ds"), dir.join("other"));
    simulate_circle(&ds, "1", FLIGHT_S);
    simulate_circle(&other, "2", FLIGHT_S);
    wins(&["run", s(&ds), "--out", s(&dir.join("run")), "--no-plots"]);
    let (mut live, csi_port, mav_port) = start_live(&dir, &ds, "2");
    let mut vehicle = start_replay(&dir, &ds, csi_port, mav_port, &[]);
    thread::sleep(Duration::from_secs(3));
    let capture = dir.join("stranger.mavlink");
    let mut stranger = start_replay(
        &dir,
        &other,
        csi_port,
        mav_port,
        &["--system-id", "7", "--capture", s(&capture)],
    );
    vehicle.finish(Duration::from_secs(90));
    stranger.finish(Duration::from_secs(90));
    live.finish(Duration::from_secs(30));

    let stats: Value =
        serde_json::from_str(&fs::read_to_string(dir.join("live/stats.json")).unwrap()).unwrap();
    let other_sender = stats["mavlink_in"]["other_sender"].as_u64().unwrap();
    let second_stream = stats["live"]["csi_second_stream"].as_u64().unwrap();
    let sent_ds = data_lines(&ds.join("imu.csv"));
    let recorded = data_lines(&dir.join("live/recording/imu.csv"));
    let returned = fs::metadata(&capture).map_or(0, |m| m.len());
    let (live_ate, run_ate) = (
        ate(&dir.join("live/trajectory.tum"), &ds),
        ate(&dir.join("run/trajectory.tum"), &ds),
    );
    let poses = read_tum(&dir.join("live/trajectory.tum")).len();
    println!(
        "stranger: {other_sender} IMU messages left out, {second_stream} CSI records refused, \
         {returned} bytes sent to it; recording {recorded} IMU samples of {sent_ds}; \
         {poses} poses, ATE {live_ate:.3} m (wins run {run_ate:.3} m)"
    );
    // The stranger plays 27 s of 200 Hz IMU, and its AP's records at about 50 Hz.
    assert!(other_sender >= 4_000, "{}", stats["mavlink_in"]);
    assert!(second_stream >= 500, "{}", stats["live"]);
    assert_eq!(returned, 0, "poses went to the stranger");
    assert!(
        recorded <= sent_ds,
        "{recorded} IMU samples recorded of {sent_ds}"
    );
    assert!(poses > 300, "{poses} poses");
    assert!(
        live_ate <= ATE_FACTOR * run_ate,
        "ATE {live_ate:.3} m, wins run {run_ate:.3} m"
    );
    fs::remove_dir_all(&dir).unwrap();
}
