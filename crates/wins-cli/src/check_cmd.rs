//! `wins csi check`: is a capture usable for AoA, with a verdict in words per finding; `wins csi
//! stats`: what the receiver adds beyond thermal noise, to set simulated CSI beside real.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use wins::aoa::capture_check::{CheckOptions, Verdict, check_any};
use wins::aoa::capture_stats::capture_stats;
use wins::csi::format::CaptureFormat;
use wins::csi::intel5300::read_log;
use wins::rig::channel::wifi_channel_hz;
use wins::rig::{ArrayGeometry, ChainCalibration};

/// The channel a capture was made on, as a Wi-Fi channel number or a centre frequency.
#[derive(clap::Args)]
struct ChannelArgs {
    /// Wi-Fi channel: 1–14 (2.4 GHz) or 32–177 (5 GHz).
    #[arg(long, value_name = "N", conflicts_with = "center_freq_hz")]
    channel: Option<u32>,
    /// The channel's centre frequency instead of --channel, Hz.
    #[arg(long, value_name = "HZ")]
    center_freq_hz: Option<f64>,
}

impl ChannelArgs {
    /// The centre frequency, Hz, when given. Errors: not a Wi-Fi channel or carrier.
    fn center_freq_hz(&self) -> Result<Option<f64>> {
        match (self.channel, self.center_freq_hz) {
            (Some(n), _) => Ok(Some(wifi_channel_hz(n).with_context(|| {
                format!("--channel {n} is not a Wi-Fi channel (1–14 at 2.4 GHz, 32–177 at 5 GHz)")
            })?)),
            (None, Some(f)) if !(f.is_finite() && f > 1e9) => {
                bail!("--center-freq-hz {f} is not a Wi-Fi carrier (Hz, e.g. 5.32e9)")
            }
            (None, f) => Ok(f),
        }
    }
}

/// `wins csi check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// Captures: Intel 5300 CSI Tool logs (`.dat`), Nexmon pcaps, FeitCSI, PicoScenes or
    /// Atheros CSI Tool files.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Read the files as this capture format instead of the one their first bytes say.
    #[arg(long, value_name = "FORMAT")]
    csi_format: Option<CaptureFormat>,
    /// The capture's channel (a CSI Tool log does not record it; it sets the chains' restart
    /// step, π at 5 GHz and π/2 at 2.4 GHz).
    #[command(flatten)]
    channel: ChannelArgs,
    /// A receive-chain calibration (`wins calibrate`) to check the chains against.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Print one JSON object per file (its findings and the log's summary).
    #[arg(long)]
    json: bool,
}

/// Runs `wins csi check`; fails when a capture is not usable for AoA (a finding is bad), after
/// every file's findings are printed.
pub fn check(args: CheckArgs) -> Result<()> {
    let center_freq_hz = args.channel.center_freq_hz()?;
    let calibration = match &args.calibration {
        Some(path) => Some(ChainCalibration::load(path)?),
        None => None,
    };
    let options = CheckOptions {
        center_freq_hz,
        calibration,
    };
    let mut out = std::io::stdout().lock();
    let mut unusable = Vec::new();
    for (i, path) in args.files.iter().enumerate() {
        let checked = check_any(path, args.csi_format, &options)?;
        let verdict = checked.verdict();
        if verdict == Verdict::Bad {
            unusable.push(path.display().to_string());
        }
        if args.json {
            let value = serde_json::json!({ "file": path, "verdict": verdict, "check": checked });
            writeln!(out, "{value}")?;
        } else {
            if i > 0 {
                writeln!(out)?;
            }
            writeln!(out, "{:<22} {}", "file", path.display())?;
            write!(out, "{checked}")?;
        }
    }
    if !unusable.is_empty() {
        bail!("not usable for AoA as recorded: {}", unusable.join(", "));
    }
    Ok(())
}

/// `wins csi stats`.
#[derive(clap::Args)]
pub struct StatsArgs {
    /// Intel 5300 CSI Tool logs (`.dat`), or simulated datasets' `<ap>.dat`.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// The captures' channel [default: 64].
    #[command(flatten)]
    channel: ChannelArgs,
    /// Antenna spacing of the 3-antenna array, m [default: half a wavelength].
    #[arg(long, value_name = "M")]
    spacing_m: Option<f64>,
    /// Settings, TOML (its `[aoa]` table: the smoothing and the path count).
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Print one JSON object per file.
    #[arg(long)]
    json: bool,
}

/// Runs `wins csi stats`: one row per capture.
pub fn stats(args: StatsArgs) -> Result<()> {
    let center_freq_hz = args
        .channel
        .center_freq_hz()?
        .unwrap_or(wins::rig::array::CHANNEL_64_HZ);
    let geometry = ArrayGeometry {
        num_antennas: 3,
        spacing_m: args
            .spacing_m
            .unwrap_or_else(|| wins::rig::array::half_wavelength_m(center_freq_hz)),
    };
    let config = crate::run_cmd::load_config(args.config.as_deref())?.aoa;
    for path in &args.files {
        if let Some(format) = CaptureFormat::other_card(path, None) {
            bail!(
                "{}: {}: `wins csi stats` measures Intel 5300 logs (`wins csi check` and `wins aoa` take this capture)",
                path.display(),
                format.describe()
            );
        }
    }
    let mut out = std::io::stdout().lock();
    if !args.json {
        writeln!(
            out,
            "{:<44} {:>7} {:>9} {:>9} {:>20} {:>9} {:>9} {:>9} {:>9} {:>7} {:>5} {:>10}",
            "capture",
            "packets",
            "phase IQR",
            "curv. R",
            "λ2, λ3, λ4 / λ1 (dB)",
            "ripple",
            "ch. ampl.",
            "ch. phase",
            "STO IQR",
            "AGC/100",
            "peaks",
            "other dir."
        )?;
    }
    for path in &args.files {
        let log = read_log(path)?;
        let Some(s) = capture_stats(&log.records, &config, geometry, center_freq_hz)? else {
            bail!("{}: no record with three chains to measure", path.display());
        };
        if args.json {
            writeln!(out, "{}", serde_json::json!({ "file": path, "stats": s }))?;
            continue;
        }
        let [l2, l3, l4] = s.eigenvalue_db;
        writeln!(
            out,
            "{:<44} {:>7} {:>8.1}° {:>9.2} {:>20} {:>7.2}dB {:>7.2}dB {:>8.1}° {:>7.1}ns {:>7.1} {:>5.2} {:>9.1}%",
            path.display().to_string(),
            s.packets,
            s.chain_phase_iqr_deg,
            s.curvature_agreement,
            format!("{l2:.1}, {l3:.1}, {l4:.1}"),
            s.amplitude_ripple_db,
            s.chain_amplitude_ripple_db,
            s.chain_phase_ripple_deg,
            s.timing_offset_iqr_ns,
            s.agc_changes_per_100,
            s.peaks_per_packet,
            s.other_direction_pct
        )?;
    }
    Ok(())
}
