//! Flight families end to end: `wins simulate --family` writes a dataset with its drawn
//! scenario, which `--scenario-file` flies again to the same dataset; `wins sweep --family`
//! writes the drawn labels as columns, keeps each run's scenario and breaks the family down.

// Tests stop at the line that failed.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::s;

fn wins(dir: &Path, args: &[&str]) -> Output {
    let out = common::wins_in(dir, args);
    assert!(
        out.status.success(),
        "wins {}: {}",
        args.join(" "),
        common::stderr(&out)
    );
    out
}

/// Every file under `dir`, by path relative to it.
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pending.push(path);
            } else {
                let rel = path.strip_prefix(dir).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

#[test]
fn a_drawn_flight_flies_again_from_its_scenario_file() {
    let root = common::fresh_dir("family", "simulate");
    let (drawn, again) = (root.join("drawn"), root.join("again"));
    let draw = [
        "simulate",
        "--family",
        "room",
        "--seed",
        "11",
        "--duration",
        "20",
    ];
    let out = wins(&root, &[&draw[..], &["-o", s(&drawn)]].concat());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("drawn: aps "), "{text}");
    let scenario = drawn.join("scenario.toml");
    let labels = std::fs::read_to_string(drawn.join("drawn.toml")).unwrap();
    assert!(
        labels.contains("family = \"room\"") && labels.contains("seed = 11"),
        "{labels}"
    );
    assert!(labels.contains("duration_s = 20.0"), "{labels}");
    wins(
        &root,
        &["simulate", "--scenario-file", s(&scenario), "-o", s(&again)],
    );
    let mut first = files(&drawn);
    first.remove(Path::new("scenario.toml")).unwrap();
    first.remove(Path::new("drawn.toml")).unwrap();
    let second = files(&again);
    assert_eq!(
        first.keys().collect::<Vec<_>>(),
        second.keys().collect::<Vec<_>>()
    );
    for (path, bytes) in &first {
        assert!(&second[path] == bytes, "{} differs", path.display());
    }
    // `--print` prints the same scenario file without simulating it.
    let printed = wins(&root, &[&draw[..], &["--print"]].concat());
    assert_eq!(
        String::from_utf8_lossy(&printed.stdout),
        std::fs::read_to_string(&scenario).unwrap()
    );

    // The families are listed; an unknown one is refused with them.
    let list = wins(&root, &["simulate", "--list-families"]);
    let list = String::from_utf8_lossy(&list.stdout);
    assert!(
        list.starts_with("room ") && list.contains("\nhall "),
        "{list}"
    );
    let bad = common::wins_in(&root, &["simulate", "--family", "garage", "-o", "x"]);
    assert!(!bad.status.success());
    let err = common::stderr(&bad);
    assert!(
        err.contains("garage") && err.contains("room, hall"),
        "{err}"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn a_family_sweep_has_label_columns_scenarios_and_a_breakdown() {
    let root = common::fresh_dir("family", "sweep");
    let out = root.join("out");
    let printed = wins(
        &root,
        &[
            "sweep",
            "--family",
            "hall",
            "--seeds",
            "4",
            "--duration-s",
            "20",
            "--airborne",
            "-o",
            s(&out),
        ],
    );
    let printed = String::from_utf8_lossy(&printed.stdout);
    assert!(printed.contains("hall, by what was drawn:"), "{printed}");
    assert!(printed.contains("\nstart air "), "{printed}");
    let mut r = csv::Reader::from_path(out.join("runs.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let row: Vec<String> = r
        .records()
        .next()
        .unwrap()
        .unwrap()
        .iter()
        .map(str::to_string)
        .collect();
    let cell = |name: &str| {
        let k = header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("{name}"));
        row[k].clone()
    };
    assert_eq!(cell("scenario"), "hall");
    assert_eq!(cell("drawn.family"), "hall");
    assert_eq!(cell("drawn.seed"), "4");
    assert_eq!(cell("drawn.start"), "air");
    assert_eq!(cell("drawn.duration_s"), "20");
    assert_eq!(cell("error"), "");
    for label in [
        "aps",
        "imu",
        "packet_rate_hz",
        "calibration",
        "bandwidth",
        "vibration_m_s2",
    ] {
        assert!(!cell(&format!("drawn.{label}")).is_empty(), "{label}");
    }
    // The run's scenario is kept, and flies alone.
    let kept = out.join("scenarios/hall-4.toml");
    wins(
        &root,
        &[
            "simulate",
            "--scenario-file",
            s(&kept),
            "-o",
            s(&root.join("alone")),
        ],
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let by: Vec<&str> = summary["breakdowns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["label"].as_str().unwrap())
        .collect();
    for label in ["aps", "imu", "packet_rate_hz", "start", "calibration"] {
        assert!(by.contains(&label), "{label}: {by:?}");
    }
    std::fs::remove_dir_all(&root).unwrap();
}
