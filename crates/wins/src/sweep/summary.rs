//! `summary.json` and the printed table: per scenario, how many runs converged, never
//! converged or failed, and the median, 90th percentile and worst of the main errors over the
//! converged runs; the same per group of a flight family's runs, grouped by what was drawn.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::RunRow;
use crate::eval::mean_nees_band;
pub use breakdown::{Breakdown, GroupSummary, breakdowns};

mod breakdown;

/// `format` of `summary.json`.
pub const SUMMARY_FORMAT: &str = "wins-sweep-summary";
/// A converged run whose aligned position error ever exceeds this is counted in
/// [`ScenarioSummary::error_over_2m_after_convergence`], m.
pub const ERROR_THRESHOLD_M: f64 = 2.0;
/// A converged run whose poses cover less than this share of the flight after convergence is
/// counted in [`ScenarioSummary::lost`].
pub const COVERAGE_THRESHOLD: f64 = 0.9;
/// What the statistics are taken over, in words (`summary.json`'s `statistics_over`).
pub const STATISTICS_OVER: &str = "converged runs: runs that never converged or failed are \
                                   counted, not in the statistics";

/// The `q`-quantile (`0 ≤ q ≤ 1`) of `sorted` (increasing, finite) as numpy's default
/// (`numpy.quantile(x, q)`, method "linear"; `numpy.percentile(x, 100·q)`), to the bit:
/// the virtual index `(n − 1)·q` splits into `i + g`, and the value is `x[i] + (x[i+1] −
/// x[i])·g`, computed as `x[i+1] − (x[i+1] − x[i])·(1 − g)` when `g ≥ 0.5` as numpy does.
/// `None` for no values.
pub fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    let n = sorted.len();
    let last = n.checked_sub(1)?;
    let virtual_index = last as f64 * q;
    if virtual_index <= 0.0 {
        return sorted.first().copied();
    }
    if virtual_index >= last as f64 {
        return sorted.last().copied();
    }
    let below = virtual_index.floor();
    let gamma = virtual_index - below;
    let i = below as usize;
    let (a, b) = (sorted[i], sorted[(i + 1).min(last)]);
    let diff = b - a;
    Some(if gamma >= 0.5 {
        b - diff * (1.0 - gamma)
    } else {
        a + diff * gamma
    })
}

/// Median, 90th percentile and largest of one quantity over the converged runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spread {
    /// Converged runs that have the quantity.
    pub count: usize,
    /// `numpy.percentile(x, 50)` (null: no value).
    pub median: Option<f64>,
    /// `numpy.percentile(x, 90)`.
    pub p90: Option<f64>,
    /// The largest.
    pub worst: Option<f64>,
}

impl Spread {
    /// Of `values` (non-finite ones left out).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        Self {
            count: v.len(),
            median: percentile(&v, 0.5),
            p90: percentile(&v, 0.9),
            worst: v.last().copied(),
        }
    }
}

/// The statistics of one scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSummary {
    /// The scenario's label.
    pub scenario: String,
    /// Runs (converged + never converged + failed).
    pub runs: usize,
    /// Runs that converged and were scored: the statistics are over these.
    pub converged: usize,
    /// Runs whose estimator never converged (no error).
    pub never_converged: usize,
    /// Runs with an error (simulation, dataset, pipeline, or converged but not scorable).
    pub failed: usize,
    /// Converged runs whose aligned position error ever exceeds [`ERROR_THRESHOLD_M`] after
    /// convergence (`max_error_after_convergence_m > 2`).
    pub error_over_2m_after_convergence: usize,
    /// Converged runs whose poses cover less than [`COVERAGE_THRESHOLD`] of the flight after
    /// convergence (`pose_coverage`): the estimate was lost for a while, or for good. Their
    /// errors are over the poses they gave.
    pub lost: usize,
    /// ATE of the poses a flight controller is sent, as `wins live` sends them: the causal
    /// estimate, m (`sent.ate_rmse_m`).
    pub sent_ate_rmse_m: Spread,
    /// Time from the start of the flight to the first pose sent, s
    /// (`sent.time_to_first_s`).
    pub time_to_first_sent_s: Spread,
    /// ATE in hindsight: RMSE of the aligned position error of every converged pose, those
    /// made before the chain offsets' decision included, m (`ate_rmse_m`).
    pub ate_rmse_m: Spread,
    /// RMSE of the attitude error, deg (`attitude_error_rmse_deg`).
    pub attitude_error_rmse_deg: Spread,
    /// Largest per-AP position error of each run, m (`ap_position_error_max_m`).
    pub ap_position_error_max_m: Spread,
    /// Time from the start of the flight to the first converged pose, in hindsight (a held
    /// one included), s (`convergence_time_s`).
    pub convergence_time_s: Spread,
    /// Each run's mean position NEES (`position_nees_mean`; 3 when its covariance is honest).
    pub position_nees_mean: Spread,
    /// The mean over the converged runs of their mean position NEES (null: none has one).
    pub position_nees_mean_over_runs: Option<f64>,
    /// The 95 % band that mean lies in when the covariances are honest
    /// ([`crate::eval::mean_nees_band`] of the runs that have one; null: none has one).
    pub position_nees_band: Option<[f64; 2]>,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSummary {
    /// [`SUMMARY_FORMAT`].
    pub format: String,
    /// The plan's `plan_id` (`plan.json`).
    pub plan_id: String,
    /// The version of the `wins` library.
    pub wins_version: String,
    /// [`STATISTICS_OVER`].
    pub statistics_over: String,
    /// [`ERROR_THRESHOLD_M`].
    pub error_threshold_m: f64,
    /// Per scenario, in the plan's order.
    pub scenarios: Vec<ScenarioSummary>,
    /// Per flight family, in the plan's order, its runs broken down by each label of
    /// [`crate::sim::family::BREAKDOWNS`] (absent: no family).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub breakdowns: Vec<Breakdown>,
}

/// How a row counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Converged and scored.
    Converged,
    /// The estimator never converged.
    NeverConverged,
    /// An error (its text in the row).
    Failed,
}

impl Outcome {
    /// Of `row`: an error first, then convergence.
    pub fn of(row: &RunRow) -> Self {
        if !row.error.is_empty() {
            Self::Failed
        } else if row.converged {
            Self::Converged
        } else {
            Self::NeverConverged
        }
    }
}

/// The statistics of `rows` per scenario of `labels` (in that order), for the plan `plan_id`,
/// and each flight family's breakdown by its drawn labels ([`breakdowns`]).
pub fn summarize(
    plan_id: &str,
    wins_version: &str,
    labels: &[String],
    rows: &[RunRow],
) -> SweepSummary {
    let scenarios = labels
        .iter()
        .map(|label| {
            let mine: Vec<&RunRow> = rows.iter().filter(|r| &r.scenario == label).collect();
            summarize_runs(label, &mine)
        })
        .collect();
    SweepSummary {
        format: SUMMARY_FORMAT.to_string(),
        plan_id: plan_id.to_string(),
        wins_version: wins_version.to_string(),
        statistics_over: STATISTICS_OVER.to_string(),
        error_threshold_m: ERROR_THRESHOLD_M,
        scenarios,
        breakdowns: breakdowns(labels, rows),
    }
}

/// The statistics of the runs `mine`, under the name `label`.
pub fn summarize_runs(label: &str, mine: &[&RunRow]) -> ScenarioSummary {
    let count = |o: Outcome| mine.iter().filter(|r| Outcome::of(r) == o).count();
    let converged: Vec<&RunRow> = mine
        .iter()
        .copied()
        .filter(|r| Outcome::of(r) == Outcome::Converged)
        .collect();
    let nees: Vec<f64> = converged
        .iter()
        .filter_map(|r| r.metric("position_nees_mean"))
        .filter(|x| x.is_finite())
        .collect();
    let spread =
        |f: &dyn Fn(&RunRow) -> Option<f64>| Spread::of(converged.iter().filter_map(|r| f(r)));
    ScenarioSummary {
        scenario: label.to_string(),
        runs: mine.len(),
        converged: converged.len(),
        never_converged: count(Outcome::NeverConverged),
        failed: count(Outcome::Failed),
        error_over_2m_after_convergence: converged
            .iter()
            .filter(|r| {
                r.max_error_after_convergence_m
                    .is_some_and(|e| e > ERROR_THRESHOLD_M)
            })
            .count(),
        lost: converged
            .iter()
            .filter(|r| r.pose_coverage.is_some_and(|c| c < COVERAGE_THRESHOLD))
            .count(),
        sent_ate_rmse_m: spread(&|r| r.metric("sent.ate_rmse_m")),
        time_to_first_sent_s: spread(&|r| r.metric("sent.time_to_first_s")),
        ate_rmse_m: spread(&|r| r.metric("ate_rmse_m")),
        attitude_error_rmse_deg: spread(&|r| r.metric("attitude_error_rmse_deg")),
        ap_position_error_max_m: spread(&|r| r.ap_position_error_max_m),
        convergence_time_s: spread(&|r| r.metric("convergence_time_s")),
        position_nees_mean: spread(&|r| r.metric("position_nees_mean")),
        position_nees_mean_over_runs: mean_over(&nees),
        position_nees_band: (!nees.is_empty()).then(|| {
            let (lo, hi) = mean_nees_band(nees.len());
            [lo, hi]
        }),
    }
}

impl SweepSummary {
    /// `summary.json`'s text (pretty, with a final newline).
    pub fn to_json(&self) -> String {
        // Plain strings, integers and floats: serializing cannot fail.
        let mut s = serde_json::to_string_pretty(self).unwrap_or_default();
        s.push('\n');
        s
    }
}

fn mean_over(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// `mean [low, high]`: the mean NEES over the runs and its band, `–` for none.
fn nees_cell(s: &ScenarioSummary) -> String {
    match (s.position_nees_mean_over_runs, s.position_nees_band) {
        (Some(m), Some([lo, hi])) => format!("{m:.2} [{lo:.2}, {hi:.2}]"),
        _ => "–".to_string(),
    }
}

/// `median / p90 / worst` with `digits` decimals, `–` for none.
fn spread_cell(s: &Spread, digits: usize) -> String {
    let f = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.digits$}"));
    format!("{} / {} / {}", f(s.median), f(s.p90), f(s.worst))
}

/// The columns of the printed table after the first.
const TABLE_HEADER: [&str; 13] = [
    "runs",
    "conv",
    "never",
    "failed",
    ">2 m",
    "lost",
    "sent ATE (m)",
    "first sent (s)",
    "ATE, hindsight (m)",
    "attitude RMSE (deg)",
    "AP error max (m)",
    "converged, hindsight (s)",
    "NEES [95 % band]",
];

/// One line of statistics per `(name, summary)` under a header whose first column is `first`,
/// the columns aligned.
fn write_table(
    f: &mut fmt::Formatter<'_>,
    first: &str,
    lines: &[(String, &ScenarioSummary)],
) -> fmt::Result {
    let mut header = [first; 14];
    header[1..].copy_from_slice(&TABLE_HEADER);
    let rows: Vec<[String; 14]> = lines
        .iter()
        .map(|(name, s)| {
            [
                name.clone(),
                s.runs.to_string(),
                s.converged.to_string(),
                s.never_converged.to_string(),
                s.failed.to_string(),
                s.error_over_2m_after_convergence.to_string(),
                s.lost.to_string(),
                spread_cell(&s.sent_ate_rmse_m, 3),
                spread_cell(&s.time_to_first_sent_s, 1),
                spread_cell(&s.ate_rmse_m, 3),
                spread_cell(&s.attitude_error_rmse_deg, 2),
                spread_cell(&s.ap_position_error_max_m, 3),
                spread_cell(&s.convergence_time_s, 1),
                nees_cell(s),
            ]
        })
        .collect();
    let mut width = header.map(|h| h.chars().count());
    for r in &rows {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |f: &mut fmt::Formatter<'_>, cells: &[&str]| -> fmt::Result {
        let mut text = String::new();
        for (k, (c, w)) in cells.iter().zip(width).enumerate() {
            let pad = w - c.chars().count();
            if k == 0 {
                text.push_str(c);
                text.push_str(&" ".repeat(pad));
            } else {
                text.push_str("  ");
                text.push_str(&" ".repeat(pad));
                text.push_str(c);
            }
        }
        writeln!(f, "{}", text.trim_end())
    };
    line(f, &header)?;
    for r in &rows {
        line(f, &r.each_ref().map(String::as_str))?;
    }
    Ok(())
}

impl fmt::Display for SweepSummary {
    /// The table `wins sweep` prints: one line per scenario; then, per flight family, one line
    /// per group of its breakdowns.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "median / p90 / worst over the converged runs (never-converged and failed runs are \
             counted, not in the statistics); sent: the poses a flight controller is sent, as \
             `wins live` sends them (the causal estimate), scored alone; hindsight: every \
             converged pose, those held until the chain offsets were decided included; \
             >{ERROR_THRESHOLD_M} m: converged runs whose error \
             exceeds {ERROR_THRESHOLD_M} m after convergence; lost: converged runs whose poses \
             cover less than {:.0} % of the flight after convergence; NEES: the mean over the converged \
             runs of their mean position NEES, 3 when the reported covariance is honest, and the \
             band that mean lies in then",
            COVERAGE_THRESHOLD * 100.0
        )?;
        let lines: Vec<(String, &ScenarioSummary)> = self
            .scenarios
            .iter()
            .map(|s| (s.scenario.clone(), s))
            .collect();
        write_table(f, "scenario", &lines)?;
        for family in self.scenarios.iter().map(|s| &s.scenario) {
            let lines: Vec<(String, &ScenarioSummary)> = self
                .breakdowns
                .iter()
                .filter(|b| &b.scenario == family)
                .flat_map(|b| {
                    b.groups
                        .iter()
                        .map(move |g| (format!("{} {}", b.label, g.value), &g.summary))
                })
                .collect();
            if !lines.is_empty() {
                writeln!(f, "\n{family}, by what was drawn:")?;
                write_table(f, "group", &lines)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
