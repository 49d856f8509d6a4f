//! `wins aoa` and `wins calibrate` end to end on a simulated paper-circle flight.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use wins::dataset::truth::Truth;
use wins::rig::ChainCalibration;

mod common;
use common::{s, stderr, wins};

/// A fresh directory holding a 4 s paper-circle dataset in `ds/`.
fn flight(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-cli-aoa-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let ds = dir.join("ds");
    let out = wins(&[
        "simulate",
        "--scenario",
        "paper-circle",
        "--duration",
        "4",
        "--airborne",
        "--out",
        s(&ds),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    dir
}

/// `wins ARGS` fails, without a panic, and says every one of `expect`.
fn failure(args: &[&str], expect: &[&str]) {
    let out = wins(args);
    let err = stderr(&out);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: {err}");
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median |AoA error| (degrees) of a `wins aoa --format csv` output against the truth, over
/// received packets in front of the array within ±60°; also the number compared.
fn median_error_deg(csv_path: &Path, truth: &Truth) -> (f64, usize) {
    let mut reader = csv::Reader::from_path(csv_path).expect("csv output");
    let headers = reader.headers().expect("header").clone();
    let column = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (status, aoa) = (column("status"), column("aoa_deg"));
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.expect("row")).collect();
    let received: Vec<_> = truth.packets[0].iter().filter(|r| r.received).collect();
    assert_eq!(rows.len(), received.len());
    let errors: Vec<f64> = rows
        .iter()
        .zip(received)
        .filter(|(row, t)| &row[status] == "ok" && t.in_front && t.aoa_deg.abs() <= 60.0)
        .map(|(row, t)| (row[aoa].parse::<f64>().expect("aoa_deg") - t.aoa_deg).abs())
        .collect();
    let n = errors.len();
    (median(errors), n)
}

#[test]
fn calibrate_on_the_truth_then_aoa_is_within_three_degrees() {
    let dir = flight("accuracy");
    let ds = dir.join("ds");
    let calib = dir.join("calib.toml");
    let out = wins(&["calibrate", s(&ds), "--ap", "ap0", "--out", s(&calib)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("packets used") && text.contains("offset (deg)"),
        "{text}"
    );

    let truth = Truth::load(&ds).expect("truth");
    let cal = ChainCalibration::load(&calib).expect("calibration file");
    assert!(cal.source.contains("truth of"), "{}", cal.source);
    let want = &truth
        .info
        .as_ref()
        .expect("truth.toml")
        .chain_phase_offsets_rad;
    for m in 1..3 {
        let err = (cal.phase_offsets_rad[m] - (want[m] - want[0]) + PI).rem_euclid(TAU) - PI;
        println!("chain {m}: offset error {:.2}°", err.to_degrees());
        // Measured 0.27° and 2.18° (seed 1, 4 s).
        assert!(err.abs().to_degrees() <= 3.0, "chain {m}: {err} rad");
    }

    let rows = dir.join("aoa.csv");
    let out = wins(&[
        "aoa",
        s(&ds.join("ap0.dat")),
        "--calibration",
        s(&calib),
        "--format",
        "csv",
        "--out",
        s(&rows),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("packets,"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("uncalibrated"), "{}", stderr(&out));
    let (calibrated, n) = median_error_deg(&rows, &truth);
    println!("calibrated: median |error| {calibrated:.2}° over {n} packets");
    // Measured 2.10° over 186 packets (uncalibrated: 49.5°).
    assert!(n >= 100 && calibrated <= 3.0, "{calibrated} over {n}");

    let out = wins(&["aoa", s(&ds.join("ap0.dat")), "--out", s(&rows)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("uncalibrated chains: the curvature is measured from the log"),
        "{}",
        stderr(&out)
    );
    let (uncalibrated, n) = median_error_deg(&rows, &truth);
    println!("uncalibrated: median |error| {uncalibrated:.2}° over {n} packets");
    assert!(uncalibrated > 15.0, "{uncalibrated}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn spotfi_jsonl_and_the_spectrum_plot() {
    let dir = flight("spotfi");
    let ds = dir.join("ds");
    let png = dir.join("spectrum.png");
    let out = wins(&[
        "aoa",
        s(&ds),
        "--ap",
        "ap0",
        "--mode",
        "spotfi",
        "--group-size",
        "10",
        "--format",
        "jsonl",
        "--plot",
        s(&png),
        "--plot-packet",
        "3",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("SpotFi:"), "{}", stderr(&out));
    let truth = Truth::load(&ds).expect("truth");
    let received = truth.packets[0].iter().filter(|r| r.received).count();
    let text = String::from_utf8(out.stdout).expect("utf-8");
    let rows: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect();
    assert_eq!(rows.len(), received);
    assert_eq!(rows[25]["group"], 2);
    assert_eq!(rows[25]["index"], 25);
    let ok = rows.iter().filter(|r| r["status"] == "ok").count();
    assert!(ok * 10 >= received * 8, "{ok} of {received}");
    assert!(rows.iter().all(|r| r["group_aoa_deg"].is_number()));

    let bytes = std::fs::read(&png).expect("png written");
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_fails_with_a_message_and_no_panic() {
    let dir = flight("errors");
    let ds = dir.join("ds");
    let log = ds.join("ap0.dat");
    let calib = dir.join("calib.toml");
    failure(
        &["aoa", "no/such/file.dat"],
        &["cannot read no/such/file.dat"],
    );
    failure(
        &["calibrate", s(&log), "--aoa-deg", "120", "--out", s(&calib)],
        &["120", "outside [-90°, 90°]"],
    );
    failure(&["calibrate", s(&log), "--out", s(&calib)], &["--aoa-deg"]);
    failure(&["aoa", s(&ds)], &["name its AP (ap0)", "--ap NAME"]);
    failure(&["aoa", s(&ds), "--ap", "ap9"], &["no AP \"ap9\""]);
    failure(
        &["aoa", s(&log), "--mode", "spotfi", "--group-size", "1"],
        &["group size 1"],
    );
    failure(
        &[
            "aoa",
            s(&log),
            "--plot",
            s(&dir.join("p.png")),
            "--plot-packet",
            "100000",
        ],
        &["--plot-packet 100000"],
    );
    std::fs::write(&calib, "phase_offsets_rad = [0.0, 1.0]\n").expect("write");
    failure(
        &["aoa", s(&log), "--calibration", s(&calib)],
        &[
            "does not fit the array",
            "2 finite offsets, the CSI has 3 antennas",
        ],
    );
    std::fs::write(&calib, "offsets = [0.0, 1.0, 2.0]\n").expect("write");
    failure(
        &["aoa", s(&log), "--calibration", s(&calib)],
        &["unknown field"],
    );

    std::fs::remove_dir_all(&dir).ok();
}

/// The guards a user needs: a calibration that cannot be right is not written; one made on
/// another set-up is refused; a carrier in the wrong unit, an unknown channel, an array wider than
/// λ/2 and a file with no CSI are errors that say so.
#[test]
fn guards_refuse_what_would_give_wrong_angles() {
    let dir = flight("guards");
    let log = dir.join("ds").join("ap0.dat");
    let calib = dir.join("calib.toml");
    // The flight moves: one angle for all its packets spreads each chain's offsets widely, and
    // nothing is written.
    failure(
        &["calibrate", s(&log), "--aoa-deg", "-20", "--out", s(&calib)],
        &[
            "offsets spread",
            "not static",
            "--max-spread-deg",
            "not written",
        ],
    );
    assert!(!calib.exists());
    // Let through on request, the file says what it was made for.
    let out = wins(&[
        "calibrate",
        s(&log),
        "--aoa-deg",
        "-20",
        "--max-spread-deg",
        "180",
        "--out",
        s(&calib),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let cal = ChainCalibration::load(&calib).expect("calibration file");
    assert!(cal.source.contains("at -20°"), "{}", cal.source);
    let made_for = cal.made_for.expect("the set-up recorded");
    assert_eq!(made_for.center_freq_hz, 5.32e9);
    assert!((made_for.spacing_m - 0.028_176).abs() < 1e-5);
    assert_eq!(made_for.bandwidths, vec![wins::csi::Bandwidth::Ht20]);
    // Applied on channel 165, or to a wider array: refused.
    failure(
        &[
            "aoa",
            s(&log),
            "--calibration",
            s(&calib),
            "--channel",
            "165",
        ],
        &["made for 5.320 GHz", "5.825 GHz"],
    );
    failure(
        &[
            "aoa",
            s(&log),
            "--calibration",
            s(&calib),
            "--spacing-m",
            "0.025",
        ],
        &["made for 5.320 GHz with 28.18 mm", "25.00 mm"],
    );
    // On its own set-up it is applied.
    let out = wins(&[
        "aoa",
        s(&log),
        "--calibration",
        s(&calib),
        "--channel",
        "64",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // Carriers and channels.
    failure(
        &["aoa", s(&log), "--center-freq-hz", "5.32"],
        &["5.32 Hz", "given in Hz"],
    );
    failure(
        &["aoa", s(&log), "--channel", "200"],
        &["channel 200 is not a Wi-Fi channel", "--channel"],
    );
    failure(
        &[
            "aoa",
            s(&log),
            "--channel",
            "64",
            "--center-freq-hz",
            "5.32e9",
        ],
        &["cannot be used with"],
    );
    // An array wider than λ/2 runs, says so, and lists each packet's aliases.
    let rows = dir.join("wide.csv");
    let out = wins(&["aoa", s(&log), "--spacing-m", "0.1", "--out", s(&rows)]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("wider than half a wavelength") && err.contains("-34.3°, +34.3°"),
        "{err}"
    );
    let text = std::fs::read_to_string(&rows).expect("rows");
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let column = reader
        .headers()
        .expect("header")
        .iter()
        .position(|h| h == "aliases_deg")
        .expect("aliases_deg column");
    let listed = reader
        .records()
        .filter(|r| r.as_ref().is_ok_and(|r| !r[column].is_empty()))
        .count();
    assert!(listed > 0, "no packet lists its aliases");
    // A file with no CSI records.
    let empty = dir.join("empty.dat");
    std::fs::write(&empty, b"").expect("write");
    failure(&["aoa", s(&empty)], &["no CSI records"]);
    failure(
        &["calibrate", s(&empty), "--aoa-deg", "0", "--out", s(&calib)],
        &["no CSI records"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_output_named_as_the_input_is_refused_before_anything_is_read() {
    let dir = std::env::temp_dir().join(format!("wins-aoa-same-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("capture.dat");
    let original = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/intel5300/csikit_example.dat"),
    )
    .unwrap();
    std::fs::write(&log, &original).unwrap();
    let same = dir.join(".").join("capture.dat");
    for args in [
        vec!["aoa", s(&log), "--out", s(&same)],
        vec!["aoa", s(&log), "--plot", s(&same)],
        vec!["calibrate", s(&log), "--aoa-deg", "10", "--out", s(&same)],
    ] {
        let out = wins(&args);
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains("is the input"), "{}", stderr(&out));
        assert_eq!(std::fs::read(&log).unwrap(), original, "{args:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
