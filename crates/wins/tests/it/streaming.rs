//! `wins run`'s path reads its inputs as it consumes them and writes its rows as it produces
//! them: the same inputs in the same order as the dataset in memory, the same files, and a
//! reader whose held records do not grow with the flight's length.

use std::path::{Path, PathBuf};

use wins::dataset::Dataset;
use wins::dataset::stream::{DatasetEvent, DatasetStream};
use wins::sim::{Scenario, simulate, write_dataset};
use wins::{Config, RunOptions, run_dataset_into, run_dataset_with};

fn flight(name: &str, scenario: &str, seconds: f64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-stream-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::built_in(scenario).unwrap();
    s.duration_s = seconds;
    write_dataset(&dir, &s, &simulate(&s, &mut |_| {}).unwrap()).unwrap();
    dir
}

/// Every event of the stream, and the most records it held at once.
fn stream_all(dir: &Path) -> (Vec<DatasetEvent>, usize) {
    let stream = DatasetStream::open(dir).unwrap();
    let mut events = stream.events(true).unwrap();
    let (mut out, mut most) = (Vec::new(), 0);
    while let Some(e) = events.next_event().unwrap() {
        most = most.max(events.held());
        out.push(e);
    }
    (out, most)
}

#[test]
fn the_stream_gives_the_loaded_inputs_in_time_order_and_the_same_report() {
    let dir = flight("order", "paper-circle-3ap", 20.0);
    let data = Dataset::load(&dir).unwrap();
    let stream = DatasetStream::open(&dir).unwrap();
    assert_eq!(stream.inputs, data.inputs);
    assert_eq!(stream.baro, data.baro);
    let (events, _) = stream_all(&dir);
    let mut want: Vec<(wins::time::Timestamp, u8, usize, usize)> = Vec::new();
    want.extend(data.imu.iter().enumerate().map(|(i, s)| (s.t, 2, 0, i)));
    want.extend(data.baro.iter().enumerate().map(|(i, b)| (b.t, 1, 0, i)));
    for (l, ap) in data.aps.iter().enumerate() {
        want.extend(ap.packets.iter().enumerate().map(|(i, p)| (p.t, 0, l, i)));
    }
    want.sort_unstable();
    assert_eq!(events.len(), want.len());
    for (got, &(_, kind, l, i)) in events.iter().zip(&want) {
        let expected = match kind {
            0 => DatasetEvent::Csi {
                ap: l,
                packet: Box::new(data.aps[l].packets[i].clone()),
            },
            1 => DatasetEvent::Baro(data.baro[i]),
            _ => DatasetEvent::Imu(data.imu[i]),
        };
        assert_eq!(got, &expected);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_records_held_do_not_grow_with_the_flight() {
    let short = flight("short", "paper-circle-3ap", 20.0);
    let long = flight("long", "paper-circle-3ap", 60.0);
    let (short_events, short_most) = stream_all(&short);
    let (long_events, long_most) = stream_all(&long);
    assert!(long_events.len() > 2 * short_events.len());
    // Three APs at 50 packets/s: a record waits 0.1 s at most, so a handful per AP.
    assert!(long_most <= 3 * 8, "{long_most}");
    assert!(long_most <= short_most + 3, "{short_most} then {long_most}");
    let _ = std::fs::remove_dir_all(&short);
    let _ = std::fs::remove_dir_all(&long);
}

#[test]
fn the_scoring_holds_no_trajectory_however_long_the_flight() {
    let held = |seconds: f64| {
        let dir = flight(&format!("held-{seconds}"), "paper-circle", seconds);
        let (config, options) = (Config::default(), RunOptions::default());
        let run = run_dataset_into(&dir, &config, &options, &dir.join("out")).unwrap();
        assert!(run.metrics.is_some(), "{:?}", run.evaluation);
        let s = run.spooled.clone().unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        (s.frames_converged, s.scoring_poses_held)
    };
    let (short_frames, short_held) = held(30.0);
    let (long_frames, long_held) = held(90.0);
    assert!(
        long_frames > 2 * short_frames,
        "{short_frames} {long_frames}"
    );
    // The truth's poses of the last 20 ms (200 Hz) and the estimate's, and the join's three.
    assert!(long_held <= 12, "{long_held}");
    assert!(long_held <= short_held + 1, "{short_held} then {long_held}");
}

#[test]
fn a_spooled_run_writes_the_same_files_and_statistics_as_one_in_memory() {
    let dir = flight("spool", "paper-circle", 30.0);
    let config = Config::default();
    let options = RunOptions::default();
    let memory = dir.join("out-memory");
    let spooled = dir.join("out-spooled");
    let a = run_dataset_with(&dir, &config, &options).unwrap();
    a.write(&memory).unwrap();
    let b = run_dataset_into(&dir, &config, &options, &spooled).unwrap();
    assert!(b.frames.is_empty() && b.packets.is_empty());
    assert_eq!(a.evaluation, b.evaluation);
    let written = b.write(&spooled).unwrap();
    assert_eq!(a.metrics.is_some(), b.metrics.is_some());
    let names = |files: &[PathBuf]| -> Vec<String> {
        files
            .iter()
            .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
            .collect()
    };
    assert_eq!(names(&written), names(&a.write(&memory).unwrap()));
    for name in [
        "trajectory.tum",
        "trajectory_all.tum",
        "covariance.csv",
        "aoa.csv",
        "aps.csv",
    ] {
        let (x, y) = (
            std::fs::read(memory.join(name)).unwrap(),
            std::fs::read(spooled.join(name)).unwrap(),
        );
        assert!(x == y, "{name} differs");
    }
    let metrics = |dir: &Path| {
        let text = std::fs::read_to_string(dir.join("metrics.json")).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v.as_object_mut().unwrap().remove("realtime_factor");
        v
    };
    assert_eq!(metrics(&memory), metrics(&spooled));
    let strip = |run: &wins::RunOutput| {
        let mut v = serde_json::to_value(run.run_stats()).unwrap();
        for key in ["wall_s", "realtime_factor", "timing"] {
            v.as_object_mut().unwrap().remove(key);
        }
        v
    };
    assert_eq!(strip(&a), strip(&b));
    // No spool file is left behind.
    let left: Vec<_> = std::fs::read_dir(&spooled)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(".wins-spool-"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn on_damaged_inputs_the_stream_reports_and_keeps_what_the_loader_does() {
    let dir = flight("damaged", "paper-circle", 20.0);
    // The log written twice, then a stretch of garbage; an IMU row back in time.
    let log = dir.join("ap0.dat");
    let bytes = std::fs::read(&log).unwrap();
    std::fs::write(&log, [bytes.clone(), bytes, vec![0x5A; 5000]].concat()).unwrap();
    let imu = dir.join("imu.csv");
    let text = std::fs::read_to_string(&imu).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.swap(500, 501);
    std::fs::write(&imu, lines.join("\n") + "\n").unwrap();
    let data = Dataset::load(&dir).unwrap();
    let stream = DatasetStream::open(&dir).unwrap();
    assert_eq!(stream.inputs, data.inputs);
    assert!(data.inputs.aps[0].repeated > 0 && data.inputs.imu.time_not_increasing == 1);
    let (events, _) = stream_all(&dir);
    let packets: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            DatasetEvent::Csi { packet, .. } => Some(packet.as_ref().clone()),
            _ => None,
        })
        .collect();
    assert_eq!(packets, data.aps[0].packets);
    let imu_kept = events
        .iter()
        .filter(|e| matches!(e, DatasetEvent::Imu(_)))
        .count();
    assert_eq!(imu_kept, data.imu.len());
    let _ = std::fs::remove_dir_all(&dir);
}
