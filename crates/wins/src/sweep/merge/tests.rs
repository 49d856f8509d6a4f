use super::*;
use crate::sweep::plan::tests::temp_dir;
use crate::sweep::table::tests::{converged_row, sample_metrics};
use crate::sweep::{Plan, Seeds, Shard, write_outputs};

/// A plan of two scenarios × seeds 1..5 and made-up rows for it: converged ones with the
/// second scenario's having another AP set, a never-converged run and a failed one.
fn plan_and_rows(seeds: &str) -> (Plan, Vec<RunRow>) {
    let names = vec!["hover".to_string(), "paper-circle".to_string()];
    let plan = Plan::new(
        &names,
        &[],
        Seeds::parse(seeds).unwrap(),
        None,
        None,
        None,
        false,
    )
    .unwrap();
    let m = sample_metrics();
    let mut one_ap = m.clone();
    one_ap.ap_position_error_m.remove("ap1");
    let rows = plan
        .runs()
        .iter()
        .map(|r| {
            let label = &plan.scenarios[r.scenario].label;
            let mut metrics = if r.scenario == 0 {
                m.clone()
            } else {
                one_ap.clone()
            };
            metrics.ate_rmse_m += r.seed as f64 / 7.0;
            match r.seed {
                2 => RunRow::failed(label, r.seed, String::new()),
                4 if r.scenario == 1 => RunRow::failed(label, r.seed, "pipeline: x".into()),
                _ => converged_row(label, r.seed, &metrics),
            }
        })
        .collect();
    (plan, rows)
}

/// Writes the outputs of `rows` (those of `shard`) into a new directory `name`.
fn write_dir(name: &str, plan: &Plan, rows: &[RunRow], shard: Option<Shard>) -> PathBuf {
    let dir = temp_dir(name);
    let record = plan.record(shard).unwrap();
    let mine: Vec<RunRow> = rows
        .iter()
        .filter(|r| {
            let i = record.run_index(&r.scenario, r.seed).unwrap();
            shard.is_none_or(|s| s.keeps(i))
        })
        .cloned()
        .collect();
    let labels: Vec<String> = plan.scenarios.iter().map(|s| s.label.clone()).collect();
    let summary = summarize(&record.plan_id, &record.wins_version, &labels, &mine);
    let columns = crate::sweep::table::metric_columns(&mine);
    write_outputs(&dir, &record, &columns, &mine, &summary).unwrap();
    dir
}

fn shard(index: usize, count: usize) -> Option<Shard> {
    Some(Shard { index, count })
}

fn merge_error(dirs: &[PathBuf]) -> String {
    match merge_dirs(dirs) {
        Err(SweepError::Merge(m)) => m,
        other => panic!("{other:?}"),
    }
}

#[test]
fn shards_merge_into_the_unsharded_outputs() {
    let (plan, rows) = plan_and_rows("1..5");
    let whole = write_dir("merge-whole", &plan, &rows, None);
    let shards: Vec<PathBuf> = (1..=3)
        .map(|k| write_dir(&format!("merge-shard{k}"), &plan, &rows, shard(k, 3)))
        .collect();
    // Any order of the directories.
    let reversed: Vec<PathBuf> = shards.iter().rev().cloned().collect();
    let merged = merge_dirs(&reversed).unwrap();
    assert_eq!(merged.record.shard, None);
    assert_eq!(merged.rows.len(), 10);
    let out = temp_dir("merge-out");
    merged.write(&out).unwrap();
    for file in [RUNS_FILE, super::super::SUMMARY_FILE, PLAN_FILE] {
        let a = std::fs::read(whole.join(file)).unwrap();
        let b = std::fs::read(out.join(file)).unwrap();
        assert!(a == b, "{file} differs");
    }
    for d in shards.iter().chain([&whole, &out]) {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn merge_refuses_other_plans_duplicates_strays_and_gaps() {
    let (plan, rows) = plan_and_rows("1..5");
    let s1 = write_dir("refuse-s1", &plan, &rows, shard(1, 3));
    let s2 = write_dir("refuse-s2", &plan, &rows, shard(2, 3));
    let s3 = write_dir("refuse-s3", &plan, &rows, shard(3, 3));

    let (other_plan, other_rows) = plan_and_rows("1..6");
    let other = write_dir("refuse-other", &other_plan, &other_rows, shard(3, 3));
    let e = merge_error(&[s1.clone(), s2.clone(), other.clone()]);
    assert!(
        e.contains("different plans") && e.contains("seeds 1..5 vs 1..6"),
        "{e}"
    );

    let e = merge_error(&[s1.clone(), s2.clone(), s3.clone(), s2.clone()]);
    assert!(
        e.contains("found twice") && e.contains("hover seed 2"),
        "{e}"
    );

    let e = merge_error(&[s1.clone(), s3.clone()]);
    assert!(e.contains("3 of the plan's 10 runs are missing"), "{e}");
    assert!(
        e.contains("hover seed 2") && e.contains("shards not given: 2/3"),
        "{e}"
    );

    // A row of another scenario in a shard's runs.csv.
    let stray = write_dir("refuse-stray", &plan, &rows, shard(2, 3));
    let csv = stray.join(RUNS_FILE);
    let text = std::fs::read_to_string(&csv).unwrap();
    std::fs::write(&csv, text.replacen("\nhover,", "\nwarehouse,", 1)).unwrap();
    let e = merge_error(&[s1.clone(), stray.clone(), s3.clone()]);
    assert!(
        e.contains("run warehouse seed") && e.contains("not in the plan"),
        "{e}"
    );

    assert!(merge_error(&[]).contains("no directories"));
    let empty = temp_dir("refuse-empty");
    assert!(matches!(
        merge_dirs(std::slice::from_ref(&empty)),
        Err(SweepError::Read { .. })
    ));
    for d in [s1, s2, s3, other, stray, empty] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
