use super::*;
use crate::sweep::table::tests::{converged_row, sample_metrics};

fn sorted(v: &[f64]) -> Vec<f64> {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v
}

/// Each expected value is numpy 2.4's `repr(float(np.percentile(x, q)))`.
#[test]
fn percentile_is_numpys_linear_to_the_bit() {
    let cases: [(&[f64], f64, f64); 12] = [
        (&[0.3, 1.2, 0.7, 2.5], 0.5, 0.95),
        (&[0.3, 1.2, 0.7, 2.5], 0.9, 2.1100000000000003),
        (
            &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
            0.5,
            0.55,
        ),
        (
            &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
            0.9,
            0.91,
        ),
        (
            &[
                4.185667441453079,
                1.1049619296521276,
                4.400231,
                0.8123,
                3.3,
                2.9999,
                0.01,
            ],
            0.9,
            4.271492864871847,
        ),
        (&[5.0], 0.5, 5.0),
        (&[5.0], 0.9, 5.0),
        (&[1.0, 2.0], 0.5, 1.5),
        (&[1.0, 2.0], 0.9, 1.9),
        // Where x[i] + (x[i+1] − x[i])·g would give 3.6065000000000005: numpy computes from
        // the upper neighbour when g ≥ 0.5.
        (&[1.469, 3.844], 0.9, 3.6065),
        // numpy.median gives 1.09 here; numpy.percentile(x, 50), which this is, does not.
        (&[2.994, 0.424, 0.14, 1.756], 0.5, 1.0899999999999999),
        (&[2.994, 0.424, 0.14, 1.756], 1.0, 2.994),
    ];
    for (x, q, expected) in cases {
        let got = percentile(&sorted(x), q).unwrap();
        assert_eq!(got.to_bits(), expected.to_bits(), "{x:?} q {q}: {got}");
    }
    assert_eq!(percentile(&[], 0.5), None);
    assert_eq!(percentile(&[1.0, 3.0], 0.0), Some(1.0));
}

#[test]
fn spread_leaves_out_non_finite_values() {
    let s = Spread::of([3.0, f64::NAN, 1.0, 2.0]);
    assert_eq!(s.count, 3);
    assert_eq!(
        (s.median, s.p90, s.worst),
        (Some(2.0), Some(2.8), Some(3.0))
    );
    let none = Spread::of([]);
    assert_eq!((none.count, none.median, none.worst), (0, None, None));
}

#[test]
fn never_converged_and_failed_runs_are_counted_not_averaged() {
    let m = sample_metrics();
    let mut far = m.clone();
    far.ate_rmse_m = 3.0;
    far.position_nees_mean = Some(5.0);
    far.position_error_max_m = 5.0;
    let mut never = RunRow::failed("a", 3, String::new());
    never.restarts = Some(0);
    never.rejected_convergences = Some(4);
    // The far run was also lost: its poses cover half the flight after convergence.
    let mut far_row = converged_row("a", 2, &far);
    far_row.pose_coverage = Some(0.5);
    let mut whole = converged_row("a", 1, &m);
    whole.pose_coverage = Some(1.0);
    let rows = vec![
        whole,
        far_row,
        never,
        RunRow::failed("a", 4, "simulation: boom".into()),
        RunRow::failed("b", 1, String::new()),
    ];
    let labels = vec!["a".to_string(), "b".to_string(), "c".to_string()];
    let s = summarize("id", "0.1.0", &labels, &rows);
    let a = &s.scenarios[0];
    assert_eq!(
        (a.runs, a.converged, a.never_converged, a.failed),
        (4, 2, 1, 1)
    );
    assert_eq!(a.error_over_2m_after_convergence, 1);
    assert_eq!(a.lost, 1);
    assert_eq!(a.ate_rmse_m.count, 2);
    let mean = m.ate_rmse_m / 2.0 + 3.0 / 2.0;
    assert!((a.ate_rmse_m.median.unwrap() - mean).abs() < 1e-12);
    assert_eq!(a.ate_rmse_m.worst, Some(3.0));
    assert_eq!(a.convergence_time_s.count, 2);
    // Only the run that reported a covariance has a NEES: one run's band is χ²(3)'s.
    assert_eq!(a.position_nees_mean.count, 1);
    assert_eq!(a.position_nees_mean_over_runs, Some(5.0));
    let [lo, hi] = a.position_nees_band.unwrap();
    assert!(lo < 0.3 && (9.0..10.0).contains(&hi), "{lo} {hi}");
    let b = &s.scenarios[1];
    assert_eq!((b.runs, b.never_converged, b.converged), (1, 1, 0));
    assert_eq!(b.ate_rmse_m.median, None);
    assert_eq!(
        (b.position_nees_mean_over_runs, b.position_nees_band),
        (None, None)
    );
    let c = &s.scenarios[2];
    assert_eq!(c.runs, 0);
    // The JSON reads back, and the table names every scenario with its counts.
    let back: SweepSummary = serde_json::from_str(&s.to_json()).unwrap();
    assert_eq!(back.scenarios.len(), 3);
    let table = s.to_string();
    assert!(table.contains("over the converged runs"), "{table}");
    assert!(table.contains("5.00 [0."), "{table}");
    let line_a = table.lines().find(|l| l.starts_with("a ")).unwrap();
    let cells: Vec<&str> = line_a.split_whitespace().collect();
    assert_eq!(&cells[..7], ["a", "4", "2", "1", "1", "1", "1"], "{line_a}");
    assert!(
        table
            .lines()
            .any(|l| l.starts_with("b ") && l.contains("– / – / –"))
    );
}

#[test]
fn a_familys_runs_break_down_by_their_labels() {
    let m = sample_metrics();
    let row = |seed: u64, aps: &str, rate: &str, converged: bool| {
        let mut r = converged_row("room", seed, &m);
        r.converged = converged;
        if !converged {
            r.metrics.clear();
        }
        r.labels = vec![
            ("aps".to_string(), aps.to_string()),
            ("imu".to_string(), "consumer".to_string()),
            ("packet_rate_hz".to_string(), rate.to_string()),
        ];
        r
    };
    let rows = vec![
        row(1, "10", "12", true),
        row(2, "2", "99", false),
        row(3, "2", "30", true),
        converged_row("hover", 1, &m),
    ];
    let labels = ["hover".to_string(), "room".to_string()];
    let s = summarize("id", "v", &labels, &rows);
    // Only the family is broken down, by every label of BREAKDOWNS (absent ones: no group).
    assert!(s.breakdowns.iter().all(|b| b.scenario == "room"));
    let by = |label: &str| s.breakdowns.iter().find(|b| b.label == label).unwrap();
    let aps = by("aps");
    let values: Vec<&str> = aps.groups.iter().map(|g| g.value.as_str()).collect();
    assert_eq!(values, ["2", "10"], "numbers sort as numbers");
    let two = &aps.groups[0].summary;
    assert_eq!((two.runs, two.converged, two.never_converged), (2, 1, 1));
    let rate = by("packet_rate_hz");
    let values: Vec<&str> = rate.groups.iter().map(|g| g.value.as_str()).collect();
    assert_eq!(values, ["10–25", "25–50", "50–100"]);
    assert!(by("start").groups.is_empty());
    let table = s.to_string();
    assert!(table.contains("room, by what was drawn:"), "{table}");
    assert!(table.contains("\npacket_rate_hz 50–100 "), "{table}");
    assert!(table.contains("\nimu consumer "), "{table}");
    // A sweep without a family writes no breakdowns at all.
    let plain = summarize("id", "v", &labels[..1], &rows[3..]);
    assert!(!plain.to_json().contains("breakdowns"));
    let back: SweepSummary = serde_json::from_str(&s.to_json()).unwrap();
    assert_eq!(back, s);
}
