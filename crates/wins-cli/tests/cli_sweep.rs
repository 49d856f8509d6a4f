//! `wins sweep` end to end: its rows are what `wins simulate` then `wins run` give, shards
//! merge into the unsharded outputs, and its output directory is guarded.

// Tests stop at the line that failed.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::s;

/// Flight length of the test sweeps, s: long enough for the estimator to converge on most
/// airborne seeds (and for the built-in flights' rest, take-off and landing plus some mission),
/// short enough to keep the test quick in a debug build.
const DURATION_S: &str = "40";
/// `wins simulate`'s flag for the flight duration.
const SIMULATE_DURATION_FLAG: &str = "--duration-s";
/// The seeds whose rows are checked against `wins simulate` + `wins run`.
const CHECKED_SEEDS: [u64; 3] = [1, 4, 8];

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

fn temp_dir(name: &str) -> PathBuf {
    common::fresh_dir("sweep", name)
}

/// `runs.csv` as its header and one `column → cell` map per row.
fn read_runs(dir: &Path) -> (Vec<String>, Vec<BTreeMap<String, String>>) {
    let mut r = csv::Reader::from_path(dir.join("runs.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(str::to_string))
                .collect()
        })
        .collect();
    (header, rows)
}

/// The leaves of a JSON value, `.`-joined paths to values.
fn leaves(v: &serde_json::Value, path: &str, out: &mut BTreeMap<String, serde_json::Value>) {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, x)| leaves(x, &join(k), out)),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| leaves(x, &join(&i.to_string()), out)),
        leaf => {
            out.insert(path.to_string(), leaf.clone());
        }
    }
}

/// The row of `runs.csv` equals the `metrics.json` and `stats.json` that `wins simulate` and
/// `wins run` write for this seed: every metric, to the bit (both texts parsed alike).
/// `airborne`: the sweep flew the scenario with `--airborne`.
fn check_against_simulate_and_run(
    tmp: &Path,
    row: &BTreeMap<String, String>,
    header: &[String],
    airborne: bool,
) {
    let (scenario, seed) = (&row["scenario"], &row["seed"]);
    let data = tmp.join(format!("data-{scenario}-{seed}"));
    let run = tmp.join(format!("run-{scenario}-{seed}"));
    let mut args = vec![
        "simulate",
        "--scenario",
        scenario,
        "--seed",
        seed,
        SIMULATE_DURATION_FLAG,
        DURATION_S,
        "--out",
        s(&data),
    ];
    if airborne {
        args.push("--airborne");
    }
    wins(tmp, &args);
    wins(tmp, &["run", s(&data), "--out", s(&run), "--no-plots"]);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("stats.json")).unwrap()).unwrap();
    let estimator = &stats["estimator"];
    assert_eq!(
        row["restarts"],
        estimator["restarts"].to_string(),
        "seed {seed}"
    );
    assert_eq!(
        row["rejected_convergences"],
        estimator["rejected_convergences"].to_string()
    );
    assert_eq!(row["error"], "", "seed {seed}");
    let metrics = run.join("metrics.json");
    assert!(
        !header.contains(&"realtime_factor".to_string()),
        "wall clock"
    );
    if !metrics.is_file() {
        // Never converged: no metrics, and so empty metric cells.
        assert_eq!(row["converged"], "false", "seed {seed}");
        assert!(stats["converged_at_s"].is_null());
        for key in [
            "ate_rmse_m",
            "convergence_time_s",
            "max_error_after_convergence_m",
        ] {
            assert_eq!(row[key], "", "seed {seed} {key}");
        }
        return;
    }
    assert_eq!(row["converged"], "true", "seed {seed}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(metrics).unwrap()).unwrap();
    let mut expected = BTreeMap::new();
    leaves(&json, "", &mut expected);
    expected.remove("realtime_factor");
    for (key, value) in &expected {
        let cell = row.get(key).unwrap_or_else(|| panic!("no column {key}"));
        let got: serde_json::Value = if cell.is_empty() {
            serde_json::Value::Null
        } else {
            serde_json::from_str(cell).unwrap()
        };
        assert_eq!(&got, value, "seed {seed} {key}");
    }
    assert_eq!(
        row["max_error_after_convergence_m"],
        row["position_error_max_m"]
    );
}

/// `runs.csv` without its `wall_s` column.
fn without_wall(dir: &Path) -> (Vec<String>, Vec<BTreeMap<String, String>>) {
    let (mut header, mut rows) = read_runs(dir);
    header.retain(|h| h != "wall_s");
    for r in &mut rows {
        assert!(r.remove("wall_s").unwrap().parse::<f64>().unwrap() > 0.0);
    }
    (header, rows)
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn sweep_rows_match_simulate_and_run_and_shards_merge_to_the_same() {
    let tmp = temp_dir("main");
    let whole = tmp.join("whole");
    let out = wins(
        &tmp,
        &[
            "sweep",
            "--scenario",
            "paper-circle",
            "--seeds",
            "1..8",
            "--jobs",
            "2",
            "--duration-s",
            DURATION_S,
            "--airborne",
            "--out",
            s(&whole),
        ],
    );
    let printed = String::from_utf8(out.stdout).unwrap();
    assert!(printed.contains("8 runs"), "{printed}");
    assert!(printed.contains("over the converged runs"), "{printed}");
    for f in [
        "runs.csv",
        "summary.json",
        "plan.json",
        "position_error.png",
    ] {
        assert!(whole.join(f).is_file(), "{f}");
    }
    assert!(
        !whole.join(".datasets").exists(),
        "temporary datasets deleted"
    );

    // (1) Rows in canonical order, each what `wins simulate` + `wins run` give.
    let (header, rows) = read_runs(&whole);
    let seeds: Vec<&str> = rows.iter().map(|r| r["seed"].as_str()).collect();
    assert_eq!(seeds, ["1", "2", "3", "4", "5", "6", "7", "8"]);
    for r in rows
        .iter()
        .filter(|r| CHECKED_SEEDS.iter().any(|s| r["seed"] == s.to_string()))
    {
        check_against_simulate_and_run(&tmp, r, &header, true);
    }
    // The summary counts the rows: converged, never converged, failed.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(whole.join("summary.json")).unwrap())
            .unwrap();
    let s0 = &summary["scenarios"][0];
    let count =
        |f: &dyn Fn(&BTreeMap<String, String>) -> bool| rows.iter().filter(|r| f(r)).count();
    let failed = count(&|r| !r["error"].is_empty());
    let converged = count(&|r| r["error"].is_empty() && r["converged"] == "true");
    let never = count(&|r| r["error"].is_empty() && r["converged"] == "false");
    assert_eq!(s0["runs"], 8);
    assert_eq!(s0["failed"], failed);
    assert_eq!(s0["converged"], converged);
    assert_eq!(s0["never_converged"], never);
    assert_eq!(s0["ate_rmse_m"]["count"], converged);
    // Airborne, the paper's flight converges on most seeds within 40 s, so the rows compared
    // above and the statistics merged below carry numbers.
    assert!(converged >= 6, "{converged} of 8 converged");

    // (2) Three shards, run side by side, merged: the same outputs.
    let shards: Vec<PathBuf> = (1..=3).map(|k| tmp.join(format!("shard{k}"))).collect();
    std::thread::scope(|scope| {
        for (k, dir) in shards.iter().enumerate() {
            let shard = format!("{}/3", k + 1);
            let tmp = &tmp;
            scope.spawn(move || {
                wins(
                    tmp,
                    &[
                        "sweep",
                        "--scenario",
                        "paper-circle",
                        "--seeds",
                        "1..8",
                        "--jobs",
                        "1",
                        "--duration-s",
                        DURATION_S,
                        "--airborne",
                        "--shard",
                        &shard,
                        "--out",
                        s(dir),
                    ],
                )
            });
        }
    });
    let merged = tmp.join("merged");
    let mut args = vec!["sweep", "merge"];
    args.extend(shards.iter().map(|d| s(d)));
    args.extend(["--out", s(&merged)]);
    wins(&tmp, &args);
    let bytes = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    assert!(
        bytes(&whole, "summary.json") == bytes(&merged, "summary.json"),
        "summary.json differs"
    );
    assert_eq!(without_wall(&whole), without_wall(&merged));
    // A shard missing: refused, naming it.
    let out = common::wins_in(
        &tmp,
        &[
            "sweep",
            "merge",
            s(&shards[0]),
            s(&shards[2]),
            "--out",
            s(&tmp.join("gap")),
        ],
    );
    assert!(!out.status.success());
    let err = common::stderr(&out);
    assert!(err.contains("missing") && err.contains("2/3"), "{err}");

    // (3) A non-empty output directory is refused before any run.
    let out = common::wins_in(
        &tmp,
        &[
            "sweep",
            "--scenario",
            "paper-circle",
            "--seeds",
            "1",
            "--out",
            s(&whole),
        ],
    );
    assert!(!out.status.success());
    assert!(
        common::stderr(&out).contains("is not empty"),
        "{}",
        common::stderr(&out)
    );
    std::fs::remove_dir_all(&tmp).unwrap();
}

/// A one-run sweep of a built-in flight as shipped (on the ground first), checked against
/// `wins simulate` + `wins run` like the rows above; its dataset is deleted, or kept with
/// `--keep`.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_converged_row_matches_and_datasets_are_deleted_unless_kept() {
    let tmp = temp_dir("keep");
    for keep in [false, true] {
        let out = tmp.join(format!("keep-{keep}"));
        let mut args = vec![
            "sweep",
            "--scenario",
            "paper-circle-3ap",
            "--seeds",
            "1",
            "--duration-s",
            DURATION_S,
            "--out",
            s(&out),
        ];
        if keep {
            args.push("--keep");
        }
        wins(&tmp, &args);
        let dataset = out.join(".datasets/paper-circle-3ap-1");
        assert_eq!(dataset.join("dataset.toml").is_file(), keep);
        assert_eq!(out.join(".datasets").exists(), keep);
        let (header, rows) = read_runs(&out);
        assert_eq!(rows.len(), 1);
        if !keep {
            check_against_simulate_and_run(&tmp, &rows[0], &header, false);
        }
    }
    std::fs::remove_dir_all(&tmp).unwrap();
}
