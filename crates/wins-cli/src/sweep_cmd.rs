//! `wins sweep`: the estimator over many simulated flights (scenarios and flight families ×
//! seeds), on all cores, shardable across machines; `wins sweep merge` joins the shards.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use wins::csi::format::CaptureFormat;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use wins::sweep::summary::Outcome;
use wins::sweep::{self, Merged, Plan, Progress, RunRow, Seeds, Shard, SweepOptions, SweepSummary};
use wins_plot::{StripGroup, StripPlot, strip_plot_png};

/// The figure written beside `runs.csv`.
const FIGURE_FILE: &str = "position_error.png";
const FIGURE_WIDTH_PX: u32 = 900;
/// Width given to each scenario when there are many, so that their labels do not overlap, px.
const FIGURE_PX_PER_SCENARIO: u32 = 170;
const FIGURE_HEIGHT_PX: u32 = 550;

/// Arguments of `wins sweep`.
#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    command: Option<SweepCommand>,
    /// Plan file (TOML: `scenarios` and/or `families`, `seeds`, optional `duration_s`, `config`
    /// and `airborne`), instead of --scenario, --family and --seeds.
    #[arg(
        value_name = "PLAN",
        conflicts_with_all = ["scenario", "family", "seeds", "duration_s", "config", "airborne", "card"]
    )]
    plan: Option<PathBuf>,
    /// Scenarios, comma-separated or repeated: built-in names (`wins simulate --list`) and
    /// scenario files (`*.toml`) side by side.
    #[arg(long, value_delimiter = ',', required_unless_present_any = ["plan", "family"])]
    scenario: Vec<String>,
    /// Flight families, comma-separated or repeated (`wins simulate --list-families`): each
    /// seed flies the flight drawn from it; each run's scenario is kept in OUT/scenarios/.
    #[arg(long, value_delimiter = ',')]
    family: Vec<String>,
    /// Seeds: `1..20` (inclusive: 20 seeds), a list `1,5,9`, or both `1..10,15`.
    #[arg(long, required_unless_present = "plan")]
    seeds: Option<String>,
    /// Output directory: must be new or empty.
    #[arg(long, short, required = true)]
    out: Option<PathBuf>,
    /// Flight duration of every scenario, s (default: each scenario's own).
    #[arg(long, value_name = "SECONDS")]
    duration_s: Option<f64>,
    /// Pipeline settings (TOML, as for `wins run --config`; default: the defaults).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Worker threads (0: one per core).
    #[arg(long, short, default_value_t = 0)]
    jobs: usize,
    /// Run only shard K of N: the runs whose index i (scenario-major, then seed, from 0) has
    /// i % N = K − 1. Join the shards with `wins sweep merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// Keep each run's dataset in OUT/.datasets/<scenario>-<seed>/.
    #[arg(long)]
    keep: bool,
    /// Fly every scenario airborne from t = 0: drop its phases (rest on the ground, take-off,
    /// landing).
    #[arg(long)]
    airborne: bool,
    /// Fly every scenario with this card: `intel5300` or `atheros` (default: each scenario's
    /// own, the Intel 5300 for the built-in ones and the families).
    #[arg(long)]
    card: Option<CaptureFormat>,
}

#[derive(clap::Subcommand)]
enum SweepCommand {
    /// Join the output directories of a sharded sweep into the outputs of the whole plan.
    Merge(MergeArgs),
}

#[derive(clap::Args)]
struct MergeArgs {
    /// The shards' output directories.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Output directory: must be new or empty.
    #[arg(long, short)]
    out: PathBuf,
}

pub fn sweep(args: SweepArgs) -> Result<()> {
    if let Some(SweepCommand::Merge(m)) = args.command {
        return merge(m);
    }
    let Some(out) = args.out else {
        anyhow::bail!("--out is required");
    };
    let plan = match &args.plan {
        Some(path) => Plan::from_file(path)?,
        None => {
            let seeds = Seeds::parse(args.seeds.as_deref().unwrap_or_default())?;
            Plan::new(
                &args.scenario,
                &args.family,
                seeds,
                args.duration_s,
                args.config.as_deref(),
                None,
                args.airborne,
            )?
            .with_card(args.card)?
        }
    };
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?;
    let options = SweepOptions {
        jobs: args.jobs,
        shard,
        keep_datasets: args.keep,
    };
    let total = plan.runs_of(shard).len();
    let bar = progress_bar(total as u64);
    let report = sweep::run_sweep(&plan, &out, &options, &|p: Progress<'_>| {
        bar.set_position(p.done as u64);
        bar.set_message(describe(p.row));
    })?;
    bar.finish_and_clear();
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    let figure = draw_or_warn(&out, &report.summary, &report.rows);
    let mut stdout = std::io::stdout().lock();
    let what = match shard {
        Some(s) => format!(
            "shard {s}: {} of the plan's {} runs",
            total, report.record.runs
        ),
        None => runs(total),
    };
    writeln!(stdout, "{what} (plan {})", report.record.plan_id)?;
    write!(stdout, "{}", report.summary)?;
    for p in report.files.iter().chain(&figure) {
        writeln!(stdout, "wrote {}", p.display())?;
    }
    let drawn = out.join(sweep::SCENARIOS_DIR);
    if drawn.is_dir() {
        writeln!(stdout, "kept the drawn scenarios in {}", drawn.display())?;
    }
    if args.keep {
        let kept = out.join(sweep::DATASETS_DIR);
        writeln!(stdout, "kept the datasets in {}", kept.display())?;
    }
    Ok(())
}

fn merge(args: MergeArgs) -> Result<()> {
    sweep::prepare_out_dir(&args.out)?;
    let merged = sweep::merge_dirs(&args.dirs)?;
    let mut files = merged.write(&args.out)?;
    let Merged {
        record,
        rows,
        summary,
        ..
    } = merged;
    let scenarios = sweep::copy_scenario_files(&args.dirs, &args.out)?;
    files.extend(draw_or_warn(&args.out, &summary, &rows));
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{} from {} directories (plan {})",
        runs(rows.len()),
        args.dirs.len(),
        record.plan_id
    )?;
    write!(stdout, "{summary}")?;
    for p in &files {
        writeln!(stdout, "wrote {}", p.display())?;
    }
    if !scenarios.is_empty() {
        let dir = args.out.join(sweep::SCENARIOS_DIR);
        writeln!(
            stdout,
            "copied the scenarios of {} drawn flights to {}",
            scenarios.len(),
            dir.display()
        )?;
    }
    Ok(())
}

/// `1 run`, `8 runs`.
fn runs(n: usize) -> String {
    format!("{n} run{}", if n == 1 { "" } else { "s" })
}

/// A bar on stderr when it is a terminal, hidden otherwise.
fn progress_bar(total: u64) -> ProgressBar {
    let bar = ProgressBar::new(total);
    if std::io::stderr().is_terminal() {
        bar.set_style(
            ProgressStyle::with_template("{pos}/{len} [{bar:40}] {elapsed} (ETA {eta}) {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
    } else {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar
}

/// One finished run, in a few words.
fn describe(row: &RunRow) -> String {
    let what = match Outcome::of(row) {
        Outcome::Failed => "failed".to_string(),
        Outcome::NeverConverged => "never converged".to_string(),
        Outcome::Converged => match row.metric("ate_rmse_m") {
            Some(ate) => format!("ATE {ate:.3} m"),
            None => "converged".to_string(),
        },
    };
    format!("{} seed {}: {what}", row.scenario, row.seed)
}

/// The figure, or a warning: the results are written already, and a machine without fonts
/// (a cluster node) must not turn a finished sweep into a failed job.
fn draw_or_warn(out: &Path, summary: &SweepSummary, rows: &[RunRow]) -> Vec<PathBuf> {
    draw(out, summary, rows).unwrap_or_else(|e| {
        eprintln!("warning: no figure: {e:#}");
        Vec::new()
    })
}

/// `position_error.png`: per scenario, the ATE RMSE of each converged run; the runs that are
/// not shown are counted under the scenario's name.
fn draw(out: &Path, summary: &SweepSummary, rows: &[RunRow]) -> Result<Vec<PathBuf>> {
    let values: Vec<Vec<f64>> = summary
        .scenarios
        .iter()
        .map(|s| {
            rows.iter()
                .filter(|r| r.scenario == s.scenario && Outcome::of(r) == Outcome::Converged)
                .filter_map(|r| r.metric("ate_rmse_m"))
                .collect()
        })
        .collect();
    let notes: Vec<String> = summary
        .scenarios
        .iter()
        .map(|s| {
            let mut note = format!("{}/{} converged", s.converged, s.runs);
            if s.failed > 0 {
                note.push_str(&format!(", {} failed", s.failed));
            }
            note
        })
        .collect();
    let groups: Vec<StripGroup> = summary
        .scenarios
        .iter()
        .zip(&values)
        .zip(&notes)
        .map(|((s, values), note)| StripGroup {
            label: &s.scenario,
            note,
            values,
        })
        .collect();
    let plot = StripPlot {
        title: "ATE RMSE per converged run (bar: median)",
        y_label: "ATE RMSE (m)",
        groups: &groups,
    };
    // plotters picks the encoder from the extension: the temporary name ends in .png too.
    let path = out.join(FIGURE_FILE);
    let tmp = out.join(format!(".tmp.{FIGURE_FILE}"));
    let width_px =
        FIGURE_WIDTH_PX.max(FIGURE_PX_PER_SCENARIO.saturating_mul(groups.len() as u32 + 1));
    strip_plot_png(&tmp, &plot, width_px, FIGURE_HEIGHT_PX)
        .with_context(|| format!("drawing {}", path.display()))?;
    std::fs::rename(&tmp, &path).with_context(|| format!("writing {}", path.display()))?;
    Ok(vec![path])
}
