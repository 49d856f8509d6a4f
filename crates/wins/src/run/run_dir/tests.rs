use std::fs;
use std::path::PathBuf;

use super::*;

/// A fresh folder for one test, with a dataset folder `data` holding a `truth/` file.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-run-dir-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("data/truth")).unwrap();
    fs::write(dir.join("data/truth/poses.tum"), "").unwrap();
    dir
}

fn inputs(dir: &Path) -> (PathBuf, PathBuf) {
    (dir.join("data"), dir.join("my.toml"))
}

#[test]
fn the_dataset_its_truth_and_the_settings_file_are_refused_as_output() {
    let dir = scratch("refuse");
    let (data, config) = inputs(&dir);
    fs::write(&config, "").unwrap();
    let inputs = RunInputs {
        dataset: &data,
        config_file: Some(&config),
        calibration_file: None,
    };
    for out in [
        data.clone(),
        data.join("truth"),
        data.join("x"),
        config.clone(),
    ] {
        let err = RunDir::prepare(&out, &inputs).unwrap_err();
        assert!(
            matches!(err, OutputError::OntoInput { .. }),
            "{out:?}: {err}"
        );
    }
    assert!(!data.join("x").exists(), "nothing created");
    assert!(data.join("truth/poses.tum").is_file());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_previous_run_is_cleared_of_its_own_files_only() {
    let dir = scratch("rerun");
    let (data, _) = inputs(&dir);
    let inputs = RunInputs {
        dataset: &data,
        config_file: None,
        calibration_file: None,
    };
    let out = dir.join("run");
    let run = RunDir::prepare(&out, &inputs).unwrap();
    let manifest = RunManifest::new(&inputs, &Config::default(), false);
    run.start(&manifest).unwrap();
    let pending: RunManifest =
        serde_json::from_str(&fs::read_to_string(out.join(MANIFEST_FILE)).unwrap()).unwrap();
    assert!(!pending.complete);
    assert_eq!(pending.files.len(), RUN_FILES.len());
    let written: Vec<PathBuf> = [METRICS_FILE, REPORT_FILE, "../outside.txt"]
        .iter()
        .map(|f| out.join(f))
        .collect();
    for f in &written {
        fs::write(f, "old").unwrap();
    }
    fs::write(out.join("notes.txt"), "mine").unwrap();
    run.finish(&manifest, &written).unwrap();
    let done: RunManifest =
        serde_json::from_str(&fs::read_to_string(out.join(MANIFEST_FILE)).unwrap()).unwrap();
    assert!(done.complete);
    assert_eq!(done.config_file, "defaults");
    assert_eq!(
        done.inputs,
        [resolve(&data.join("truth/poses.tum")).unwrap()]
    );

    // A hand-edited manifest cannot reach out of the folder.
    let text = fs::read_to_string(out.join(MANIFEST_FILE)).unwrap();
    fs::write(
        out.join(MANIFEST_FILE),
        text.replace("\"outside.txt\"", "\"../outside.txt\""),
    )
    .unwrap();
    let again = RunDir::prepare(&out, &inputs).unwrap();
    again.start(&manifest).unwrap();
    assert!(!out.join(METRICS_FILE).exists() && !out.join(REPORT_FILE).exists());
    assert_eq!(fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    assert_eq!(fs::read_to_string(dir.join("outside.txt")).unwrap(), "old");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_non_empty_folder_without_a_readable_manifest_is_refused() {
    let dir = scratch("foreign");
    let (data, _) = inputs(&dir);
    let inputs = RunInputs {
        dataset: &data,
        config_file: None,
        calibration_file: None,
    };
    let out = dir.join("photos");
    fs::create_dir_all(&out).unwrap();
    fs::write(out.join("cat.jpg"), "meow").unwrap();
    let err = RunDir::prepare(&out, &inputs).unwrap_err();
    assert!(
        err.to_string().contains("not a wins run directory"),
        "{err}"
    );
    fs::write(out.join(MANIFEST_FILE), "{").unwrap();
    let err = RunDir::prepare(&out, &inputs).unwrap_err();
    assert!(matches!(err, OutputError::BadManifest { .. }), "{err}");
    assert_eq!(fs::read_to_string(out.join("cat.jpg")).unwrap(), "meow");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_interrupted_runs_spool_files_do_not_block_the_folder_and_are_removed() {
    let dir = scratch("spool");
    let (data, _) = inputs(&dir);
    let out = dir.join("out");
    fs::create_dir_all(&out).unwrap();
    // Left by a run of another process that was killed.
    let stale = out.join(format!("{SPOOL_PREFIX}0-trajectory.tum"));
    fs::write(&stale, "# timestamp tx ty tz qx qy qz qw\n").unwrap();
    let inputs = RunInputs {
        dataset: &data,
        config_file: None,
        calibration_file: None,
    };
    let run_dir = RunDir::prepare(&out, &inputs).unwrap();
    // This process's own spool survives the start: the run writes it before.
    let own = out.join(format!("{SPOOL_PREFIX}{}-aoa.csv", std::process::id()));
    fs::write(&own, "").unwrap();
    run_dir
        .start(&RunManifest::new(&inputs, &Config::default(), false))
        .unwrap();
    assert!(!stale.exists() && own.exists());
    let _ = fs::remove_dir_all(&dir);
}
