//! A flight family's runs broken down by what was drawn: for each label of
//! [`BREAKDOWNS`] (AP count, IMU class, packet-rate bins, start, calibration, trajectory,
//! bandwidth), the statistics of each group of runs, as the scenarios' are.

use serde::{Deserialize, Serialize};

use super::{RunRow, ScenarioSummary, summarize_runs};
use crate::sim::family::{BREAKDOWNS, LabelBreakdown};

/// One family's runs grouped by one label.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Breakdown {
    /// The family's label in the plan.
    pub scenario: String,
    /// The drawn label the runs are grouped by (`aps`, `imu`, `packet_rate_hz`, …).
    pub label: String,
    /// The groups that have runs, in order: bins increasing, values sorted (numbers as
    /// numbers).
    pub groups: Vec<GroupSummary>,
}

/// The statistics of one group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupSummary {
    /// The label's value (`2`, `consumer`), or its bin (`25–50`).
    pub value: String,
    /// The group's statistics, as a scenario's (its `scenario` is the family's label).
    pub summary: ScenarioSummary,
}

/// The breakdowns of every scenario of `labels` whose runs carry drawn labels (the flight
/// families), in the plan's order then [`BREAKDOWNS`]' order.
pub fn breakdowns(labels: &[String], rows: &[RunRow]) -> Vec<Breakdown> {
    let mut out = Vec::new();
    for scenario in labels {
        let mine: Vec<&RunRow> = rows.iter().filter(|r| &r.scenario == scenario).collect();
        if mine.iter().all(|r| r.labels.is_empty()) {
            continue;
        }
        for spec in BREAKDOWNS {
            out.push(Breakdown {
                scenario: scenario.clone(),
                label: spec.label.to_string(),
                groups: groups(scenario, spec, &mine),
            });
        }
    }
    out
}

/// The groups of `mine` by `spec`, in order; runs without the label (a failed draw) are in
/// none.
fn groups(scenario: &str, spec: &LabelBreakdown, mine: &[&RunRow]) -> Vec<GroupSummary> {
    // (bin, value as a number if it is one, value, runs)
    let mut found: Vec<(usize, Option<f64>, String, Vec<&RunRow>)> = Vec::new();
    for &row in mine {
        let Some((bin, value)) = row.label(spec.label).and_then(|v| spec.group(v)) else {
            continue;
        };
        match found.iter_mut().find(|g| g.2 == value) {
            Some(g) => g.3.push(row),
            None => {
                let number = value.parse::<f64>().ok();
                found.push((bin, number, value, vec![row]));
            }
        }
    }
    found.sort_by(|a, b| {
        a.0.cmp(&b.0)
            .then_with(|| match (a.1, b.1) {
                (Some(x), Some(y)) => x.total_cmp(&y),
                _ => std::cmp::Ordering::Equal,
            })
            .then_with(|| a.2.cmp(&b.2))
    });
    found
        .into_iter()
        .map(|(_, _, value, runs)| GroupSummary {
            summary: summarize_runs(scenario, &runs),
            value,
        })
        .collect()
}
