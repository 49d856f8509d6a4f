//! `wins bound`: the lowest error any estimator could reach on simulated flights.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use wins::eval::bound::{BoundConfig, flight_bound, load_bound_input};

/// `wins bound`.
#[derive(clap::Args)]
pub struct BoundArgs {
    /// Simulated dataset directories (each with its `truth/`).
    #[arg(required = true)]
    datasets: Vec<PathBuf>,
    /// One bearing's error at broadside, white, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 1.0)]
    bearing_sigma_deg: f64,
    /// Correlation time of each AP's bearing error, s (0: white; docs/ESTIMATOR.md measures
    /// 0.3 s on the simulated rooms).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    bearing_correlation_s: f64,
    /// Score from this time on, s after the first pose (as `[eval] sent_from_s` would).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    from_s: f64,
    /// Bound the IMU as the datasheet in `dataset.toml` states it, without the rotors'
    /// vibration the truth records (a sensor on a bench).
    #[arg(long)]
    without_vibration: bool,
    /// Also write one CSV row per dataset to this file.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
}

/// Runs `wins bound`.
pub fn bound(args: BoundArgs) -> Result<()> {
    if !(args.bearing_sigma_deg.is_finite() && args.bearing_sigma_deg > 0.0) {
        bail!("--bearing-sigma-deg must be > 0");
    }
    if let Some(path) = &args.csv {
        // Never written over a dataset's own files.
        let inputs: Vec<&std::path::Path> = args.datasets.iter().map(PathBuf::as_path).collect();
        wins::io_safety::refuse_overlap(path, &inputs)
            .with_context(|| format!("--csv {}", path.display()))?;
    }
    let config = BoundConfig {
        bearing_sigma_rad: args.bearing_sigma_deg.to_radians(),
        bearing_correlation_s: args.bearing_correlation_s,
        from_s: args.from_s,
        imu_vibration: !args.without_vibration,
        ..BoundConfig::default()
    };
    let mut rows = String::from("dataset,ate_bound_m,last_sigma_m,worst_ap_sigma_m,bearings\n");
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<40} {:>14} {:>14} {:>16} {:>9}",
        "dataset", "ATE bound (m)", "last σ (m)", "worst AP σ (m)", "bearings"
    )?;
    let mut failed = 0;
    for dir in &args.datasets {
        let name = dir.display().to_string();
        let result = load_bound_input(dir)
            .map_err(anyhow::Error::msg)
            .and_then(|input| flight_bound(&input, &config).map_err(anyhow::Error::from));
        match result {
            Ok(b) => {
                let last = b.keyframes.last().map_or(0.0, |k| k.position_sigma_m);
                let worst = b.ap_sigma_m.iter().copied().fold(0.0, f64::max);
                writeln!(
                    out,
                    "{name:<40} {:>14.4} {last:>14.4} {worst:>16.4} {:>9}",
                    b.ate_rmse_m, b.bearings
                )?;
                rows.push_str(&format!(
                    "{name},{},{last},{worst},{}\n",
                    b.ate_rmse_m, b.bearings
                ));
            }
            Err(e) => {
                failed += 1;
                eprintln!("{name}: {e:#}");
            }
        }
    }
    if let Some(path) = &args.csv {
        wins::io_safety::write_atomically(path, |w| w.write_all(rows.as_bytes()))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if failed > 0 {
        bail!("{failed} of {} datasets have no bound", args.datasets.len());
    }
    Ok(())
}
