//! The `wins` binary end to end: exit codes and what it prints.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::path::PathBuf;
use std::process::Output;

mod common;

/// Runs `wins` at the repository root (the paths below are relative to it).
fn wins(args: &[&str]) -> Output {
    common::wins_in(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../.."),
        args,
    )
}

const MIXED: &str = "data/intel5300/csikit_log.all_csi.6.7.6.dat";

#[test]
fn csi_info_reports_records_shapes_and_rates() {
    let out = wins(&["csi", "info", MIXED, "data/intel5300/csikit_example.dat"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("29 CSI, 0 non-CSI"), "{text}");
    assert!(text.contains("3x1: 10, 3x2: 9, 3x3: 10"), "{text}");
    assert!(text.contains("HT20 MCS 16 (0x0110): 10"), "{text}");
    assert!(text.contains("26 CSI"), "{text}");

    let out = wins(&["csi", "info", "--json", MIXED]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["summary"]["csi_records"], 29);
    assert_eq!(v["summary"]["lost_bytes"], 0);
}

#[test]
fn csi_export_jsonl_has_one_line_per_record_and_csv_one_row_per_entry() {
    let out = wins(&["csi", "export", MIXED, "--format", "jsonl"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert_eq!(text.lines().count(), 29);
    let first: serde_json::Value =
        serde_json::from_str(text.lines().next().expect("a line")).expect("json");
    assert_eq!(first["nrx"], 3);
    assert_eq!(first["perm"], serde_json::json!([3, 2, 1]));

    let out = wins(&["csi", "export", MIXED, "--format", "csv"]);
    let text = String::from_utf8(out.stdout).expect("utf-8");
    // 10·3 + 9·6 + 10·9 entries of 30 subcarriers, plus the header row.
    assert_eq!(text.lines().count(), 1 + (10 * 3 + 9 * 6 + 10 * 9) * 30);
}

#[test]
fn corrupt_and_missing_input() {
    let dir = std::env::temp_dir().join(format!("wins-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut bytes = std::fs::read(root.join(MIXED)).expect("sample");
    bytes.truncate(bytes.len() - 100);
    let bad = dir.join("cut.dat");
    std::fs::write(&bad, &bytes).expect("write");
    let bad = bad.to_str().expect("utf-8 path");

    let out = wins(&["csi", "export", bad]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("28 CSI records written"), "{err}");
    assert!(err.contains("truncated tail"), "{err}");

    let out = wins(&["csi", "info", bad]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("lost") && text.contains("truncated tail"),
        "{text}"
    );

    let out = wins(&["csi", "info", "no/such/file.dat"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot read no/such/file.dat"), "{err}");

    // A damaged capture of another format is read as that format and refused with why, and no
    // output is made for it.
    let mut pcap = vec![0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0];
    pcap.extend((0..4000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8));
    let pcap_path = dir.join("nexmon.pcap");
    std::fs::write(&pcap_path, &pcap).expect("write");
    let exported = dir.join("nexmon.jsonl");
    let pcap_arg = pcap_path.to_str().expect("utf-8 path");
    let out = wins(&[
        "csi",
        "export",
        pcap_arg,
        "-o",
        exported.to_str().expect("utf-8"),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("link type"), "{err}");
    assert!(!exported.exists());
    let out = wins(&["csi", "info", pcap_arg]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("link type"), "{err}");

    // A Nexmon capture is summarized: two packets (cores 0 and 1) of one frame.
    let nexmon = dir.join("two.pcap");
    std::fs::write(&nexmon, nexmon_capture()).expect("write");
    let out = wins(&["csi", "info", nexmon.to_str().expect("utf-8")]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("2 packets, 1 frames"), "{text}");
    assert!(
        text.contains("0,1: 1") && text.contains("channel     6: 2"),
        "{text}"
    );

    // A FeitCSI file is summarized: three HT20 records of 2 chains × 56 subcarriers.
    let mut feit = Vec::new();
    for _ in 0..3 {
        let mut header = vec![0u8; 272];
        header[..4].copy_from_slice(&448u32.to_le_bytes());
        header[46] = 2;
        header[47] = 1;
        header[52..56].copy_from_slice(&56u32.to_le_bytes());
        header[92..96].copy_from_slice(&(2u32 << 8 | 3 << 14 | 7).to_le_bytes());
        feit.extend(header);
        feit.extend([1u8, 0, 255, 255].repeat(112));
    }
    let feit_path = dir.join("ax210.csi");
    std::fs::write(&feit_path, feit).expect("write");
    let out = wins(&["csi", "info", feit_path.to_str().expect("utf-8")]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("FeitCSI") && text.contains("2x1x56: 3"),
        "{text}"
    );
    assert!(text.contains("HT 20 MHz: 3"), "{text}");

    // `wins csi export` writes its packets: one CSV row per value (3 × 52 × 2 × 1 + header).
    let csv = dir.join("ax210.csv");
    let out = wins(&[
        "csi",
        "export",
        feit_path.to_str().expect("utf-8"),
        "--format",
        "csv",
        "-o",
        csv.to_str().expect("utf-8"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).expect("read");
    assert_eq!(text.lines().count(), 1 + 3 * 52 * 2, "{text}");
    assert!(
        text.lines()
            .nth(1)
            .is_some_and(|l| l.ends_with(",-28,0,0,1,-1")),
        "{text}"
    );
    // `wins aoa` takes it: the file has no carrier, so one must be given.
    let feit_arg = feit_path.to_str().expect("utf-8");
    let out = wins(&["aoa", feit_arg]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("does not say its carrier"), "{err}");
    let out = wins(&["aoa", feit_arg, "--channel", "9"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.lines().count(), 4, "{text}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("FeitCSI") && err.contains("2 antennas"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A little-endian pcap of two Nexmon packets (old header, cores 0 and 1, channel 6, 20 MHz).
fn nexmon_capture() -> Vec<u8> {
    let mut out = vec![0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0];
    out.extend([0u8; 8]);
    out.extend(65535u32.to_le_bytes());
    out.extend(1u32.to_le_bytes());
    for core in [0u16, 1] {
        let mut payload = 0x1111_1111u32.to_le_bytes().to_vec();
        payload.extend([0x6c, 0xb7, 0x49, 5, 0x3e, 0xf4]);
        payload.extend((3586u16 << 4).to_le_bytes());
        payload.extend((core << 8).to_le_bytes());
        payload.extend(0x1006u16.to_le_bytes());
        payload.extend(0x006au16.to_le_bytes());
        payload.extend((0..64u32).flat_map(|k| (k << 18 | 5).to_le_bytes()));
        let mut frame = vec![0u8; 12];
        frame.extend([0x08, 0x00, 0x45, 0, 0, 0, 0, 0, 0, 0, 64, 17]);
        frame.extend([0u8; 10]);
        frame.extend([0x15, 0x7c, 0x15, 0x7c]);
        frame.extend((8 + payload.len() as u16).to_be_bytes());
        frame.extend([0, 0]);
        frame.extend(payload);
        for v in [
            1_611_581_394,
            149_783 + u32::from(core),
            frame.len() as u32,
            frame.len() as u32,
        ] {
            out.extend(v.to_le_bytes());
        }
        out.extend(frame);
    }
    out
}

#[test]
fn simulate_lists_prints_and_runs_scenarios() {
    let out = wins(&["simulate", "--list"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    for name in [
        "paper-circle ",
        "paper-circle-3ap",
        "paper-circle-obstacle",
        "figure8-yaw",
        "hover",
    ] {
        assert!(text.contains(name), "{text}");
    }
    // Every name stands apart from its description (the longest one included).
    for line in text.lines().filter(|l| l.starts_with("paper-circle")) {
        let name = line.split_whitespace().next().unwrap_or_default();
        assert!(
            [
                "paper-circle",
                "paper-circle-restart",
                "paper-circle-uncalibrated",
                "paper-circle-3ap",
                "paper-circle-obstacle"
            ]
            .contains(&name),
            "{line}"
        );
    }

    let printed = wins(&["simulate", "--print-scenario", "hover"]);
    assert!(printed.status.success());
    let toml = String::from_utf8(printed.stdout).expect("utf-8");
    assert!(toml.contains("kind = \"hover\""), "{toml}");

    // Edit the printed scenario and run it: a 3 s hover with another seed, airborne from t = 0
    // (without its `[phases]` table: the built-in one spends 13 s on the ground, taking off and
    // landing).
    let dir = std::env::temp_dir().join(format!("wins-cli-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("short.toml");
    let start = toml.find("[phases]").expect("a [phases] table");
    let end = start + toml[start..].find("\n\n").expect("a blank line after it");
    let airborne = format!("{}{}", &toml[..start], &toml[end..]);
    std::fs::write(
        &file,
        airborne.replace("duration_s = 30.0", "duration_s = 3.0"),
    )
    .unwrap();
    let out_dir = dir.join("out");
    let out = wins(&[
        "simulate",
        "--scenario-file",
        file.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--seed",
        "9",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("hover (seed 9): 3.0 s of flight"), "{text}");
    assert!(text.contains("packets received"), "{text}");
    for f in [
        "dataset.toml",
        "imu.csv",
        "ap0.dat",
        "truth/poses.tum",
        "truth/packets_ap0.csv",
    ] {
        assert!(out_dir.join(f).is_file(), "{f}");
    }
    // The written log is an ordinary Intel 5300 log.
    let info = wins(&["csi", "info", out_dir.join("ap0.dat").to_str().unwrap()]);
    assert!(info.status.success());
    assert!(String::from_utf8_lossy(&info.stdout).contains("3x1:"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// 8 s of `paper-circle`, airborne, simulated into `dir/d`.
fn simulated_8_s(dir: &std::path::Path) -> PathBuf {
    let data = dir.join("d");
    let out = wins(&[
        "simulate",
        "--scenario",
        "paper-circle",
        "--airborne",
        "--duration",
        "8",
        "--out",
        data.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    data
}

/// A calibration the dataset names but does not hold is a warning, and the run goes on without
/// one; `--no-calibration` does not read the file at all (a broken one included).
#[test]
fn a_missing_calibration_is_a_warning_and_no_calibration_reads_none() {
    let dir = std::env::temp_dir().join(format!("wins-cli-nocal-{}", std::process::id()));
    let data = simulated_8_s(&dir);
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    std::fs::remove_file(data.join("calibration.toml")).unwrap();
    let out = wins(&["run", &s(&data), "--out", &s(&dir.join("r1"))]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr
            .contains("names the chain calibration calibration.toml, which is not in the dataset"),
        "{stderr}"
    );
    std::fs::write(data.join("calibration.toml"), "not a calibration").unwrap();
    let out = wins(&["run", &s(&data), "--out", &s(&dir.join("r2"))]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("calibration.toml"));
    let out = wins(&[
        "run",
        &s(&data),
        "--out",
        &s(&dir.join("r3")),
        "--no-calibration",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("which is not in the dataset"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A clock offset that puts no packet inside the IMU's span is refused with the offset that
/// makes the recordings start together, and that offset runs.
#[test]
fn a_wrong_clock_offset_gets_the_one_that_fits() {
    let dir = std::env::temp_dir().join(format!("wins-cli-clock-{}", std::process::id()));
    let data = simulated_8_s(&dir);
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let manifest = data.join("dataset.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("imu_minus_nic_ns"))
        .unwrap()
        .to_string();
    let truth: i64 = line.rsplit(' ').next().unwrap().parse().unwrap();
    std::fs::write(&manifest, text.replace(&line, "imu_minus_nic_ns = 0")).unwrap();
    let out = wins(&["run", &s(&data), "--out", &s(&dir.join("r1"))]);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success());
    let proposed: i64 = stderr
        .split("ap0: imu_minus_nic_ns = ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{stderr}"));
    // The first packet comes a few milliseconds after the first IMU sample.
    assert!(
        (proposed - truth).abs() < 50_000_000,
        "{proposed} against {truth}"
    );
    std::fs::write(
        &manifest,
        text.replace(&line, &format!("imu_minus_nic_ns = {proposed}")),
    )
    .unwrap();
    let out = wins(&["run", &s(&data), "--out", &s(&dir.join("r2"))]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn simulate_rejects_unknown_scenarios_and_bad_files_with_a_message() {
    let out = wins(&[
        "simulate",
        "--scenario",
        "nope",
        "--out",
        "/tmp/unused-wins",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no built-in scenario \"nope\"") && err.contains("paper-circle"),
        "{err}"
    );

    let dir = std::env::temp_dir().join(format!("wins-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bad.toml");
    std::fs::write(&file, "duration_s = -1.0\n").unwrap();
    let out = wins(&[
        "simulate",
        "--scenario-file",
        file.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("duration_s"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `wins demo` simulates, runs and scores; `wins run` on its dataset writes the same files; a
/// missing dataset is a clear error.
#[test]
fn demo_and_run_write_the_run_directory() {
    let dir = std::env::temp_dir().join(format!("wins-cli-demo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = wins(&["demo", "--duration", "20", "--out", dir.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("converged at") && text.contains("ATE"),
        "{text}"
    );
    let run = dir.join("run");
    for f in [
        "trajectory.tum",
        "trajectory_all.tum",
        "aps.csv",
        "aoa.csv",
        "stats.json",
        "metrics.json",
        "report.txt",
        "trajectory.png",
        "position_error.png",
        "aoa.png",
        "height.png",
        "attitude.png",
        "sigma.png",
    ] {
        assert!(run.join(f).is_file(), "{f} missing");
    }
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("metrics.json")).unwrap()).unwrap();
    assert!(metrics["packets_used"].as_u64().unwrap() > 500, "{metrics}");
    assert!(
        metrics["ap_position_error_m"]["ap0"]
            .as_f64()
            .unwrap()
            .is_finite()
    );

    let again = dir.join("again");
    let dataset = dir.join("dataset");
    let out = wins(&[
        "run",
        dataset.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--no-plots",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(again.join("trajectory.tum")).unwrap(),
        std::fs::read_to_string(run.join("trajectory.tum")).unwrap(),
        "the same dataset gives the same trajectory"
    );
    assert!(!again.join("aoa.png").exists());

    // Without the dataset's calibration the chains' offsets are resolved from the flight, and
    // the run says so; a calibration and --no-calibration together are refused.
    let uncalibrated = dir.join("uncalibrated");
    let out = wins(&[
        "run",
        dataset.to_str().unwrap(),
        "--out",
        uncalibrated.to_str().unwrap(),
        "--no-plots",
        "--no-calibration",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("resolved from the flight alone"), "{err}");
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(uncalibrated.join("stats.json")).unwrap()).unwrap();
    let chains = &stats["chain_offsets"];
    assert_eq!(chains["had_calibration"], false, "{chains}");
    assert_eq!(
        chains["hypotheses_deg"].as_array().unwrap().len(),
        8,
        "{chains}"
    );
    let calibration = dataset.join("calibration.toml");
    let out = wins(&[
        "run",
        dataset.to_str().unwrap(),
        "--out",
        uncalibrated.to_str().unwrap(),
        "--calibration",
        calibration.to_str().unwrap(),
        "--no-calibration",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("cannot be used with"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let out = wins(&["run", "/nonexistent-wins", "--out", again.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nonexistent-wins"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn config_prints_the_shipped_defaults_and_lists_every_problem_of_a_file() {
    let out = wins(&["config"]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let shipped = std::fs::read_to_string(root.join("configs/default.toml")).expect("shipped");
    assert_eq!(String::from_utf8(out.stdout).expect("utf-8"), shipped);

    let dir = std::env::temp_dir().join(format!("wins-cli-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let good = dir.join("good.toml");
    std::fs::write(&good, "[pipeline]\ngate_deg = 7\n").expect("write");
    let out = wins(&["config", "--check", common::s(&good)]);
    assert!(out.status.success(), "{}", common::stderr(&out));

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[pipeline]\ngate_rad = 0.1\n[aoa.music]\naoa_step_deg = 1e-9\n[window]\nmax_frames = 0\n",
    )
    .expect("write");
    for args in [
        vec!["config", "--check", common::s(&bad)],
        vec![
            "run",
            "data/none",
            "--out",
            "target/none",
            "--config",
            common::s(&bad),
        ],
    ] {
        let out = wins(&args);
        assert!(!out.status.success(), "{args:?} accepted a bad file");
        let err = common::stderr(&out);
        for key in [
            "pipeline.gate_rad",
            "aoa.music.aoa_step_deg",
            "window.max_frames",
        ] {
            assert!(err.contains(key), "{args:?}: {key} not named in {err}");
        }
        assert!(err.contains("did you mean `gate_deg`"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn csi_check_gives_a_verdict_per_finding_and_fails_on_an_unusable_capture() {
    // The CSI Tool's own sample: three chains, 51 dB of SNR, too few packets for a rate.
    let out = wins(&["csi", "check", MIXED, "--channel", "64"]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    for topic in [
        "antennas",
        "signal",
        "clipping",
        "chain phases",
        "calibration",
        "packets",
    ] {
        assert!(text.contains(topic), "{topic}: {text}");
    }
    assert!(text.contains("centre 5.320 GHz as given"), "{text}");
    assert!(
        text.lines()
            .last()
            .is_some_and(|l| l.starts_with("verdict")),
        "{text}"
    );

    // The CSIKit example's chains step by quarter turns from packet to packet.
    let out = wins(&[
        "csi",
        "check",
        "--json",
        "data/intel5300/csikit_example.dat",
    ]);
    assert!(!out.status.success());
    assert!(
        common::stderr(&out).contains("not usable for AoA"),
        "{}",
        common::stderr(&out)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["verdict"], "bad");
    let phases = v["check"]["findings"]
        .as_array()
        .expect("findings")
        .iter()
        .find(|f| f["topic"] == "chain phases")
        .expect("chain phases");
    assert_eq!(phases["verdict"], "bad", "{phases}");

    // Not a log at all, a bad channel, a missing file: clear errors.
    let out = wins(&[
        "csi",
        "check",
        "data/intel5300/csikit_example.matlab_ref.jsonl",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("a text file"));
    let out = wins(&["csi", "check", MIXED, "--channel", "15"]);
    assert!(
        common::stderr(&out).contains("--channel 15 is not a Wi-Fi channel"),
        "{}",
        common::stderr(&out)
    );
    let out = wins(&["csi", "check", "no/such/file.dat"]);
    assert!(
        common::stderr(&out).contains("cannot read no/such/file.dat"),
        "{}",
        common::stderr(&out)
    );
}

#[test]
fn csi_stats_prints_a_row_per_capture_and_refuses_a_log_without_three_chains() {
    let out = wins(&[
        "csi",
        "stats",
        "--json",
        "data/intel5300/csikit_example.dat",
        MIXED,
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let rows: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("json"))
        .collect();
    assert_eq!(rows.len(), 2);
    for r in &rows {
        let s = &r["stats"];
        assert!(s["packets"].as_u64().is_some_and(|n| n > 0), "{r}");
        // The second and third eigenvalues under the first, the ripple a few dB.
        let l = s["eigenvalue_db"].as_array().expect("eigenvalues");
        assert!(l.iter().all(|x| x.as_f64().is_some_and(|x| x < 0.0)), "{r}");
        assert!(
            s["amplitude_ripple_db"]
                .as_f64()
                .is_some_and(|x| x > 0.0 && x < 20.0),
            "{r}"
        );
    }
    let out = wins(&[
        "csi",
        "stats",
        "data/intel5300/csikit_example.matlab_ref.jsonl",
    ]);
    assert!(!out.status.success());
    assert!(
        common::stderr(&out).contains("no record with three chains"),
        "{}",
        common::stderr(&out)
    );
}
