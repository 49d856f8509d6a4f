//! `wins eval`: an estimated trajectory (and AP positions) against the truth.

use std::fs::File;
use std::io::{self, BufReader, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use wins::dataset::truth::{Pose, Truth, read_tum};
use wins::eval::{
    AlignMode, DEFAULT_MAX_TIME_DIFF_S, DEFAULT_RPE_DELTA_FRAMES, EstimatedAp, EvalOptions,
    covariance_of_each_pose, evaluate, position_error_rms_from, position_nees, read_estimated_aps,
    read_position_covariance,
};
use wins::figures::RunFigures;
use wins::time::Timestamp;

use crate::draw::draw_run;

/// `wins eval`.
#[derive(clap::Args)]
pub struct EvalArgs {
    /// Estimated trajectory, TUM format (t[s] x y z qx qy qz qw, world_from_body).
    est: PathBuf,
    /// Truth: a TUM file, a dataset directory (its truth/poses.tum and truth/aps.csv), or a
    /// truth folder itself (poses.tum, aps.csv).
    truth: PathBuf,
    /// Estimated AP positions in the estimate's world frame, CSV `name,x_m,y_m,z_m` (needs a
    /// dataset directory or truth folder as TRUTH; a run writes its own as `aps.csv`).
    #[arg(long, value_name = "FILE")]
    aps: Option<PathBuf>,
    /// The covariance reported with each pose, as `wins run` writes it: for the position NEES.
    /// Default: `covariance.csv` beside EST, when there.
    #[arg(long, value_name = "FILE")]
    covariance: Option<PathBuf>,
    /// Largest time difference of an associated pose pair, s (evo's --t_max_diff).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_MAX_TIME_DIFF_S)]
    max_time_diff: f64,
    /// Relative pose error delta, in associated poses (evo_rpe --delta N --delta_unit f).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_RPE_DELTA_FRAMES)]
    rpe_delta: usize,
    /// What the alignment before the ATE may apply: `posyaw` (a heading and a translation, the
    /// default: gravity is observed, so a tilted or mirrored estimate is an error) or `se3` (any
    /// rotation, as `evo_ape -a`).
    #[arg(long, value_name = "MODE", default_value = "posyaw", value_parser = parse_align)]
    align: AlignMode,
    /// Print the metrics as JSON instead of the text report.
    #[arg(long)]
    json: bool,
    /// Also write the metrics as JSON to this file (metrics.json).
    #[arg(long, short, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Draw the figures into this folder (created if missing): the track from above with the
    /// truth, height, attitude and the error per axis; with the files a run writes beside EST
    /// (`covariance.csv`, `aps.csv`, `aoa.csv`, `stats.json`) also the σ band, the APs with
    /// their ellipses and the AoA.
    #[arg(long, value_name = "DIR")]
    figures: Option<PathBuf>,
    /// Also the position error RMS over the poses at or after this time (s, the trajectory's
    /// clock), under the alignment of the whole trajectory: the error after a restart, its
    /// placement scored and not only its shape.
    #[arg(long, value_name = "S")]
    from: Option<f64>,
}

fn parse_align(s: &str) -> Result<AlignMode, String> {
    [AlignMode::PosYaw, AlignMode::Se3]
        .into_iter()
        .find(|m| m.name() == s)
        .ok_or_else(|| format!("`{s}` is not an alignment: `posyaw` or `se3`"))
}

/// Runs `wins eval`.
pub fn eval(args: EvalArgs) -> Result<()> {
    let est = read_tum_file(&args.est)?;
    let truth_all = read_truth(&args.truth)?;
    let (truth, truth_aps) = (&truth_all.poses, &truth_all.aps);
    let beside = |name: &str| {
        let path = args.est.with_file_name(name);
        path.is_file().then_some(path)
    };
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
        align: args.align,
    };
    let mut metrics = evaluate(&est, truth, &aps, truth_aps, &options).with_context(|| {
        format!(
            "evaluating {} against {}",
            args.est.display(),
            args.truth.display()
        )
    })?;
    if let Some(path) = args.covariance.clone().or_else(|| beside("covariance.csv")) {
        let file = File::open(&path).with_context(|| format!("cannot open {}", path.display()))?;
        let rows = read_position_covariance(BufReader::new(file))
            .with_context(|| format!("reading {}", path.display()))?;
        let cov = covariance_of_each_pose(&est, &rows);
        if let Some(nees) = position_nees(&est, &cov, truth, &options)
            .with_context(|| format!("the NEES with {}", path.display()))?
        {
            metrics.position_nees_mean = Some(nees.mean);
            metrics.position_nees_within_95 = Some(nees.within_95);
        }
    }
    if let Some(dir) = &args.figures {
        let figures = RunFigures::from_files(&args.est, None, Some(&truth_all), &options)
            .with_context(|| format!("the figures of {}", args.est.display()))?;
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for path in draw_run(dir, &figures)? {
            eprintln!("wrote {}", path.display());
        }
    }
    let from = match args.from {
        Some(t_s) => Some((t_s, error_from(&est, truth, &options, t_s)?)),
        None => None,
    };
    let mut value = serde_json::to_value(&metrics)?;
    if let (Some((t_s, late)), Some(map)) = (from, value.as_object_mut()) {
        map.insert(
            "position_error_from".to_string(),
            serde_json::json!({
                "t_s": t_s,
                "rmse_m": late.map(|(rms, _)| rms),
                "poses": late.map_or(0, |(_, n)| n),
            }),
        );
    }
    let json = serde_json::to_string_pretty(&value)?;
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
        match from {
            Some((t_s, Some((rms, n)))) => writeln!(
                out,
                "position error from {t_s:.3} s on: {rms:.3} m RMS over {n} poses (whole alignment)"
            )?,
            Some((t_s, None)) => writeln!(out, "position error from {t_s:.3} s on: no pose")?,
            None => {}
        }
    }
    Ok(())
}

/// The position error RMS and count from `t_s` on ([`position_error_rms_from`]).
fn error_from(
    est: &[Pose],
    truth: &[Pose],
    options: &EvalOptions,
    t_s: f64,
) -> Result<Option<(f64, usize)>> {
    if !(t_s.is_finite() && t_s.abs() < 9e9) {
        bail!("--from {t_s}: not a time in seconds (finite, below 9e9 in size)");
    }
    let from = Timestamp((t_s * 1e9).round() as i64);
    position_error_rms_from(est, truth, options, from).context("scoring the poses from --from on")
}

fn read_tum_file(path: &Path) -> Result<Vec<Pose>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    read_tum(BufReader::new(file)).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// The truth: a dataset directory's or a truth folder's, or poses only from a TUM file.
fn read_truth(path: &Path) -> Result<Truth> {
    if path.is_dir() {
        if path.join("poses.tum").is_file() {
            Truth::load_dir(path)
                .with_context(|| format!("loading the truth folder {}", path.display()))
        } else {
            Truth::load(path)
                .with_context(|| format!("loading the truth of dataset {}", path.display()))
        }
    } else {
        Ok(Truth {
            poses: read_tum_file(path)?,
            aps: Vec::new(),
            packets: Vec::new(),
            imu_biases: Vec::new(),
            info: None,
        })
    }
}
