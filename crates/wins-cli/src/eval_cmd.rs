//! `wins eval`: an estimated trajectory (and AP positions) against the truth.

use std::fs::File;
use std::io::{self, BufReader, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use wins::dataset::truth::{ApRow, Pose, Truth, read_tum};
use wins::eval::{
    DEFAULT_MAX_TIME_DIFF_S, DEFAULT_RPE_DELTA_FRAMES, EstimatedAp, EvalOptions, evaluate,
    read_estimated_aps,
};

/// `wins eval`.
#[derive(clap::Args)]
pub struct EvalArgs {
    /// Estimated trajectory, TUM format (t[s] x y z qx qy qz qw, world_from_body).
    est: PathBuf,
    /// Truth: a TUM file, or a dataset directory (its truth/poses.tum and truth/aps.csv).
    truth: PathBuf,
    /// Estimated AP positions in the estimate's world frame, CSV `name,x_m,y_m,z_m` (needs a
    /// dataset directory as TRUTH).
    #[arg(long, value_name = "FILE")]
    aps: Option<PathBuf>,
    /// Largest time difference of an associated pose pair, s (evo's --t_max_diff).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_MAX_TIME_DIFF_S)]
    max_time_diff: f64,
    /// Relative pose error delta, in associated poses (evo_rpe --delta N --delta_unit f).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_RPE_DELTA_FRAMES)]
    rpe_delta: usize,
    /// Print the metrics as JSON instead of the text report.
    #[arg(long)]
    json: bool,
    /// Also write the metrics as JSON to this file (metrics.json).
    #[arg(long, short, value_name = "FILE")]
    out: Option<PathBuf>,
}

/// Runs `wins eval`.
pub fn eval(args: EvalArgs) -> Result<()> {
    let est = read_tum_file(&args.est)?;
    let (truth, truth_aps) = read_truth(&args.truth)?;
    let aps: Vec<EstimatedAp> = match &args.aps {
        Some(path) => {
            if truth_aps.is_empty() {
                bail!(
                    "--aps needs the truth AP positions: give a dataset directory as TRUTH, not {}",
                    args.truth.display()
                );
            }
            let file =
                File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
            read_estimated_aps(BufReader::new(file))
                .with_context(|| format!("reading {}", path.display()))?
        }
        None => Vec::new(),
    };
    let options = EvalOptions {
        max_time_diff_s: args.max_time_diff,
        rpe_delta_frames: args.rpe_delta,
    };
    let metrics = evaluate(&est, &truth, &aps, &truth_aps, &options).with_context(|| {
        format!(
            "evaluating {} against {}",
            args.est.display(),
            args.truth.display()
        )
    })?;
    let json = serde_json::to_string_pretty(&metrics)?;
    if let Some(path) = &args.out {
        std::fs::write(path, format!("{json}\n"))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let stdout = io::stdout();
    let mut out = stdout.lock();
    if args.json {
        writeln!(out, "{json}")?;
    } else {
        write!(out, "{}", metrics.report())?;
    }
    Ok(())
}

fn read_tum_file(path: &Path) -> Result<Vec<Pose>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    read_tum(BufReader::new(file)).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Truth poses and AP positions: from a dataset directory, or poses only from a TUM file.
fn read_truth(path: &Path) -> Result<(Vec<Pose>, Vec<ApRow>)> {
    if path.is_dir() {
        let truth = Truth::load(path)
            .with_context(|| format!("loading the truth of dataset {}", path.display()))?;
        Ok((truth.poses, truth.aps))
    } else {
        Ok((read_tum_file(path)?, Vec::new()))
    }
}
