//! The WINS pipeline on simulated datasets (issue 6): a dataset written to disk, loaded, replayed
//! through the push API and scored against its truth.

use std::path::PathBuf;

use wins::Config;
use wins::csi::intel5300::CsiRecord;
use wins::dataset::Dataset;
use wins::dataset::truth::Truth;
use wins::eval::{EvalOptions, Metrics};
use wins::imu::ImuSample;
use wins::pipeline::PacketStatus;
use wins::pipeline::output::{METRICS_FILE, TRAJECTORY_FILE};
use wins::pipeline::replay::{RunOutput, replay, rig_of};
use wins::sim::{Scenario, simulate, write_dataset};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wins-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Simulates `name` for `seconds`, writes it, loads it back; `spoil` may damage the loaded data.
fn dataset(
    name: &str,
    seconds: f64,
    dir: &PathBuf,
    spoil: impl Fn(&mut Dataset),
) -> (Dataset, Truth) {
    let mut s = Scenario::built_in(name).unwrap();
    s.duration_s = seconds;
    let out = simulate(&s, &mut |_| {}).unwrap();
    write_dataset(dir, &s, &out).unwrap();
    let mut data = Dataset::load(dir).unwrap();
    spoil(&mut data);
    (data, Truth::load(dir).unwrap())
}

fn run(data: &Dataset) -> RunOutput {
    let rig = rig_of(data, None, None).unwrap();
    replay(data, rig, &Config::default()).unwrap()
}

fn check_accounting(run: &RunOutput) {
    for s in &run.stats.per_ap {
        assert_eq!(s.fed + s.acquisition + s.dropped(), s.packets, "{s:?}");
    }
    assert_eq!(
        run.packets.len() as u64,
        run.stats.per_ap.iter().map(|s| s.packets).sum::<u64>()
    );
    for f in &run.frames {
        assert!(f.p_b_in_w.iter().all(|x| x.is_finite()), "NaN at {:?}", f.t);
    }
    // Every fed packet says how good its peak was.
    for r in run.packets.iter().filter(|r| r.status == PacketStatus::Fed) {
        assert!(
            r.residual.is_some_and(|v| (0.0..=1.0).contains(&v)),
            "{r:?}"
        );
        assert!(r.candidates.is_some_and(|c| c >= 1), "{r:?}");
    }
}

fn print(label: &str, run: &RunOutput, m: &Metrics) {
    println!(
        "{label}: converged {:.2} s, position mean {:.3} m (ATE {:.3} m), attitude {:.2}°, APs {:?}, \
         AoA median {:.2}°, {} fed / {} dropped, {:.0}× real time (AoA {:.3} s, estimator {:.3} s)",
        m.convergence_time_s,
        m.position_error_mean_m,
        m.ate_rmse_m,
        m.attitude_error_mean_deg,
        m.ap_position_error_m,
        m.aoa_error_median_deg.unwrap_or(f64::NAN),
        run.stats.fed(),
        run.stats.dropped(),
        run.realtime_factor(),
        run.timing.aoa_s,
        run.timing.estimator_s,
    );
}

/// paper-circle, default seed, 40 s, from the files on disk. Asserted: accounting, outputs, the
/// AoA stage, convergence; the accuracy bounds are regression bounds around what this session
/// measured (0.3 m class), NOT issue 6's targets, which are not met on every seed (README).
#[test]
fn paper_circle_from_disk_end_to_end() {
    let dir = temp_dir("pipeline-circle");
    let (data, truth) = dataset("paper-circle", 40.0, &dir, |_| {});
    let run = run(&data);
    check_accounting(&run);
    let m = run.score(&truth, &EvalOptions::default()).unwrap();
    print("paper-circle 40 s", &run, &m);
    let aoa = m.aoa_error_median_deg.unwrap();
    assert!(aoa < 2.5, "{aoa}");
    assert!(m.convergence_time_s < 20.0, "{}", m.convergence_time_s);
    assert!(m.position_error_mean_m < 1.0, "{}", m.position_error_mean_m);
    assert!(
        m.ap_position_error_m["ap0"] < 1.0,
        "{:?}",
        m.ap_position_error_m
    );
    assert!(run.stats.fed() > 1500, "{}", run.stats.fed());

    let out = dir.join("run");
    let mut run = run;
    run.metrics = Some(m.clone());
    let written = run.write(&out).unwrap();
    assert!(written.iter().all(|p| p.is_file()));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join(METRICS_FILE)).unwrap()).unwrap();
    for key in [
        "position_error_mean_m",
        "position_error_rmse_m",
        "convergence_time_s",
        "attitude_error_mean_deg",
        "ap_position_error_m",
        "aoa_error_median_deg",
        "packets_used",
        "packets_dropped",
        "realtime_factor",
    ] {
        assert!(!json[key].is_null(), "{key} missing");
    }
    let tum = std::fs::read_to_string(out.join(TRAJECTORY_FILE)).unwrap();
    assert_eq!(
        tum.lines().filter(|l| !l.starts_with('#')).count(),
        run.converged_frames().count()
    );

    // The figures' data: every converged pose, the AP, every fed packet paired with the truth.
    let fig = run.figures(&truth, &m, &EvalOptions::default()).unwrap();
    assert_eq!(fig.estimate_xy.len(), run.converged_frames().count());
    assert_eq!(fig.truth_xy.len(), truth.poses.len());
    assert_eq!((fig.truth_aps_xy.len(), fig.estimated_aps_xy.len()), (1, 1));
    assert_eq!(fig.aoa.len(), 1);
    assert_eq!(fig.aoa[0].measured.len(), run.aoa_vs_truth(&truth).len());
    assert!(
        fig.converged_s
            .is_some_and(|t| (t - m.convergence_time_s).abs() < 0.1)
    );
    let error_mean =
        fig.position_error.iter().map(|p| p.1).sum::<f64>() / fig.position_error.len() as f64;
    assert!((error_mean - m.position_error_mean_m).abs() < 1e-9);

    // A truth of poses only (motion capture): it loads and scores the trajectory, no AP or AoA.
    for entry in std::fs::read_dir(dir.join("truth")).unwrap() {
        let path = entry.unwrap().path();
        if path.file_name().is_some_and(|n| n != "poses.tum") {
            std::fs::remove_file(path).unwrap();
        }
    }
    let poses_only = Truth::load(&dir).unwrap();
    assert!(poses_only.info.is_none() && poses_only.aps.is_empty());
    let m2 = run.score(&poses_only, &EvalOptions::default()).unwrap();
    assert_eq!(m2.position_error_mean_m, m.position_error_mean_m);
    assert!(m2.ap_position_error_m.is_empty());
    assert!(
        m2.aoa_error_median_deg.is_none(),
        "{:?}",
        m2.aoa_error_median_deg
    );
    std::fs::remove_file(dir.join("truth").join("poses.tum")).unwrap();
    assert!(Truth::load(&dir).is_err(), "the poses are required");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Three APs and an obstacle finish with finite output and every packet accounted for.
#[test]
fn three_aps_and_an_obstacle_finish() {
    // Before the track filter and the convergence test both diverged (kilometres): the middle
    // AP's track random-walked onto a reflection and the startup solution collapsed an AP
    // onto the trajectory. Bounds guard that (issue 6's 0.15 m with three APs is NOT met).
    for (name, seconds, max_converged_s, max_error_m) in [
        ("paper-circle-3ap", 30.0, 12.0, 1.0),
        ("paper-circle-obstacle", 30.0, 20.0, 2.0),
    ] {
        let dir = temp_dir(name);
        let (data, truth) = dataset(name, seconds, &dir, |_| {});
        let run = run(&data);
        check_accounting(&run);
        assert_eq!(run.stats.per_ap.len(), data.aps.len());
        let m = run.score(&truth, &EvalOptions::default()).unwrap();
        print(name, &run, &m);
        assert_eq!(run.wins.restarts, 0, "{name}");
        assert!(
            run.converged_at
                .is_some_and(|t| t.as_secs_f64() <= max_converged_s),
            "{name}: {:?}",
            run.converged_at
        );
        assert!(
            m.position_error_mean_m < max_error_m,
            "{name}: {}",
            m.position_error_mean_m
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Bad input is counted, never a panic: a NaN IMU sample, a packet of an AP the rig does not
/// know, packets with two chains and a time outage of the CSI.
#[test]
fn bad_input_is_counted() {
    let dir = temp_dir("pipeline-bad");
    let (data, _) = dataset("paper-circle", 8.0, &dir, |d| {
        let nan = ImuSample {
            gyro_rad_s: nalgebra::Vector3::new(f64::NAN, 0.0, 0.0),
            ..d.imu[300]
        };
        d.imu[300] = nan;
        for p in d.aps[0].packets.iter_mut().skip(100).take(5) {
            let mut header = p.record.header;
            header.nrx = 2;
            header.ntx = 1;
            let csi = &p.record.csi()[..header.num_entries()];
            p.record = CsiRecord::new(header, csi, p.record.timestamp).unwrap();
        }
        let (from, to) = (3_000_000_000, 5_000_000_000);
        d.aps[0].packets.retain(|p| p.t.0 < from || p.t.0 > to);
    });
    let run = run(&data);
    check_accounting(&run);
    assert_eq!(run.imu_refused, 1);
    assert_eq!(run.stats.per_ap[0].skipped, 5, "{:?}", run.stats.per_ap[0]);
    let skipped: Vec<_> = run
        .packets
        .iter()
        .filter(|r| r.status == PacketStatus::Skipped)
        .collect();
    assert!(skipped.iter().all(|r| !r.reason.is_empty()));
    assert_eq!(run.stats.per_ap[0].log_skips, 0);

    // A log cut in the middle of a record: the reader's skip reaches the run's statistics.
    let log = dir.join(format!("{}.dat", data.aps[0].name));
    let bytes = std::fs::read(&log).unwrap();
    std::fs::write(&log, &bytes[..bytes.len() / 2 + 7]).unwrap();
    let cut = Dataset::load(&dir).unwrap();
    let cut_run = self::run(&cut);
    check_accounting(&cut_run);
    let s = &cut_run.stats.per_ap[0];
    assert!(s.log_skips >= 1 && s.log_skipped_bytes > 0, "{s:?}");
    assert!(s.packets < data.aps[0].packets.len() as u64, "{s:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
