//! The WINS pipeline on simulated datasets: a dataset written to disk, run through the library's
//! front door (`wins::run_dataset`) and scored against its truth. The accuracy tests are
//! regression bounds on the median over several seeds, about 20 % above what the estimator gives
//! today (docs/RESULTS.md), so a 20 % regression fails them and an improvement never does.

use std::path::PathBuf;

use wins::Config;
use wins::csi::intel5300::CsiRecord;
use wins::dataset::Dataset;
use wins::dataset::truth::Truth;
use wins::eval::{EvalOptions, Metrics};
use wins::figures::RunFigures;
use wins::fusion::choice::EstimatorKind;
use wins::imu::ImuSample;
use wins::pipeline::PacketStatus;
use wins::run::output::{COVARIANCE_FILE, METRICS_FILE, TRAJECTORY_FILE};
use wins::run::replay::{RunOutput, replay, rig_of};
use wins::sim::{Scenario, simulate, write_dataset};

/// A fresh folder for `name`, its own even when two tests fly the same scenario and seed at once,
/// removed with everything in it when the value is dropped (at the end of the test, or when it
/// fails).
pub(crate) fn temp_dir(name: &str) -> TempDir {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("wins-it-{}-{k}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    TempDir(d)
}

/// A test's scratch folder ([`temp_dir`]): removed on drop.
pub(crate) struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl std::ops::Deref for TempDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<std::path::Path> for TempDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

/// Simulates `name` for `seconds`, writes it, loads it back; `spoil` may damage the loaded data.
fn dataset(
    name: &str,
    seconds: f64,
    dir: &PathBuf,
    spoil: impl Fn(&mut Dataset),
) -> (Dataset, Truth) {
    let mut s = Scenario::built_in(name).unwrap().airborne();
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

pub(crate) fn check_accounting(run: &RunOutput) {
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

/// paper-circle, default seed, 40 s, through the front door from the files on disk: accounting,
/// the run's files, the metrics' keys, the figures' data, a truth of poses only.
#[test]
fn paper_circle_from_disk_end_to_end() {
    let dir = temp_dir("pipeline-circle");
    let (data, truth) = dataset("paper-circle", 40.0, &dir, |_| {});
    let run = wins::run_dataset(&dir, &Config::default()).unwrap();
    check_accounting(&run);
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);
    let m = run.metrics.clone().expect("scored against truth/");
    print("paper-circle 40 s", &run, &m);
    assert_eq!(
        run.stats.per_ap[0].packets,
        data.aps[0].packets.len() as u64
    );
    // The same run as the push API driven by hand.
    let by_hand = self::run(&data);
    assert_eq!(by_hand.frames, run.frames);
    let by_hand_m = by_hand.score(&truth, &EvalOptions::default()).unwrap();
    assert_eq!(by_hand_m.position_error_mean_m, m.position_error_mean_m);

    let out = dir.join("run");
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
    // The covariance beside each pose: same times, 21 finite cells, positive position variances.
    let cov = std::fs::read_to_string(out.join(COVARIANCE_FILE)).unwrap();
    let mut rows = cov.lines();
    assert!(
        rows.next()
            .unwrap()
            .starts_with("t_s,c_x_x,c_x_y,c_x_z,c_x_rx,")
    );
    let times: Vec<&str> = tum.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows.clone().count(), times.len());
    for (row, pose) in rows.zip(&times) {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), 22, "{row}");
        assert_eq!(cells[0], pose.split(' ').next().unwrap());
        let v: Vec<f64> = cells[1..].iter().map(|c| c.parse().unwrap()).collect();
        assert!(v.iter().all(|x| x.is_finite()), "{row}");
        // c_x_x, c_y_y, c_z_z in the upper triangle's row-major order.
        assert!(v[0] > 0.0 && v[6] > 0.0 && v[11] > 0.0, "{row}");
    }

    // The figures' data, from the files written: every converged pose, the AP with its
    // ellipse, every fed packet, the convergence, and the error the metrics have.
    let fig = RunFigures::from_files(
        &out.join(TRAJECTORY_FILE),
        Some(&dir),
        Some(&truth),
        &EvalOptions::default(),
    )
    .unwrap();
    let finite = |p: &[(f64, f64)]| {
        p.iter()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .count()
    };
    assert_eq!(finite(&fig.track_xy), run.converged_frames().count());
    assert_eq!(fig.aps.len(), 1);
    assert!(fig.aps[0].ellipse_2sigma.len() > 10);
    assert_eq!(fig.aoa.len(), 1);
    assert_eq!(fig.aoa[0].fed.len() as u64, run.stats.per_ap[0].fed);
    assert!(!fig.aoa[0].truth.is_empty() && !fig.baro_height.is_empty());
    assert!(
        fig.events
            .first()
            .is_some_and(|e| (e.t_s - m.convergence_time_s).abs() < 0.1)
    );
    let t = fig.truth.as_ref().expect("the truth's figures");
    let norms: Vec<f64> = (0..t.error_m[0].len())
        .map(|i| {
            (0..3)
                .map(|k| t.error_m[k][i].1.powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .filter(|e| e.is_finite())
        .collect();
    let error_mean = norms.iter().sum::<f64>() / norms.len() as f64;
    assert!(
        (error_mean - m.position_error_mean_m).abs() < 1e-6,
        "{error_mean}"
    );
    assert_eq!(finite(&fig.sigma_m[0]), run.converged_frames().count());

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
    // A truth folder that cannot be read fails the evaluation, not the run: the estimate is
    // there, and the reason names the file.
    std::fs::remove_file(dir.join("truth").join("poses.tum")).unwrap();
    assert!(Truth::load(&dir).is_err(), "the poses are required");
    let unscored = wins::run_dataset(&dir, &Config::default()).unwrap();
    assert!(!unscored.frames.is_empty() && unscored.metrics.is_none());
    match &unscored.evaluation {
        wins::run::replay::Evaluation::Failed(why) => {
            assert!(why.contains("poses.tum"), "{why}");
        }
        other => panic!("{other:?}"),
    }
    assert!(
        unscored
            .warnings
            .iter()
            .any(|w| w.starts_with("evaluation failed")),
        "{:?}",
        unscored.warnings
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The paper's estimator (the airborne regression bounds below are its).
fn paper() -> Config {
    Config {
        estimator: EstimatorKind::Paper,
        ..Config::default()
    }
}

/// The metrics of `name` flown for `seconds` with each seed (airborne from t = 0, or as built in:
/// a rest on the ground, a take-off, a landing), run from disk through the front door with
/// `config`.
pub(crate) fn metrics_over_seeds(
    name: &str,
    seconds: f64,
    seeds: &[u64],
    airborne: bool,
    config: &Config,
) -> Vec<Metrics> {
    seeds
        .iter()
        .map(|&seed| {
            let dir = temp_dir(&format!("{name}-{seed}"));
            let mut s = Scenario::built_in(name).unwrap();
            if airborne {
                s = s.airborne();
            }
            s.duration_s = seconds;
            s.seed = seed;
            let out = simulate(&s, &mut |_| {}).unwrap();
            write_dataset(&dir, &s, &out).unwrap();
            let run = wins::run_dataset(&dir, config).unwrap();
            check_accounting(&run);
            let _ = std::fs::remove_dir_all(&dir);
            let m = run
                .metrics
                .clone()
                .unwrap_or_else(|| panic!("{name} seed {seed}: {:?}", run.warnings));
            print(&format!("{name} {seconds} s seed {seed}"), &run, &m);
            m
        })
        .collect()
}

/// The median of `f` over the runs.
pub(crate) fn median(runs: &[Metrics], f: impl Fn(&Metrics) -> f64) -> f64 {
    let mut v: Vec<f64> = runs.iter().map(f).collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The largest of `f` over the runs.
pub(crate) fn worst(runs: &[Metrics], f: impl Fn(&Metrics) -> f64) -> f64 {
    runs.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
}

/// The paper's estimator on the paper's flight, airborne, 40 s, seeds 1–5, with the built-ins'
/// rotor vibration and the Intel 5300's measured response. Today: converged 14.1–14.6 s,
/// position mean 0.39–1.43 m on four seeds (median of the five 0.78) and 4.95 m on seed 1,
/// whose AP is placed 5.6 m off; attitude median 6.5°, AP median 1.15 m, AoA median 1.7°. (On
/// an ideal receiver: position median 0.62 m, worst 0.98 m, AP median 0.75 m.) Bounds: medians
/// +20 %, the worst run +50 %.
#[test]
fn paper_circle_accuracy_over_five_seeds() {
    let runs = metrics_over_seeds("paper-circle", 40.0, &[1, 2, 3, 4, 5], true, &paper());
    let converged = median(&runs, |m| m.convergence_time_s);
    let position = median(&runs, |m| m.position_error_mean_m);
    let attitude = median(&runs, |m| m.attitude_error_mean_deg);
    let ap = median(&runs, |m| m.ap_position_error_m["ap0"]);
    let aoa = median(&runs, |m| m.aoa_error_median_deg.unwrap_or(f64::INFINITY));
    assert!(converged <= 17.6, "median convergence {converged} s");
    assert!(position <= 0.93, "median position {position} m");
    assert!(attitude <= 7.8, "median attitude {attitude}°");
    assert!(ap <= 1.38, "median AP {ap} m");
    assert!(aoa <= 2.06, "median AoA {aoa}°");
    let worst_position = worst(&runs, |m| m.position_error_mean_m);
    assert!(worst_position <= 7.4, "worst position {worst_position} m");
}

/// The paper's estimator, three APs on one wall at three heights, airborne, 30 s, seeds 1–3.
/// Today: converged 9.8–10.4 s (median
/// 10.3), position mean 0.46–0.66 m (median 0.51), AoA median 2.0°. Bounds: medians +20 %, no
/// restart.
#[test]
fn three_aps_accuracy_over_three_seeds() {
    let runs = metrics_over_seeds("paper-circle-3ap", 30.0, &[1, 2, 3], true, &paper());
    let converged = median(&runs, |m| m.convergence_time_s);
    let position = median(&runs, |m| m.position_error_mean_m);
    let aoa = median(&runs, |m| m.aoa_error_median_deg.unwrap_or(f64::INFINITY));
    assert!(converged <= 12.3, "median convergence {converged} s");
    assert!(position <= 0.62, "median position {position} m");
    assert!(aoa <= 2.4, "median AoA {aoa}°");
}

/// The paper's estimator, a board in front of the AP, airborne, 30 s, seeds 1–3: the AoA stage and the convergence time are bounded
/// (AoA median 2.1–2.4°, converged 16.3–17.6 s today); the position is not, because on 30 s the
/// estimate diverges after convergence on some seeds (docs/RESULTS.md): what is asserted is that
/// the run finishes, finite, with every packet accounted for. With the Intel 5300's measured
/// response the AoA median is 2.9–4.4° (median 3.1°; 2.1–2.4° on an ideal receiver); the bound is
/// +20 %.
#[test]
fn obstacle_flight_finishes_accounted_over_three_seeds() {
    let runs = metrics_over_seeds("paper-circle-obstacle", 30.0, &[1, 2, 3], true, &paper());
    let converged = median(&runs, |m| m.convergence_time_s);
    let aoa = median(&runs, |m| m.aoa_error_median_deg.unwrap_or(f64::INFINITY));
    assert!(converged <= 20.0, "median convergence {converged} s");
    assert!(aoa <= 3.8, "median AoA {aoa}°");
    assert!(runs.iter().all(|m| m.position_error_mean_m.is_finite()));
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
            let record = p.record.intel5300().unwrap();
            let mut header = record.header;
            header.nrx = 2;
            header.ntx = 1;
            let csi = &record.csi()[..header.num_entries()];
            p.record = CsiRecord::new(header, csi, record.timestamp)
                .unwrap()
                .into();
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

/// The default (nonlinear) estimator on the paper's flight as flown, from the ground (3 s at rest,
/// a take-off, the circle, a landing), with the built-ins' rotor vibration, 60 s, seeds 1–5.
/// Today (docs/ESTIMATOR.md): every seed converges (median 10.6 s; the take-off starts at 3 s);
/// position mean 0.27–0.32 m on four seeds (median 0.28) and 1.50 m on seed 2, whose AP is
/// placed 5.6 m off (a wrong placement, docs/ESTIMATOR.md); attitude median 1.9°, AP median
/// 0.39 m (0.32 m before the rest test held the means to the rest's own, which finds the
/// motion 5 ms sooner on seed 1 and moves what the rest averages: docs/ESTIMATOR.md, "A biased
/// IMU's rest"); jumps over 0.3 m 1–5 per run (18 on seed 2); the runs' mean position NEES
/// 1.1–1.9 (27 on seed 2). With the Intel 5300's measured response (the simulator's default since):
/// position mean 0.30–0.43 m (median 0.35), AP 0.19–0.99 m (median 0.54), attitude median 2.5°,
/// every seed converged by 10.7 s, median jumps 4. Bounds: medians +20 %, the worst run +50 %, the median run's
/// jumps +20 %, and
/// the median run's NEES in [1, the upper end of one run's honest 95 % band] (honest or a little
/// cautious on the typical run).
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn nonlinear_paper_circle_from_the_ground_over_five_seeds() {
    let runs = metrics_over_seeds(
        "paper-circle",
        60.0,
        &[1, 2, 3, 4, 5],
        false,
        &Config::default(),
    );
    let converged = median(&runs, |m| m.convergence_time_s);
    let position = median(&runs, |m| m.position_error_mean_m);
    let attitude = median(&runs, |m| m.attitude_error_mean_deg);
    let ap = median(&runs, |m| m.ap_position_error_m["ap0"]);
    assert!(converged <= 12.7, "median convergence {converged} s");
    assert!(position <= 0.42, "median position {position} m");
    assert!(attitude <= 3.24, "median attitude {attitude}°");
    assert!(ap <= 0.65, "median AP {ap} m");
    let worst_position = worst(&runs, |m| m.position_error_mean_m);
    assert!(worst_position <= 0.65, "worst position {worst_position} m");
    let jumps = median(&runs, |m| m.jumps as f64);
    assert!(jumps <= 4.8, "median jumps {jumps}");
    let nees: Vec<f64> = runs.iter().filter_map(|m| m.position_nees_mean).collect();
    assert_eq!(nees.len(), runs.len(), "every run reports a covariance");
    let typical = median(&runs, |m| m.position_nees_mean.unwrap_or(f64::INFINITY));
    let (_, hi) = wins::eval::mean_nees_band(1);
    assert!(
        (1.0..=hi).contains(&typical),
        "median NEES {typical} outside [1, {hi}]: {nees:?}"
    );
}

/// The default estimator, three APs at three heights, from the ground, 40 s, seeds 1–3, with the
/// built-ins' rotor vibration and the Intel 5300's measured response. On an ideal receiver every
/// seed converged (position mean 0.41–1.94 m, median 0.61); with the response seed 1 does not
/// converge within 60 s (docs/ESTIMATOR.md, "What does not work yet"). Bounds: at least two of
/// the three converge with the first AP within 2 m, and their median position +20 %.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn nonlinear_three_aps_from_the_ground_over_three_seeds() {
    let mut converged = Vec::new();
    for seed in [1, 2, 3] {
        let dir = temp_dir(&format!("paper-circle-3ap-{seed}"));
        let mut s = Scenario::built_in("paper-circle-3ap").unwrap();
        s.duration_s = 40.0;
        s.seed = seed;
        let out = simulate(&s, &mut |_| {}).unwrap();
        write_dataset(&dir, &s, &out).unwrap();
        let run = wins::run_dataset(&dir, &Config::default()).unwrap();
        check_accounting(&run);
        let _ = std::fs::remove_dir_all(&dir);
        match &run.metrics {
            Some(m) => {
                print(&format!("paper-circle-3ap 40 s seed {seed}"), &run, m);
                converged.push(m.clone());
            }
            None => println!("paper-circle-3ap 40 s seed {seed}: {:?}", run.warnings),
        }
    }
    assert!(converged.len() >= 2, "{} of 3 converged", converged.len());
    let position = median(&converged, |m| m.position_error_mean_m);
    assert!(position <= 0.73, "median position {position} m");
    assert!(
        converged
            .iter()
            .all(|m| m.ap_position_error_m.get("ap0").is_some_and(|e| *e < 2.0))
    );
}
