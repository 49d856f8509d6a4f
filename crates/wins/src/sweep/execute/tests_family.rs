//! A sweep of a flight family: the drawn labels as columns, each run's scenario kept, the
//! breakdown tables, and shards that merge into the same outputs.

use super::*;
use crate::sim::Scenario;
use crate::sim::family::{BREAKDOWNS, Family, FamilyError};
use crate::sweep::plan::tests::temp_dir;
use crate::sweep::table::{LABEL_PREFIX, read_runs_csv};
use crate::sweep::{Seeds, copy_scenario_files, merge_dirs};

/// The family `room`, seeds 1 and 4, 20 s flights (the shortest a ground start allows; both
/// converge and are scored).
fn family_plan() -> Plan {
    Plan::new(
        &[],
        &["room".to_string()],
        Seeds::parse("1,4").unwrap(),
        Some(20.0),
        None,
        None,
        false,
    )
    .unwrap()
}

#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn a_family_sweep_writes_its_labels_scenarios_and_breakdowns() {
    let plan = family_plan();
    assert_eq!(plan.scenarios[0].label, "room");
    assert_eq!(plan.scenarios[0].family, Some(Family::Room));
    let record = plan.record(None).unwrap();
    assert_eq!(record.scenarios[0].toml, Family::Room.plan_toml());
    let root = temp_dir("family-sweep");
    let one = root.join("one");
    let options = SweepOptions {
        jobs: 1,
        ..SweepOptions::default()
    };
    let report = run_sweep(&plan, &one, &options, &|_| {}).unwrap();

    // Labels: in the rows, as columns after the leading ones, read back the same.
    let (columns, rows) = read_runs_csv(&one.join(RUNS_FILE)).unwrap();
    assert_eq!(columns, report.columns);
    for (row, seed) in rows.iter().zip([1, 4]) {
        assert!(row.error.is_empty(), "seed {seed}: {}", row.error);
        let drawn = Family::Room
            .draw(seed)
            .unwrap()
            .with_overrides(Some(20.0), false)
            .unwrap();
        let expected: Vec<(String, String)> = drawn
            .flight
            .labels()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        assert_eq!(row.labels, expected);
        assert_eq!(row.label("duration_s"), Some("20"));
        // The run's scenario, kept: it is the flight that was flown.
        let kept = Scenario::from_file(&scenario_file(&one, "room", seed)).unwrap();
        assert_eq!(kept, drawn.scenario);
    }
    let labels = |rows: &[RunRow]| -> Vec<Vec<(String, String)>> {
        rows.iter().map(|r| r.labels.clone()).collect()
    };
    assert_eq!(labels(&rows), labels(&report.rows));
    let header = std::fs::read_to_string(one.join(RUNS_FILE)).unwrap();
    let header: Vec<&str> = header.lines().next().unwrap().split(',').collect();
    assert_eq!(
        &header[5..7],
        [
            format!("{LABEL_PREFIX}family"),
            format!("{LABEL_PREFIX}seed")
        ]
    );
    assert!(header.contains(&"drawn.packet_rate_hz") && header.contains(&"ate_rmse_m"));

    // The breakdowns: every label of BREAKDOWNS, each run in one group of each.
    let summary = &report.summary;
    assert_eq!(summary.breakdowns.len(), BREAKDOWNS.len());
    for (b, spec) in summary.breakdowns.iter().zip(BREAKDOWNS) {
        assert_eq!(
            (b.scenario.as_str(), b.label.as_str()),
            ("room", spec.label)
        );
        let runs: usize = b.groups.iter().map(|g| g.summary.runs).sum();
        assert_eq!(runs, 2, "{}", b.label);
        for g in &b.groups {
            let s = &g.summary;
            assert_eq!(s.runs, s.converged + s.never_converged + s.failed);
        }
    }
    let table = summary.to_string();
    assert!(table.contains("room, by what was drawn:"), "{table}");
    assert!(
        table.contains("\naps ") && table.contains("\npacket_rate_hz "),
        "{table}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(one.join(SUMMARY_FILE)).unwrap()).unwrap();
    assert_eq!(json["breakdowns"][0]["label"], "aps");

    // Shards merge into the same outputs, the scenarios copied along.
    let shards: Vec<PathBuf> = (1..=2)
        .map(|k| {
            let dir = root.join(format!("shard{k}"));
            let options = SweepOptions {
                jobs: 1,
                shard: Some(Shard { index: k, count: 2 }),
                keep_datasets: false,
            };
            run_sweep(&plan, &dir, &options, &|_| {}).unwrap();
            dir
        })
        .collect();
    let merged = merge_dirs(&shards).unwrap();
    let out = root.join("merged");
    prepare_out_dir(&out).unwrap();
    merged.write(&out).unwrap();
    let copied = copy_scenario_files(&shards, &out).unwrap();
    assert_eq!(
        copied,
        [
            scenario_file(&out, "room", 1),
            scenario_file(&out, "room", 4)
        ]
    );
    assert_eq!(
        std::fs::read(one.join(SUMMARY_FILE)).unwrap(),
        std::fs::read(out.join(SUMMARY_FILE)).unwrap()
    );
    for seed in [1, 4] {
        assert_eq!(
            std::fs::read(scenario_file(&one, "room", seed)).unwrap(),
            std::fs::read(scenario_file(&out, "room", seed)).unwrap()
        );
    }
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn family_plans_that_cannot_run_are_refused_before_any_run() {
    let new = |families: &[&str], duration_s: Option<f64>, airborne: bool| {
        let families: Vec<String> = families.iter().map(|s| s.to_string()).collect();
        Plan::new(
            &["hover".to_string()],
            &families,
            Seeds::parse("1..3").unwrap(),
            duration_s,
            None,
            None,
            airborne,
        )
    };
    let unknown = new(&["garage"], None, false).unwrap_err();
    assert!(
        matches!(&unknown, SweepError::Family(FamilyError::Unknown { .. })),
        "{unknown}"
    );
    assert!(unknown.to_string().contains("room, hall"), "{unknown}");
    assert!(matches!(
        new(&["room", "room"], None, false),
        Err(SweepError::DuplicateScenario { .. })
    ));
    let short = new(&["hall"], Some(10.0), false).unwrap_err();
    assert!(matches!(short, SweepError::Duration { .. }), "{short}");
    // In the air a short flight is fine.
    let plan = new(&["hall"], Some(10.0), true).unwrap();
    assert_eq!(plan.runs().len(), 6);
    let flight = plan.scenarios[1].flight(3, Some(10.0), true).unwrap();
    let drawn = flight.drawn.unwrap();
    assert_eq!((drawn.seed, drawn.duration_s), (3, 10.0));
    assert!(flight.scenario.phases.is_none());
    assert!(
        plan.scenarios[0]
            .flight(3, None, true)
            .unwrap()
            .drawn
            .is_none()
    );
}
