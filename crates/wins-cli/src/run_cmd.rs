//! `wins run` and `wins demo`: replay a dataset through the pipeline, write the run directory,
//! score it against the truth when there is one, and draw the figures.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use wins::figures::RunFigures;
use wins::rig::ChainCalibration;
use wins::run::folder::{FolderRun, run_into_folder};
use wins::run::replay::Evaluation;
use wins::run::run_dir::{RunDir, RunInputs};
use wins::sim::{self, Scenario};
use wins::{Config, RunOptions, RunOutput};

use crate::draw::draw_run;

/// Arguments of `wins run`.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Dataset directory (`dataset.toml`, `imu.csv`, one `.dat` per AP; `truth/` optional).
    dataset: PathBuf,
    /// Output directory: new, empty or a previous run's (whose files are replaced); never the
    /// dataset folder, inside it, or holding an input file.
    #[arg(long, short)]
    out: PathBuf,
    /// Settings (TOML: `[aoa]`, `[pipeline]`, `[window]`, `[eval]`; missing keys take the
    /// defaults, see `wins config`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Chain calibration to use instead of the dataset's (a prior: a NIC restart's steps are
    /// resolved from the flight).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Use no chain calibration, not even the dataset's: the offsets are resolved from the
    /// flight alone.
    #[arg(long, conflicts_with = "calibration")]
    no_calibration: bool,
    /// Do not draw the PNG figures.
    #[arg(long)]
    no_plots: bool,
}

/// Arguments of `wins demo`.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Built-in scenario to fly (see `wins simulate --list`).
    #[arg(long, default_value = "paper-circle")]
    scenario: String,
    /// Override the scenario's seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Override the flight duration, s.
    #[arg(long, value_name = "SECONDS", visible_alias = "duration-s")]
    duration: Option<f64>,
    /// Start the flight in the air (no rest on the ground, take-off or landing): the start
    /// the paper's estimator needs; the default one starts from either.
    #[arg(long)]
    airborne: bool,
    /// Where the dataset and the run go.
    #[arg(long, short, default_value = "target/demo")]
    out: PathBuf,
    /// Settings (TOML, as for `wins run`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
}

pub fn run(args: RunArgs) -> Result<()> {
    let config = load_config(args.config.as_deref())?;
    let inputs = RunInputs {
        dataset: &args.dataset,
        config_file: args.config.as_deref(),
        calibration_file: args.calibration.as_deref(),
    };
    let dir = RunDir::prepare(&args.out, &inputs)?;
    let calibration = match &args.calibration {
        Some(p) => Some(ChainCalibration::load(p)?),
        None => None,
    };
    let options = RunOptions {
        calibration,
        imu_noise: None,
        no_calibration: args.no_calibration,
    };
    process(&dir, &inputs, &config, &options, !args.no_plots)
}

pub fn demo(args: DemoArgs) -> Result<()> {
    let scenario =
        Scenario::built_in(&args.scenario)?.with_overrides(args.seed, args.duration, args.airborne);
    let data_dir = args.out.join("dataset");
    let config = load_config(args.config.as_deref())?;
    let inputs = RunInputs {
        dataset: &data_dir,
        config_file: args.config.as_deref(),
        calibration_file: None,
    };
    let dir = RunDir::prepare(&args.out.join("run"), &inputs)?;
    let output = sim::simulate(&scenario, &mut |_| {})?;
    sim::write_dataset(&data_dir, &scenario, &output)?;
    println!(
        "simulated {} (seed {}, {:.0} s) into {}",
        scenario.name,
        scenario.seed,
        scenario.duration_s,
        data_dir.display()
    );
    process(&dir, &inputs, &config, &RunOptions::default(), true)
}

/// `--config FILE`, or the defaults.
pub fn load_config(path: Option<&Path>) -> Result<Config> {
    Ok(match path {
        Some(p) => Config::from_toml_file(p)?,
        None => Config::default(),
    })
}

/// Runs `inputs` into the checked folder `dir` ([`run_into_folder`]): the data files, the
/// figures, then the manifest last. A truth that cannot be read fails the command once
/// everything else is written.
fn process(
    dir: &RunDir,
    inputs: &RunInputs<'_>,
    config: &Config,
    options: &RunOptions,
    plots: bool,
) -> Result<()> {
    let mut figures = |_: &RunOutput, out: &Path| -> Result<Vec<PathBuf>, String> {
        if !plots {
            return Ok(Vec::new());
        }
        let figures = figures_of(out, inputs.dataset, config).map_err(|e| format!("{e:#}"))?;
        draw_run(out, &figures).map_err(|e| format!("{e:#}"))
    };
    let FolderRun { run, written } = run_into_folder(dir, inputs, config, options, &mut figures)?;
    for w in &run.warnings {
        eprintln!("warning: {w}");
    }
    let mut stdout = std::io::stdout().lock();
    summary(&mut stdout, &run)?;
    if let Some(m) = &run.metrics {
        write!(stdout, "{}", m.report())?;
    }
    for p in &written {
        writeln!(stdout, "wrote {}", p.display())?;
    }
    if let Evaluation::Failed(why) = &run.evaluation {
        anyhow::bail!("evaluation failed: {why}");
    }
    Ok(())
}

fn summary(out: &mut impl Write, run: &RunOutput) -> Result<()> {
    writeln!(
        out,
        "{:.1} s of flight in {:.3} s ({:.0}× real time; AoA {:.3} s, estimator {:.3} s)",
        run.flight_s,
        run.wall_s,
        run.realtime_factor(),
        run.timing.aoa_s,
        run.timing.estimator_s
    )?;
    match run.converged_at {
        Some(t) => writeln!(out, "converged at {:.2} s", t.as_secs_f64())?,
        None => writeln!(out, "did not converge")?,
    }
    for s in &run.stats.per_ap {
        writeln!(
            out,
            "{}: {} packets: {} fed, {} for SpotFi, dropped {} (no credible peak {}, gated {}, \
             off track {}, side unknown {}, skipped {}); {} track losses, {} side switches",
            s.name,
            s.packets,
            s.fed,
            s.acquisition,
            s.dropped(),
            s.no_credible_peak,
            s.gated,
            s.off_track,
            s.side_unknown,
            s.skipped,
            s.track_losses,
            s.side_switches
        )?;
        if s.silences + s.imu_gap_restarts > 0 {
            writeln!(
                out,
                "{}: the track started over {} times after the AP fell silent and {} times \
                 after an IMU gap",
                s.name, s.silences, s.imu_gap_restarts
            )?;
        }
        if s.log_skips > 0 {
            writeln!(
                out,
                "{}: the log reader skipped {} stretches ({} bytes): corrupt, truncated or \
                 non-CSI records",
                s.name, s.log_skips, s.log_skipped_bytes
            )?;
        }
    }
    let e = &run.wins;
    if e.frames_refused + e.frames_late + e.solve_failures + run.imu_refused > 0 {
        writeln!(
            out,
            "estimator: {} frames refused, {} late, {} failed solves, {} IMU samples refused",
            e.frames_refused, e.frames_late, e.solve_failures, run.imu_refused
        )?;
    }
    Ok(())
}

/// The figures of the run written into `out` from `dataset` (a warning says why they show no
/// truth when the dataset has one).
fn figures_of(out: &Path, dataset: &Path, config: &Config) -> Result<RunFigures> {
    let (figures, no_truth) =
        RunFigures::of_run(out, dataset, &config.eval).context("making the run's figures")?;
    if let Some(why) = no_truth {
        eprintln!("warning: the figures show no truth: {why}");
    }
    Ok(figures)
}
