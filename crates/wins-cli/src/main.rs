//! `wins`: the command-line interface. Parses arguments, calls the library, prints.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use wins::csi::intel5300::{self, ExportFormat, LogSummary};

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
    },
    /// Export the CSI records of a log as JSON lines (the reference files' schema) or CSV.
    Export {
        /// Log file.
        file: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = Format::Jsonl)]
        format: Format,
        /// Output file (standard output if absent).
        #[arg(long, short)]
        out: Option<PathBuf>,
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
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain()
        .filter_map(|c| c.downcast_ref::<io::Error>())
        .any(|io| io.kind() == io::ErrorKind::BrokenPipe)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Csi { command } => match command {
            CsiCommand::Info { files, json } => csi_info(&files, json),
            CsiCommand::Export { file, format, out } => csi_export(&file, format, out),
        },
    }
}

fn csi_info(files: &[PathBuf], json: bool) -> Result<()> {
    let stdout = io::stdout();
    let mut out = stdout.lock();
    for (i, path) in files.iter().enumerate() {
        let summary = LogSummary::from_path(path)?;
        if json {
            let value = serde_json::json!({ "file": path, "summary": summary });
            writeln!(out, "{value}")?;
        } else {
            if i > 0 {
                writeln!(out)?;
            }
            writeln!(out, "{:<12}{}", "file", path.display())?;
            write!(out, "{summary}")?;
        }
    }
    Ok(())
}

fn csi_export(file: &PathBuf, format: Format, out: Option<PathBuf>) -> Result<()> {
    let input = File::open(file).with_context(|| format!("cannot open {}", file.display()))?;
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
    for s in &stats.lost {
        eprintln!(
            "warning: offset {}: {} bytes lost: {}",
            s.offset, s.len, s.reason
        );
    }
    Ok(())
}
