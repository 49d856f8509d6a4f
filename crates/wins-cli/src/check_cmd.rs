//! `wins csi check`: is a capture usable for AoA, with a verdict in words per finding.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use wins::aoa::capture_check::{CheckOptions, Verdict, check_capture};
use wins::rig::ChainCalibration;
use wins::rig::channel::wifi_channel_hz;

/// `wins csi check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// Intel 5300 CSI Tool logs (`.dat`).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Wi-Fi channel the capture was made on: 1–14 (2.4 GHz) or 32–177 (5 GHz). A CSI Tool log
    /// does not record it; it sets the chains' restart step (π at 5 GHz, π/2 at 2.4 GHz).
    #[arg(long, value_name = "N", conflicts_with = "center_freq_hz")]
    channel: Option<u32>,
    /// The channel's centre frequency instead of --channel, Hz.
    #[arg(long, value_name = "HZ")]
    center_freq_hz: Option<f64>,
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
    let center_freq_hz = match (args.channel, args.center_freq_hz) {
        (Some(n), _) => Some(wifi_channel_hz(n).with_context(|| {
            format!("--channel {n} is not a Wi-Fi channel (1–14 at 2.4 GHz, 32–177 at 5 GHz)")
        })?),
        (None, Some(f)) if !(f.is_finite() && f > 1e9) => {
            bail!("--center-freq-hz {f} is not a Wi-Fi carrier (Hz, e.g. 5.32e9)")
        }
        (None, f) => f,
    };
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
        let checked = check_capture(path, &options)?;
        if checked.verdict() == Verdict::Bad {
            unusable.push(path.display().to_string());
        }
        if args.json {
            let value =
                serde_json::json!({ "file": path, "verdict": checked.verdict(), "check": checked });
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
