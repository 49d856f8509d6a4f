//! `wins`: the command-line interface. Parses arguments, calls the library, prints.
// Printing is this binary's job; the library crates never print (workspace lints).
#![allow(clippy::print_stdout, clippy::print_stderr)]

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use wins::csi::format::CaptureFormat;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use wins::config::DEFAULT_TOML;
use wins::csi::capture::CaptureSummary;
use wins::csi::intel5300::{self, ExportFormat};
use wins::sim::family::{FAMILIES, Family};
use wins::sim::{self, Scenario};

mod aoa_cmd;
mod bound_cmd;
mod check_cmd;
mod draw;
mod eval_cmd;
mod live_cmd;
mod run_cmd;
mod sweep_cmd;

/// WiFi-inertial pose estimation for micro aerial vehicles.
#[derive(Parser)]
#[command(name = "wins", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Channel state information logs (Intel 5300 CSI Tool `.dat`).
    Csi {
        #[command(subcommand)]
        command: CsiCommand,
    },
    /// Simulate a flight (trajectory, IMU, Wi-Fi CSI per AP) and write it as a dataset directory.
    Simulate(SimulateArgs),
    /// Angle of arrival of every packet of a log or dataset AP (MUSIC or SpotFi), as CSV or JSONL.
    Aoa(aoa_cmd::AoaArgs),
    /// Receive-chain phase offsets from a capture at a known angle or a dataset's truth.
    Calibrate(aoa_cmd::CalibrateArgs),
    /// Score an estimated trajectory (TUM) against the truth: ATE, RPE, attitude and AP errors.
    Eval(eval_cmd::EvalArgs),
    /// The lowest ATE any estimator could reach on simulated flights (a Cramér–Rao bound from
    /// each flight's geometry, IMU and bearings).
    Bound(bound_cmd::BoundArgs),
    /// Run WINS on a dataset directory: trajectory, AP positions, AoA log, statistics, and with
    /// a `truth/` folder metrics, a report and figures.
    Run(run_cmd::RunArgs),
    /// Simulate the paper's flight, run WINS on it, print the report and draw the figures.
    Demo(run_cmd::DemoArgs),
    /// Measure WINS over many simulated flights (scenarios × seeds) on all cores: runs.csv,
    /// summary.json and a figure; `wins sweep merge` joins the shards of a sharded sweep.
    Sweep(sweep_cmd::SweepArgs),
    /// Run on board: CSI from the CSI Tool's `log_to_server` (TCP), IMU from the flight
    /// controller (MAVLink), the pose sent back as MAVLink ODOMETRY at every frame.
    Live(live_cmd::LiveArgs),
    /// Play a dataset as a drone would send it (IMU over MAVLink, CSI over TCP), in real time,
    /// to a `wins live`.
    Replay(live_cmd::ReplayArgs),
    /// Print the default settings as TOML (the `--config` file of `wins run`), or check a file.
    Config(ConfigArgs),
}

#[derive(clap::Args)]
struct ConfigArgs {
    /// Check this settings file and list every problem in it, instead of printing the defaults.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
}

#[derive(clap::Args)]
struct SimulateArgs {
    /// Built-in scenario to run (see --list).
    #[arg(long, default_value = "paper-circle", conflicts_with = "scenario_file")]
    scenario: String,
    /// Run a scenario TOML file instead (start from `--print-scenario NAME`).
    #[arg(long, value_name = "FILE")]
    scenario_file: Option<PathBuf>,
    /// Draw the flight from a flight family instead (see --list-families): --seed picks the
    /// flight (default 1). Its scenario (scenario.toml, which --scenario-file flies again) and
    /// what was drawn (drawn.toml) are written beside the dataset.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["scenario", "scenario_file"])]
    family: Option<String>,
    /// Output directory (created; existing files in it are replaced).
    #[arg(long, short, required_unless_present_any = ["print_scenario", "print", "list", "list_families"])]
    out: Option<PathBuf>,
    /// Override the scenario's master seed (with --family: the seed the flight is drawn from).
    #[arg(long)]
    seed: Option<u64>,
    /// Override the flight duration, s.
    #[arg(long, value_name = "SECONDS", visible_alias = "duration-s")]
    duration: Option<f64>,
    /// Start the flight in the air: drop the scenario's phases (rest on the ground, take-off,
    /// landing) and fly the mission alone from t = 0.
    #[arg(long)]
    airborne: bool,
    /// The rig's card: `intel5300` (each built-in scenario's and family's) or `atheros` (its
    /// logs in the Atheros CSI Tool's format, `[array] card = "atheros"` in dataset.toml).
    #[arg(long)]
    card: Option<CaptureFormat>,
    /// Print a built-in scenario's TOML and exit.
    #[arg(long, value_name = "NAME", conflicts_with = "out")]
    print_scenario: Option<String>,
    /// Print the scenario this command would fly (the built-in, the file, or the family's draw
    /// for --seed, with --duration and --airborne applied) as TOML, and exit.
    #[arg(long, conflicts_with_all = ["out", "print_scenario"])]
    print: bool,
    /// List the built-in scenarios and the flight families and exit.
    #[arg(long, conflicts_with = "out")]
    list: bool,
    /// List the flight families and exit.
    #[arg(long, conflicts_with = "out")]
    list_families: bool,
}

#[derive(Subcommand)]
enum CsiCommand {
    /// Summarize logs: records, skipped bytes with reasons, shapes, rates, timing, RSSI and noise.
    Info {
        /// Log files.
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Print the summary as JSON (one object per file, with every lost region).
        #[arg(long)]
        json: bool,
        /// Read the files as this format instead of the one their first bytes say:
        /// intel5300, nexmon, feitcsi, picoscenes or atheros.
        #[arg(long)]
        format: Option<CaptureFormat>,
    },
    /// Is a capture usable for AoA? Antennas, signal, clipping, chain phases, calibration,
    /// bandwidth and channel, packet rate and gaps, each with a verdict and what to do.
    Check(check_cmd::CheckArgs),
    /// What a capture's CSI carries beyond thermal noise (eigenvalue spread, ripple across
    /// subcarriers and between chains, timing offsets, AGC): one row per capture, to set a
    /// simulated capture beside a real one.
    Stats(check_cmd::StatsArgs),
    /// Export the CSI records of a log as JSON lines (the reference files' schema) or CSV.
    Export {
        /// A capture of any card: an Intel 5300 log (its records as the CSI Tool holds them),
        /// or a Nexmon, FeitCSI, PicoScenes or Atheros file (its packets: JSON Lines, or a CSV
        /// of one row per value).
        file: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Jsonl)]
        format: Format,
        /// Output file (standard output if absent).
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Read the file as this capture format instead of the one its first bytes say.
        #[arg(long, value_name = "FORMAT")]
        csi_format: Option<CaptureFormat>,
    },
}

#[derive(Copy, Clone, ValueEnum)]
enum Format {
    Jsonl,
    Csv,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`wins csi export … | head`) is the reader's choice, not a failure.
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, `: `-separated, each cause once: many library errors already show
/// their source in their own text, which `{:#}` would print twice.
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.is_empty() {
            out = text;
        } else if !out.contains(&text) {
            out.push_str(": ");
            out.push_str(&text);
        }
    }
    out
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .filter_map(|c| c.downcast_ref::<io::Error>())
        .any(|io| io.kind() == io::ErrorKind::BrokenPipe)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Csi { command } => match command {
            CsiCommand::Info {
                files,
                json,
                format,
            } => csi_info(&files, json, format),
            CsiCommand::Check(args) => check_cmd::check(args),
            CsiCommand::Stats(args) => check_cmd::stats(args),
            CsiCommand::Export {
                file,
                format,
                out,
                csi_format,
            } => csi_export(&file, format, out, csi_format),
        },
        Command::Simulate(args) => simulate(args),
        Command::Aoa(args) => aoa_cmd::aoa(args),
        Command::Calibrate(args) => aoa_cmd::calibrate_cmd(args),
        Command::Eval(args) => eval_cmd::eval(args),
        Command::Bound(args) => bound_cmd::bound(args),
        Command::Run(args) => run_cmd::run(args),
        Command::Demo(args) => run_cmd::demo(args),
        Command::Live(args) => live_cmd::live(args),
        Command::Replay(args) => live_cmd::replay(args),
        Command::Sweep(args) => sweep_cmd::sweep(args),
        Command::Config(args) => config(args),
    }
}

fn config(args: ConfigArgs) -> Result<()> {
    let mut out = io::stdout().lock();
    match &args.check {
        Some(path) => {
            run_cmd::load_config(Some(path))?;
            writeln!(out, "{}: every setting is usable", path.display())?;
        }
        None => write!(out, "{DEFAULT_TOML}")?,
    }
    Ok(())
}

fn csi_info(files: &[PathBuf], json: bool, format: Option<CaptureFormat>) -> Result<()> {
    let stdout = io::stdout();
    let mut out = stdout.lock();
    let mut empty = Vec::new();
    for (i, path) in files.iter().enumerate() {
        let summary = CaptureSummary::of_path(path, format)?;
        empty.extend(summary.why_empty(path));
        if json {
            let value = serde_json::json!({ "file": path, summary.json_key(): summary.to_json()? });
            writeln!(out, "{value}")?;
        } else {
            if i > 0 {
                writeln!(out)?;
            }
            writeln!(out, "{:<12}{}", "file", path.display())?;
            write!(out, "{summary}")?;
        }
    }
    if !empty.is_empty() {
        anyhow::bail!("{}", empty.join("\n"));
    }
    Ok(())
}

fn csi_export(
    file: &PathBuf,
    format: Format,
    out: Option<PathBuf>,
    csi_format: Option<CaptureFormat>,
) -> Result<()> {
    if let Some(p) = &out {
        // Before anything is opened: creating the output would empty the input.
        wins::io_safety::refuse_same_file(file, p)?;
    }
    if let Some(card) = CaptureFormat::other_card(file, csi_format) {
        return export_packets(file, card, format, out);
    }
    let input = File::open(file).with_context(|| format!("cannot open {}", file.display()))?;
    // Another format is named before the output is made.
    if let Ok(Some(found @ intel5300::Identified::Foreign(_))) = intel5300::identify(file) {
        anyhow::bail!("{}: {}", file.display(), found.describe());
    }
    let format = match format {
        Format::Jsonl => ExportFormat::Jsonl,
        Format::Csv => ExportFormat::Csv,
    };
    let sink: Box<dyn Write> = match &out {
        Some(p) => {
            Box::new(File::create(p).with_context(|| format!("cannot create {}", p.display()))?)
        }
        None => Box::new(io::stdout().lock()),
    };
    let stats = intel5300::export(io::BufReader::new(input), format, BufWriter::new(sink))
        .with_context(|| format!("exporting {}", file.display()))?;
    eprintln!(
        "{}: {} CSI records written, {} non-CSI records skipped, {} without scaled CSI",
        file.display(),
        stats.records,
        stats.non_csi_records,
        stats.unscalable
    );
    warn_lost(&stats.lost);
    if stats.records == 0 {
        anyhow::bail!(
            "{}: no CSI records: {}",
            file.display(),
            intel5300::why_no_records(file)
        );
    }
    Ok(())
}

/// `wins csi export` of another card's capture: its packets, read whole before the output is
/// made.
fn export_packets(
    file: &Path,
    card: CaptureFormat,
    format: Format,
    out: Option<PathBuf>,
) -> Result<()> {
    let (_, read) = wins::csi::packet::read_packets(file, Some(card))?;
    if read.packets.is_empty() {
        let mut why: Vec<String> = read.lost.into_iter().collect();
        why.extend(read.skipped.keys().cloned());
        anyhow::bail!(
            "{}: no packet with CSI as {}: {}",
            file.display(),
            card.describe(),
            why.join("; ")
        );
    }
    let sink: Box<dyn Write> = match &out {
        Some(p) => {
            Box::new(File::create(p).with_context(|| format!("cannot create {}", p.display()))?)
        }
        None => Box::new(io::stdout().lock()),
    };
    let sink = BufWriter::new(sink);
    match format {
        Format::Jsonl => wins::csi::packet::export::write_jsonl(&read.packets, sink)?,
        Format::Csv => wins::csi::packet::export::write_csv(&read.packets, sink)?,
    }
    eprintln!(
        "{}: {}, {} packets written",
        file.display(),
        card.describe(),
        read.packets.len()
    );
    for (why, n) in &read.skipped {
        eprintln!("  skipped {n}: {why}");
    }
    if let Some(lost) = &read.lost {
        eprintln!("warning: not read: {lost}");
    }
    Ok(())
}

/// One warning per byte range of a log that was lost (corrupt or cut), with its offset.
fn warn_lost<'a>(lost: impl IntoIterator<Item = &'a intel5300::Skip>) {
    for s in lost {
        eprintln!(
            "warning: offset {}: {} bytes lost: {}",
            s.offset, s.len, s.reason
        );
    }
}

fn simulate(args: SimulateArgs) -> Result<()> {
    let stdout = io::stdout();
    let mut out = stdout.lock();
    // Names padded to the longest, and two spaces, so that none runs into its description.
    let width = sim::scenario::BUILT_IN
        .iter()
        .map(|(name, _)| name.len())
        .chain(FAMILIES.iter().map(|f| f.name().len()))
        .max()
        .unwrap_or(0)
        + 2;
    if args.list {
        for (name, text) in sim::scenario::BUILT_IN {
            let scenario = Scenario::from_toml(text, name)?;
            writeln!(out, "{name:<width$}{}", scenario.description)?;
        }
        writeln!(out, "\nflight families (--family NAME --seed S):")?;
    }
    if args.list || args.list_families {
        for family in FAMILIES {
            writeln!(out, "{:<width$}{}", family.name(), family.description())?;
        }
        return Ok(());
    }
    if let Some(name) = &args.print_scenario {
        write!(out, "{}", sim::scenario::printable_toml(name)?)?;
        return Ok(());
    }
    let draw = match &args.family {
        Some(name) => {
            let mut d = Family::from_name(name)?
                .draw(args.seed.unwrap_or(1))?
                .with_overrides(args.duration, args.airborne)?;
            if let Some(card) = args.card {
                d.scenario = d.scenario.with_card(card);
            }
            Some(d)
        }
        None => None,
    };
    let scenario = match (&draw, &args.scenario_file) {
        (Some(d), _) => d.scenario.clone(),
        (None, file) => match file {
            Some(path) => Scenario::from_file(path)?,
            None => Scenario::built_in(&args.scenario)?,
        }
        .with_overrides(args.seed, args.duration, args.airborne),
    };
    let scenario = match args.card {
        Some(card) => scenario.with_card(card),
        None => scenario,
    };
    if args.print {
        match &draw {
            Some(d) => write!(out, "{}", d.scenario_toml()?)?,
            None => write!(out, "{}", scenario.to_toml()?)?,
        }
        return Ok(());
    }
    let Some(dir) = args.out else {
        anyhow::bail!("--out is required");
    };
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_message(format!("simulating {}", scenario.name));
    let started = std::time::Instant::now();
    let output = sim::simulate(&scenario, &mut |f| bar.set_position((f * 1000.0) as u64))?;
    let simulated = started.elapsed();
    let report = sim::write_dataset(&dir, &scenario, &output)?;
    bar.finish_and_clear();
    writeln!(
        out,
        "{} (seed {}): {:.1} s of flight simulated in {:.3} s, written to {} in {:.3} s",
        scenario.name,
        scenario.seed,
        scenario.duration_s,
        simulated.as_secs_f64(),
        dir.display(),
        (started.elapsed() - simulated).as_secs_f64()
    )?;
    write!(out, "{}", output.summary())?;
    if let Some(draw) = &draw {
        writeln!(out, "drawn: {}", draw.flight.describe())?;
        for path in draw.write_files(&dir)? {
            writeln!(out, "wrote {}", path.display())?;
        }
    }
    if report.clipped > 0 {
        writeln!(
            out,
            "warning: {} CSI components clipped by the 8-bit quantizer",
            report.clipped
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::message;

    /// An error that shows its source in its own text, as many of the library's do.
    #[derive(Debug)]
    struct Shows {
        source: std::io::Error,
    }

    impl std::fmt::Display for Shows {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "bad.csv: {}", self.source)
        }
    }

    impl std::error::Error for Shows {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.source)
        }
    }

    #[test]
    fn each_cause_is_printed_once() {
        let io = || std::io::Error::other("line 5: not a number");
        let e = anyhow::Error::new(Shows { source: io() }).context("loading DIR");
        assert_eq!(message(&e), "loading DIR: bad.csv: line 5: not a number");
        let plain = anyhow::Error::new(io()).context("loading DIR");
        assert_eq!(message(&plain), "loading DIR: line 5: not a number");
    }
}
