//! Outputs that cannot destroy inputs or lie: an output onto an input is refused before any work,
//! an unwritable folder fails fast, a re-run leaves none of the previous run's files, a folder
//! that is not a run is refused, and a truth that cannot be read loses only the evaluation.

// Tests stop at the line that failed.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{s, stderr, wins};

fn scratch(name: &str) -> PathBuf {
    common::fresh_dir("outputs", name)
}

/// Simulates the paper's circle for `duration_s` into `dir`: 20 s (with the take-off) converges
/// and is scored; below that the flight is airborne from the start and does not converge.
fn simulate(dir: &Path, duration_s: u32) {
    let duration = duration_s.to_string();
    let mut args = vec![
        "simulate",
        "--scenario",
        "paper-circle",
        "--duration",
        &duration,
        "--out",
        s(dir),
    ];
    if duration_s < 20 {
        args.push("--airborne");
    }
    let out = wins(&args);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(snapshot(&path));
        } else {
            files.insert(path.clone(), fs::read(&path).unwrap());
        }
    }
    files
}

fn run(dataset: &Path, out: &Path, more: &[&str]) -> Output {
    let mut args = vec!["run", s(dataset), "--out", s(out)];
    args.extend(more);
    wins(&args)
}

/// `run.json` of the run folder `dir`.
fn manifest(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&fs::read(dir.join("run.json")).expect("run.json")).expect("JSON")
}

#[test]
fn csi_export_onto_its_own_input_is_refused_and_the_log_is_untouched() {
    let dir = scratch("export");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let original = fs::read(root.join("data/intel5300/csikit_example.dat")).unwrap();
    let log = dir.join("log.dat");
    fs::write(&log, &original).unwrap();
    for spelling in ["log.dat", "./log.dat", "../log.dat"] {
        let target = if spelling.starts_with("../") {
            fs::create_dir_all(dir.join("sub")).unwrap();
            dir.join("sub").join(spelling)
        } else {
            dir.join(spelling)
        };
        let out = wins(&["csi", "export", s(&log), "-o", s(&target)]);
        assert_eq!(out.status.code(), Some(1), "{spelling}");
        let err = stderr(&out);
        assert!(
            err.contains("is the input") && err.contains(s(&target)) && err.contains(s(&log)),
            "{err}"
        );
        assert_eq!(
            fs::read(&log).unwrap(),
            original,
            "{spelling}: the log changed"
        );
    }
    let out = wins(&["csi", "export", s(&log), "-o", s(&dir.join("log.jsonl"))]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(fs::metadata(dir.join("log.jsonl")).unwrap().len() > 0);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn run_refuses_the_dataset_its_truth_and_its_inputs_as_output() {
    let dir = scratch("onto-input");
    let data = dir.join("data");
    simulate(&data, 8);
    let before = snapshot(&data);
    let config = dir.join("settings/my.toml");
    fs::create_dir_all(config.parent().unwrap()).unwrap();
    fs::write(&config, "[pipeline]\ngate_deg = 7\n").unwrap();
    for (out, more) in [
        (data.join("truth"), vec![]),
        (data.clone(), vec![]),
        (data.join("new"), vec![]),
        (dir.clone(), vec![]),
        (dir.join("settings"), vec!["--config", s(&config)]),
    ] {
        let result = run(&data, &out, &more);
        assert_eq!(result.status.code(), Some(1), "{out:?}");
        let err = stderr(&result);
        assert!(
            err.contains("would overlap the input") && err.contains(s(&out)),
            "{out:?}: {err}"
        );
        assert!(result.stdout.is_empty(), "{out:?}: work was done");
    }
    assert_eq!(snapshot(&data), before, "the dataset changed");
    assert!(
        !data.join("new").exists(),
        "a folder was created in the dataset"
    );
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_unwritable_output_fails_before_any_work() {
    let dir = scratch("unwritable");
    let data = dir.join("data");
    simulate(&data, 8);
    let file = dir.join("a-file");
    fs::write(&file, "").unwrap();
    let out = run(&data, &file.join("run"), &[]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("is not writable") && err.contains(s(&file.join("run"))),
        "{err}"
    );
    assert!(out.stdout.is_empty(), "work was done before the check");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_rerun_that_cannot_be_scored_leaves_none_of_the_previous_files() {
    let dir = scratch("rerun");
    let (scored, unscored, out) = (dir.join("scored"), dir.join("short"), dir.join("run"));
    simulate(&scored, 20);
    simulate(&unscored, 8);
    let first = run(&scored, &out, &[]);
    assert!(first.status.success(), "{}", stderr(&first));
    for f in ["metrics.json", "report.txt", "trajectory.png", "aoa.png"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let m = manifest(&out);
    assert_eq!(m["complete"], true);
    assert_eq!(m["evaluation"], "ok");
    fs::write(out.join("notes.txt"), "mine").unwrap();

    let first_aoa = fs::read(out.join("aoa.png")).unwrap();
    let second = run(&unscored, &out, &[]);
    assert!(second.status.success(), "{}", stderr(&second));
    for f in [
        "metrics.json",
        "report.txt",
        "trajectory.png",
        "position_error.png",
    ] {
        assert!(
            !out.join(f).exists(),
            "{f} of the previous run is still there"
        );
    }
    // Its packets are drawn (it has no pose to draw): the AoA figure is its own.
    assert_ne!(fs::read(out.join("aoa.png")).unwrap(), first_aoa);
    assert!(out.join("trajectory_all.tum").is_file());
    assert_eq!(fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    let m = manifest(&out);
    assert_eq!(m["complete"], true);
    assert_eq!(m["estimate"], true);
    assert!(
        m["evaluation"].as_str().unwrap().starts_with("not scored:"),
        "{m}"
    );
    assert_eq!(m["dataset"], s(&unscored.canonicalize().unwrap()));
    assert_eq!(m["config_file"], "defaults");
    assert!(m["config"]["pipeline"]["gate_deg"].is_number(), "{m}");
    let files: Vec<&str> = m["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(files.contains(&"trajectory.tum") && !files.contains(&"metrics.json"));
    let names: Vec<String> = fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.starts_with(".wins-tmp-")),
        "{names:?}"
    );
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_run_without_truth_draws_its_figures() {
    let dir = scratch("no-truth");
    let (dataset, out) = (dir.join("dataset"), dir.join("run"));
    simulate(&dataset, 20);
    fs::remove_dir_all(dataset.join("truth")).unwrap();
    let done = run(&dataset, &out, &[]);
    assert!(done.status.success(), "{}", stderr(&done));
    for f in [
        "trajectory.png",
        "height.png",
        "attitude.png",
        "aoa.png",
        "sigma.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // No truth, no error to draw.
    assert!(!out.join("position_error.png").exists());
    // The APs keep their covariance for the ellipses.
    let aps = fs::read_to_string(out.join("aps.csv")).unwrap();
    assert!(aps.starts_with("name,x_m,y_m,z_m,c_x_x,"), "{aps}");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_non_empty_folder_that_is_not_a_run_is_refused() {
    let dir = scratch("foreign");
    let data = dir.join("data");
    simulate(&data, 8);
    let out = dir.join("photos");
    fs::create_dir_all(&out).unwrap();
    fs::write(out.join("cat.jpg"), "meow").unwrap();
    let result = run(&data, &out, &[]);
    assert_eq!(result.status.code(), Some(1));
    let err = stderr(&result);
    assert!(
        err.contains("not a wins run directory") && err.contains("choose a new or empty folder"),
        "{err}"
    );
    assert!(result.stdout.is_empty());
    assert_eq!(
        fs::read_dir(&out).unwrap().count(),
        1,
        "something was written"
    );
    assert_eq!(fs::read_to_string(out.join("cat.jpg")).unwrap(), "meow");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_malformed_truth_keeps_the_estimate_and_fails_the_command() {
    let dir = scratch("bad-truth");
    let data = dir.join("data");
    simulate(&data, 20);
    fs::write(data.join("truth/poses.tum"), "0.0 1 2 three\n").unwrap();
    let out = dir.join("run");
    let result = run(&data, &out, &[]);
    assert_eq!(result.status.code(), Some(1));
    let err = stderr(&result);
    assert!(
        err.contains("error: evaluation failed") && err.contains("poses.tum"),
        "{err}"
    );
    for f in [
        "trajectory.tum",
        "trajectory_all.tum",
        "aps.csv",
        "stats.json",
    ] {
        assert!(out.join(f).is_file(), "{f} not written");
    }
    assert!(!out.join("metrics.json").exists());
    let m = manifest(&out);
    assert_eq!(m["complete"], true);
    assert_eq!(m["estimate"], true);
    let evaluation = m["evaluation"].as_str().unwrap();
    assert!(
        evaluation.starts_with("failed:") && evaluation.contains("poses.tum"),
        "{evaluation}"
    );
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn demo_runs_again_into_its_own_folder() {
    let dir = scratch("demo");
    for _ in 0..2 {
        let out = wins(&["demo", "--duration", "8", "--airborne", "--out", s(&dir)]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(manifest(&dir.join("run"))["complete"], true);
    }
    fs::remove_dir_all(&dir).unwrap();
}
