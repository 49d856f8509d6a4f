//! `wins aoa` and `wins calibrate`: argument parsing, library calls, output.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use wins::aoa::{AoaConfig, AoaEstimator, AoaWindow, CalibrateReport, calibrate, calibrate_with};
use wins::csi::format::CaptureFormat;
use wins::csi::intel5300::{CsiRecord, SkipReason};
use wins::dataset::truth::Truth;
use wins::pipeline::aoa_log::capture::{calibrate_capture, estimate_capture};
use wins::pipeline::aoa_log::input::{AoaInput, AoaInputError, AoaSource, AoaSpec};
use wins::pipeline::aoa_log::{AoaLogSummary, AoaMode, PacketAoa, truth_pairs};
use wins::rig::ChainCalibration;
use wins_plot::{HeatMap, Marker, MarkerStyle, heat_map_png};

/// Plot size, pixels.
const PLOT_WIDTH: u32 = 800;
const PLOT_HEIGHT: u32 = 600;

/// The input and the array: shared by `aoa` and `calibrate`.
#[derive(clap::Args)]
pub struct InputArgs {
    /// A capture (an Intel 5300 `.dat` log, a Nexmon pcap, a FeitCSI, PicoScenes or Atheros
    /// file), or a dataset directory (then --ap names the AP; the channel and the array come
    /// from its dataset.toml).
    file: PathBuf,
    /// AP of a dataset directory.
    #[arg(long)]
    ap: Option<String>,
    /// Channel centre frequency of a `.dat` log, Hz [default: 5.32e9, channel 64].
    #[arg(long, value_name = "HZ", conflicts_with = "channel")]
    center_freq_hz: Option<f64>,
    /// Wi-Fi channel of a `.dat` log instead of --center-freq-hz: 1–14 (2.4 GHz) or 32–177 (5 GHz).
    #[arg(long, value_name = "N")]
    channel: Option<u32>,
    /// Antenna spacing of a capture's array, m [default: half a wavelength].
    #[arg(long, value_name = "M")]
    spacing_m: Option<f64>,
    /// Settings, TOML (the `[aoa]` table of the configuration file of `wins run`; see
    /// `wins config`).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Read the file as this capture format instead of the one its first bytes say: intel5300,
    /// nexmon, feitcsi, picoscenes or atheros.
    #[arg(long, value_name = "FORMAT")]
    csi_format: Option<CaptureFormat>,
}

/// `wins aoa`.
#[derive(clap::Args)]
pub struct AoaArgs {
    #[command(flatten)]
    input: InputArgs,
    /// Receive-chain calibration from `wins calibrate` (without it real logs give wrong angles).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// How each packet's direct path is chosen.
    #[arg(long, value_enum, default_value_t = Mode::Music)]
    mode: Mode,
    /// Packets per SpotFi group (`--mode spotfi`).
    #[arg(long, default_value_t = 10)]
    group_size: usize,
    /// Output format.
    #[arg(long, value_enum, default_value_t = RowFormat::Csv)]
    format: RowFormat,
    /// Output file (standard output if absent).
    #[arg(long, short)]
    out: Option<PathBuf>,
    /// Also draw one packet's MUSIC spectrum as a PNG heat map.
    #[arg(long, value_name = "PNG")]
    plot: Option<PathBuf>,
    /// The packet to draw (record index in the log).
    #[arg(long, value_name = "N", default_value_t = 0, requires = "plot")]
    plot_packet: usize,
}

/// `wins calibrate`.
#[derive(clap::Args)]
pub struct CalibrateArgs {
    #[command(flatten)]
    input: InputArgs,
    /// Known AoA of a static capture, degrees in [-90, 90] (without it, a dataset's truth/ gives
    /// each packet's angle).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true, value_parser = parse_aoa_deg)]
    aoa_deg: Option<f64>,
    /// Calibration file to write (TOML).
    #[arg(long, short)]
    out: PathBuf,
    /// Refuse the calibration (write nothing) when a chain's per-packet offsets spread more than
    /// this, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 30.0)]
    max_spread_deg: f64,
}

#[derive(Copy, Clone, ValueEnum)]
enum Mode {
    /// Per packet: the lowest-ToF credible MUSIC peak.
    Music,
    /// SpotFi clustering over consecutive groups of packets.
    Spotfi,
}

#[derive(Copy, Clone, ValueEnum)]
enum RowFormat {
    Csv,
    Jsonl,
}

fn parse_aoa_deg(text: &str) -> Result<f64, String> {
    let v: f64 = text.parse().map_err(|e| format!("{e}"))?;
    if !(-90.0..=90.0).contains(&v) {
        return Err(format!("{v}° is outside [-90°, 90°]"));
    }
    Ok(v)
}

/// What `wins aoa` and `wins calibrate` read, with the `[aoa]` settings of `--config`.
fn spec_of(args: &InputArgs) -> Result<AoaSpec> {
    let config = match &args.config {
        Some(path) => crate::run_cmd::load_config(Some(path))?.aoa,
        None => AoaConfig::default(),
    };
    Ok(AoaSpec {
        file: args.file.clone(),
        ap: args.ap.clone(),
        channel: args.channel,
        center_freq_hz: args.center_freq_hz,
        spacing_m: args.spacing_m,
        config,
    })
}

/// Opens the input of `wins aoa` and `wins calibrate` ([`AoaInput::open`]).
fn open_input(args: &InputArgs) -> Result<AoaInput> {
    let spec = spec_of(args)?;
    AoaInput::open(&spec).map_err(|e| match e {
        AoaInputError::Options(why) => anyhow::anyhow!(
            "{why} (--ap NAME names a dataset's AP; --channel, --center-freq-hz and --spacing-m \
             describe a log)"
        ),
        other => other.into(),
    })
}

/// Prints the log's lost byte ranges (non-CSI records are only counted).
fn report_log_skips(input: &AoaInput, label: &Path) {
    let skips = input.skips();
    let non_csi = skips
        .iter()
        .filter(|s| matches!(s.reason, SkipReason::NonCsi { .. }))
        .count();
    if non_csi > 0 {
        eprintln!("{}: {non_csi} non-CSI records skipped", label.display());
    }
    crate::warn_lost(
        skips
            .iter()
            .filter(|s| !matches!(s.reason, SkipReason::NonCsi { .. })),
    );
}

/// `wins aoa`.
pub fn aoa(args: AoaArgs) -> Result<()> {
    // Before anything is read: the output made over the input would destroy it.
    for out in args.out.iter().chain(&args.plot) {
        wins::io_safety::refuse_same_file(&args.input.file, out)?;
    }
    if let Some(format) = CaptureFormat::other_card(&args.input.file, args.input.csi_format) {
        return aoa_capture(&args, format);
    }
    let input = open_input(&args.input)?;
    let calibration = match &args.calibration {
        Some(path) => Some(ChainCalibration::load(path)?),
        None => None,
    };
    let mode = match args.mode {
        Mode::Music => AoaMode::Music,
        Mode::Spotfi => AoaMode::Spotfi {
            group_size: args.group_size,
        },
    };
    let outcome = input
        .estimate(calibration, mode)
        .with_context(|| match &args.calibration {
            Some(path) => format!("calibration {} does not fit the array", path.display()),
            None => "cannot estimate the AoA".into(),
        })?;
    if let Some(ambiguity) = &outcome.ambiguity {
        eprintln!("warning: {ambiguity}");
    }
    let correction = &outcome.correction;
    if let (Some(measured), Some(prior)) = (correction.measured_rad, correction.prior_rad) {
        eprintln!(
            "chain curvature (φ0 − 2φ1 + φ2) measured on the log: {:.1}° ({} {:.1}°, moved by \
             {:.1}°)",
            measured.to_degrees(),
            if args.calibration.is_some() {
                "calibration's"
            } else {
                "uncalibrated"
            },
            prior.to_degrees(),
            correction.applied_rad.to_degrees()
        );
    }
    let (rows, summary) = (&outcome.rows, &outcome.summary);
    write_rows(rows, args.format, args.out.as_deref())?;
    let file = &args.input.file;
    report_log_skips(&input, file);
    print_summary(file, summary);
    if summary.groups > 0 {
        let failed: usize = summary.groups_without_direct_path.values().sum();
        eprintln!(
            "SpotFi: {} groups, {failed} without a direct path",
            summary.groups
        );
        for (reason, n) in &summary.groups_without_direct_path {
            eprintln!("  {n}: {reason}");
        }
    }
    if args.calibration.is_none() {
        eprintln!(
            "warning: {} (see wins calibrate)",
            wins::pipeline::aoa_log::input::UNCALIBRATED
        );
    }
    if let Some(png) = &args.plot {
        let records = input.records();
        let record = records.get(args.plot_packet).with_context(|| {
            format!(
                "--plot-packet {}: the log has {} records",
                args.plot_packet,
                records.len()
            )
        })?;
        plot_spectrum(&outcome.estimator, record, args.plot_packet, png)?;
        eprintln!(
            "packet {} spectrum drawn to {}",
            args.plot_packet,
            png.display()
        );
    }
    Ok(())
}

/// Draws one record's full MUSIC spectrum with its credible peaks.
fn plot_spectrum(est: &AoaEstimator, record: &CsiRecord, index: usize, png: &Path) -> Result<()> {
    let (music, subspace) = est
        .subspace(record)
        .with_context(|| format!("packet {index} cannot be drawn"))?;
    let spectrum = music.spectrum(&subspace, AoaWindow::FULL);
    let peaks = music.peaks_of(&subspace, &spectrum, AoaWindow::FULL);
    let x: Vec<f64> = spectrum.aoa_rad.iter().map(|a| a.to_degrees()).collect();
    let y: Vec<f64> = spectrum.tof_s.iter().map(|t| t * 1e9).collect();
    let markers: Vec<Marker> = peaks
        .iter()
        .enumerate()
        .map(|(i, p)| Marker {
            x: p.aoa_deg(),
            y: p.tof_s * 1e9,
            label: if i == 0 { "direct" } else { "path" },
            style: if i == 0 {
                MarkerStyle::Cross
            } else {
                MarkerStyle::Circle
            },
        })
        .collect();
    let title = format!("MUSIC spectrum, packet {index}");
    let map = HeatMap {
        title: &title,
        x_label: "AoA (deg)",
        y_label: "ToF (ns)",
        colorbar_label: "spectrum (dB)",
        x: &x,
        y: &y,
        values: &spectrum.db(),
        markers: &markers,
    };
    heat_map_png(png, &map, PLOT_WIDTH, PLOT_HEIGHT)
        .with_context(|| format!("cannot draw {}", png.display()))
}

/// `wins calibrate`.
pub fn calibrate_cmd(args: CalibrateArgs) -> Result<()> {
    wins::io_safety::refuse_same_file(&args.input.file, &args.out)?;
    if let Some(format) = CaptureFormat::other_card(&args.input.file, args.input.csi_format) {
        return calibrate_capture_cmd(&args, format);
    }
    let input = open_input(&args.input)?;
    let file = &args.input.file;
    let (geometry, freq, config) = (input.geometry, input.center_freq_hz, &input.config);
    let (mut calibration, report, source) = match (&input.source, args.aoa_deg) {
        (_, Some(deg)) => {
            let records = input.records();
            let (c, r) = calibrate(records, deg.to_radians(), geometry, freq, config)?;
            (c, r, format!("static capture {} at {deg}°", file.display()))
        }
        (AoaSource::Dataset { dataset, ap }, None) => {
            let truth = Truth::load(file)
                .with_context(|| format!("{} has no usable truth/", file.display()))?;
            let name = &dataset.aps[*ap].name;
            let paired = truth_pairs(dataset, &truth, name)?;
            if paired.unmatched > 0 || paired.truth_rows_skipped > 0 {
                eprintln!(
                    "warning: {} records without a truth row, {} truth rows without a record",
                    paired.unmatched, paired.truth_rows_skipped
                );
            }
            if let Some(i) = paired.lost_sync {
                eprintln!("warning: log and truth out of step from record {i} on");
            }
            let (c, r) = calibrate_with(paired.pairs, geometry, freq, config)?;
            (c, r, format!("truth of {} ({name})", file.display()))
        }
        (AoaSource::Log(_), None) => bail!(
            "{} is a log: give the known angle with --aoa-deg, or a dataset directory with truth",
            file.display()
        ),
    };
    calibration.source = source;
    report_log_skips(&input, file);
    finish_calibration(&args, calibration, &report)
}

/// Refuses a calibration spread wider than `--max-spread-deg`, else writes it and prints it.
fn finish_calibration(
    args: &CalibrateArgs,
    calibration: ChainCalibration,
    report: &CalibrateReport,
) -> Result<()> {
    calibration
        .check_spread(args.max_spread_deg.to_radians())
        .with_context(|| {
            format!(
                "{} not written (--max-spread-deg raises the bound)",
                args.out.display()
            )
        })?;
    calibration.save(&args.out)?;
    println!("calibration from {}", calibration.source);
    println!("chain  offset (deg)  spread (deg)");
    for (m, offset) in calibration.phase_offsets_rad.iter().enumerate() {
        let spread = calibration
            .spread_rad
            .get(m)
            .map_or(f64::NAN, |s| s.abs().to_degrees());
        println!("{m:>5}  {:>12.2}  {spread:>12.2}", offset.to_degrees());
    }
    println!(
        "packets used {}, skipped {}",
        report.used,
        report.skipped.len()
    );
    let mut reasons = std::collections::BTreeMap::<&str, usize>::new();
    for (_, reason) in &report.skipped {
        *reasons.entry(reason).or_default() += 1;
    }
    for (reason, n) in reasons {
        println!("  skipped {n}: {reason}");
    }
    println!("written to {}", args.out.display());
    Ok(())
}

/// `wins aoa` on a capture of another card than the Intel 5300.
fn aoa_capture(args: &AoaArgs, format: CaptureFormat) -> Result<()> {
    if matches!(args.mode, Mode::Spotfi) || args.plot.is_some() {
        bail!(
            "--mode spotfi and --plot take Intel 5300 logs and datasets; {} is {}",
            args.input.file.display(),
            format.describe()
        );
    }
    let calibration = match &args.calibration {
        Some(path) => Some(ChainCalibration::load(path)?),
        None => None,
    };
    let spec = spec_of(&args.input)?;
    let out = estimate_capture(&spec, format, calibration)?;
    write_rows(&out.rows, args.format, args.out.as_deref())?;
    eprintln!(
        "{}: {}, {} antennas {:.4} m apart at {:.3} GHz",
        args.input.file.display(),
        format.describe(),
        out.geometry.num_antennas,
        out.geometry.spacing_m,
        out.center_freq_hz / 1e9
    );
    if let Some(lost) = &out.lost {
        eprintln!("  not read: {lost}");
    }
    print_summary(&args.input.file, &out.summary);
    if args.calibration.is_none() {
        eprintln!(
            "warning: {} (see wins calibrate)",
            wins::pipeline::aoa_log::capture::UNCALIBRATED
        );
    }
    Ok(())
}

/// Writes the rows as CSV or JSON Lines to `out` (standard output if absent).
fn write_rows(rows: &[PacketAoa], format: RowFormat, out: Option<&Path>) -> Result<()> {
    let sink: Box<dyn Write> = match out {
        Some(p) => {
            Box::new(File::create(p).with_context(|| format!("cannot create {}", p.display()))?)
        }
        None => Box::new(io::stdout().lock()),
    };
    let mut sink = BufWriter::new(sink);
    match format {
        RowFormat::Csv => {
            let mut w = csv::Writer::from_writer(&mut sink);
            for row in rows {
                w.serialize(row)?;
            }
            w.flush()?;
        }
        RowFormat::Jsonl => {
            for row in rows {
                serde_json::to_writer(&mut sink, row)?;
                writeln!(sink)?;
            }
        }
    }
    sink.flush()?;
    Ok(())
}

/// Prints the run's counts.
fn print_summary(file: &Path, summary: &AoaLogSummary) {
    eprintln!(
        "{}: {} packets, {} with AoA, {} no credible peak, {} skipped",
        file.display(),
        summary.packets,
        summary.with_aoa,
        summary.no_credible_peak,
        summary.skipped()
    );
    for (reason, n) in &summary.skipped_by_reason {
        eprintln!("  skipped {n}: {reason}");
    }
}

/// `wins calibrate` on a capture of another card than the Intel 5300.
fn calibrate_capture_cmd(args: &CalibrateArgs, format: CaptureFormat) -> Result<()> {
    let Some(deg) = args.aoa_deg else {
        bail!(
            "{} is {}: give the known angle with --aoa-deg",
            args.input.file.display(),
            format.describe()
        );
    };
    let spec = spec_of(&args.input)?;
    let (mut calibration, report) = calibrate_capture(&spec, format, deg.to_radians())?;
    calibration.source = format!(
        "static capture {} ({}) at {deg}°",
        args.input.file.display(),
        format.describe()
    );
    finish_calibration(args, calibration, &report)
}
