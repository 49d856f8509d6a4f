use nalgebra::{UnitQuaternion, Vector3};
use serde_json::Value;

use super::*;
use crate::dataset::truth::{ApRow, Pose};
use crate::eval::{EstimatedAp, EvalOptions, evaluate};
use crate::time::Timestamp;

/// Metrics of a wobbly estimate of a helix against the helix, with two APs: every field has a
/// value with all its digits.
pub(crate) fn sample_metrics() -> Metrics {
    let pose = |k: i64, wobble: f64| Pose {
        t: Timestamp(k * 20_000_000),
        p_b_in_w: Vector3::new(
            (k as f64 * 0.05).cos() * 2.5 + wobble * (k as f64 * 0.7).sin(),
            (k as f64 * 0.05).sin() * 2.5 + wobble * (k as f64 * 1.3).cos(),
            1.5 + 0.01 * k as f64,
        ),
        world_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, k as f64 * 0.05 + wobble),
    };
    let truth: Vec<Pose> = (0..200).map(|k| pose(k, 0.0)).collect();
    let est: Vec<Pose> = (0..200).map(|k| pose(k, 0.031)).collect();
    let ap = |name: &str, x_m: f64| EstimatedAp {
        name: name.into(),
        x_m,
        y_m: 4.0,
        z_m: 1.5,
        ..Default::default()
    };
    let truth_ap = |name: &str, x_m: f64| ApRow {
        name: name.into(),
        x_m,
        y_m: 4.0,
        z_m: 1.5,
    };
    let mut m = evaluate(
        &est,
        &truth,
        &[ap("ap0", 1.1), ap("ap1", 10.7)],
        &[truth_ap("ap0", 1.0), truth_ap("ap1", 11.0)],
        &EvalOptions::default(),
    )
    .unwrap();
    m.aoa_error_median_deg = Some(1.234_567_890_123);
    m.packets_used = Some(1234);
    m.packets_dropped = Some(56);
    m.realtime_factor = Some(77.7);
    m
}

pub(crate) fn converged_row(scenario: &str, seed: u64, metrics: &Metrics) -> RunRow {
    let mut row = RunRow::failed(scenario, seed, String::new());
    row.converged = true;
    row.restarts = Some(1);
    row.rejected_convergences = Some(2);
    row.set_metrics(metrics).unwrap();
    row.pose_coverage = Some(0.875);
    row.wall_s = 1.25;
    row
}

#[test]
fn metrics_flatten_in_serialization_order_with_paths_for_arrays_maps_and_nesting() {
    let m = sample_metrics();
    let flat = flatten(&m).unwrap();
    let keys: Vec<&str> = flat.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(keys[0], "ate_rmse_m");
    let at = |k: &str| keys.iter().position(|&x| x == k).unwrap();
    assert_eq!(
        at("position_error_std_xyz_m.1"),
        at("position_error_std_xyz_m.0") + 1
    );
    assert_eq!(
        at("ap_position_error_m.ap1"),
        at("ap_position_error_m.ap0") + 1
    );
    assert!(at("alignment.rotation_xyzw.3") > at("alignment.rotation_xyzw.0"));
    // Every top-level field of metrics.json has its column(s).
    let json = serde_json::to_value(&m).unwrap();
    for key in json.as_object().unwrap().keys() {
        assert!(
            keys.iter()
                .any(|k| k == key || k.starts_with(&format!("{key}."))),
            "{key}"
        );
    }
    // None is an empty cell.
    let mut none = m.clone();
    none.drift_last_60s_m = None;
    let flat = flatten(&none).unwrap();
    let drift = flat.iter().find(|(k, _)| k == "drift_last_60s_m").unwrap();
    assert_eq!(drift.1, "");
}

#[test]
fn every_cell_reads_back_to_the_bits_of_its_metric() {
    let m = sample_metrics();
    let json = serde_json::to_value(&m).unwrap();
    for (key, cell) in flatten(&m).unwrap() {
        let pointer = format!("/{}", key.replace('.', "/"));
        let v = json.pointer(&pointer).unwrap_or_else(|| panic!("{key}"));
        match v {
            Value::Null => assert_eq!(cell, "", "{key}"),
            Value::Number(n) if n.is_f64() => {
                let back: f64 = cell.parse().unwrap();
                assert_eq!(back.to_bits(), n.as_f64().unwrap().to_bits(), "{key}");
            }
            Value::Number(n) => assert_eq!(cell, n.to_string(), "{key}"),
            Value::Bool(b) => assert_eq!(cell, b.to_string(), "{key}"),
            other => panic!("{key}: unexpected leaf {other}"),
        }
    }
}

#[test]
fn wall_clock_metrics_and_fixed_columns_stay_apart() {
    let m = sample_metrics();
    let row = converged_row("s", 1, &m);
    assert!(row.metric("realtime_factor").is_none());
    for (k, _) in &row.metrics {
        assert!(!LEADING_COLUMNS.contains(&k.as_str()), "{k}");
        assert!(!TRAILING_COLUMNS.contains(&k.as_str()), "{k}");
    }
    // The columns the summary reads exist under these names.
    for key in [
        "ate_rmse_m",
        "attitude_error_rmse_deg",
        "convergence_time_s",
    ] {
        assert!(row.metric(key).is_some(), "{key}");
    }
    assert_eq!(
        row.max_error_after_convergence_m,
        Some(m.position_error_max_m)
    );
    let aps = &m.ap_position_error_m;
    assert_eq!(
        row.ap_position_error_max_m,
        Some(aps["ap0"].max(aps["ap1"]))
    );
}

#[test]
fn runs_csv_round_trips_byte_for_byte() {
    let m = sample_metrics();
    let mut one_ap = m.clone();
    one_ap.ap_position_error_m.remove("ap1");
    let mut failed = RunRow::failed("b", 3, "simulation: invalid scenario: x, \"y\"\nz".into());
    failed.wall_s = 0.5;
    let mut never = RunRow::failed("b", 4, String::new());
    never.restarts = Some(0);
    never.rejected_convergences = Some(3);
    let rows = vec![
        converged_row("a", 1, &m),
        converged_row("a", 2, &one_ap),
        failed,
        never,
    ];
    let columns = metric_columns(&rows);
    let bytes = runs_csv(&columns, &rows).unwrap();
    let dir = std::env::temp_dir().join(format!("wins-sweep-table-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("runs.csv");
    std::fs::write(&path, &bytes).unwrap();
    let (columns_back, rows_back) = read_runs_csv(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(columns_back, columns);
    assert_eq!(runs_csv(&columns_back, &rows_back).unwrap(), bytes);
    assert_eq!(rows_back[2].error, rows[2].error);
    assert_eq!(rows_back[3].rejected_convergences, Some(3));
    assert!(!rows_back[3].converged);
    for (a, b) in rows.iter().zip(&rows_back) {
        assert_eq!(a.metric("ate_rmse_m"), b.metric("ate_rmse_m"));
        assert_eq!(a.ap_position_error_max_m, b.ap_position_error_max_m);
    }
    // The second row has no ap1: an empty cell.
    let ap1 = columns
        .iter()
        .position(|c| c == "ap_position_error_m.ap1")
        .unwrap();
    let text = String::from_utf8(bytes).unwrap();
    let second = text.lines().nth(2).unwrap();
    let cells: Vec<&str> = second.split(',').collect();
    assert_eq!(cells[LEADING_COLUMNS.len() + ap1], "");
}

#[test]
fn a_file_that_is_not_a_runs_csv_is_refused() {
    let dir = std::env::temp_dir().join(format!("wins-sweep-table-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("runs.csv");
    std::fs::write(&path, "a,b\n1,2\n").unwrap();
    let err = read_runs_csv(&path).unwrap_err();
    assert!(err.to_string().contains("header"), "{err}");
    let header = [&LEADING_COLUMNS[..], &TRAILING_COLUMNS[..]]
        .concat()
        .join(",");
    std::fs::write(&path, format!("{header}\ns,x,true,,,,,,1.0,\n")).unwrap();
    let err = read_runs_csv(&path).unwrap_err();
    assert!(err.to_string().contains("line 2, column seed"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn columns_of_shards_merge_to_the_columns_of_the_whole() {
    let list = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let one_ap = list(&["ate", "aps.a", "packets"]);
    let three = list(&["ate", "aps.a", "aps.b", "aps.c", "packets"]);
    let other = list(&["ate", "aps.x", "packets"]);
    let whole = merge_columns([&one_ap[..], &three[..], &other[..]]);
    assert_eq!(
        whole,
        list(&["ate", "aps.a", "aps.b", "aps.c", "aps.x", "packets"])
    );
    // Shards: the headers of each part, merged, give the same.
    let part1 = merge_columns([&one_ap[..], &other[..]]);
    let part2 = merge_columns([&three[..]]);
    assert_eq!(merge_columns([&part2[..], &part1[..]]), whole);
    assert_eq!(merge_columns([&part1[..], &part2[..]]), whole);
    // Lists that disagree still give every column once.
    let cycle = merge_columns([&list(&["a", "b"])[..], &list(&["b", "a"])[..]]);
    assert_eq!(cycle, list(&["a", "b"]));
    assert!(merge_columns(std::iter::empty::<&[String]>()).is_empty());
}

#[test]
fn rows_that_were_not_scored_get_the_columns_of_a_scored_run() {
    let mut m = sample_metrics();
    m.ap_position_error_m.remove("ap1");
    let scored: Vec<String> = converged_row("a", 1, &m)
        .metrics
        .into_iter()
        .map(|(k, _)| k)
        .collect();
    assert_eq!(metric_keys(&["ap0".to_string()]), scored);
    let none = metric_keys(&[]);
    assert!(none.contains(&"ate_rmse_m".to_string()));
    assert!(!none.iter().any(|k| k.starts_with("ap_position_error_m.")));
}

#[test]
fn drawn_labels_are_columns_of_their_own_and_read_back() {
    let m = sample_metrics();
    let mut drawn = converged_row("room", 3, &m);
    drawn.labels = vec![
        ("family".to_string(), "room".to_string()),
        ("aps".to_string(), "2".to_string()),
        ("packet_rate_hz".to_string(), "37".to_string()),
    ];
    let plain = converged_row("hover", 1, &m);
    let rows = vec![plain.clone(), drawn.clone()];
    let columns = metric_columns(&rows);
    let bytes = runs_csv(&columns, &rows).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(
        header[LEADING_COLUMNS.len()..LEADING_COLUMNS.len() + 3],
        ["drawn.family", "drawn.aps", "drawn.packet_rate_hz"]
    );
    assert_eq!(header[LEADING_COLUMNS.len() + 3], columns[0]);

    let dir = crate::sweep::plan::tests::temp_dir("labels-csv");
    std::fs::write(dir.join("runs.csv"), &bytes).unwrap();
    let (read_columns, read) = read_runs_csv(&dir.join("runs.csv")).unwrap();
    assert_eq!(read_columns, columns);
    assert!(read[0].labels.is_empty(), "a scenario's run has no labels");
    assert_eq!(read[1].labels, drawn.labels);
    assert_eq!(read[1].label("aps"), Some("2"));
    assert_eq!(read[1].metric("ate_rmse_m"), drawn.metric("ate_rmse_m"));
    assert_eq!(runs_csv(&read_columns, &read).unwrap(), bytes);
    // Without a family, no label column at all.
    let text = String::from_utf8(runs_csv(&columns, &[plain]).unwrap()).unwrap();
    assert!(!text.contains(LABEL_PREFIX));
    std::fs::remove_dir_all(&dir).unwrap();
}
