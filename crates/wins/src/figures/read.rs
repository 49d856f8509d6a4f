//! The run's files the figures are made from: each one beside the trajectory is optional, but
//! one that is there and malformed is an error naming it.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use nalgebra::Matrix3;
use serde::Deserialize;

use super::{AoaFigure, Event, EventKind, FigureError};
use crate::dataset::baro_csv;
use crate::dataset::load::read_manifest;
use crate::dataset::truth::{Pose, read_tum};
use crate::eval::{EstimatedAp, read_estimated_aps, read_position_covariance};
use crate::run::output::{AOA_FILE, APS_FILE, COVARIANCE_FILE, STATS_FILE};

/// What the figures read of a run.
#[derive(Clone, Debug, Default)]
pub(super) struct RunFiles {
    /// The trajectory's poses, in time order.
    pub(super) poses: Vec<Pose>,
    /// `covariance.csv`: per row, time s and the position covariance (`None`: a row without).
    pub(super) covariances: Vec<(f64, Option<Matrix3<f64>>)>,
    /// `aps.csv`.
    pub(super) aps: Vec<EstimatedAp>,
    /// `aoa.csv`, per AP (truth left empty).
    pub(super) aoa: Vec<AoaFigure>,
    /// `stats.json`'s phases as events.
    pub(super) events: Vec<Event>,
    /// The dataset's barometer: (time s, altitude m).
    pub(super) baro: Vec<(f64, f64)>,
}

/// The columns of `aoa.csv` the figures use.
#[derive(Deserialize)]
struct AoaRow {
    ap: usize,
    t_ns: i64,
    status: String,
    predicted_aoa_deg: Option<f64>,
    aoa_deg: Option<f64>,
}

/// What the figures use of `stats.json`.
#[derive(Deserialize, Default)]
struct Stats {
    #[serde(default)]
    converged_at_s: Option<f64>,
    #[serde(default)]
    phases: Vec<PhaseRow>,
    #[serde(default)]
    packets: Option<Packets>,
}

#[derive(Deserialize)]
struct PhaseRow {
    phase: String,
    t_s: Option<f64>,
}

#[derive(Deserialize)]
struct Packets {
    per_ap: Vec<Named>,
}

#[derive(Deserialize)]
struct Named {
    name: String,
}

fn bad(path: &Path, reason: impl ToString) -> FigureError {
    FigureError::File {
        path: path.display().to_string(),
        reason: reason.to_string(),
    }
}

fn open(path: &Path) -> Result<BufReader<File>, FigureError> {
    File::open(path)
        .map(BufReader::new)
        .map_err(|e| bad(path, e))
}

impl RunFiles {
    /// Reads `trajectory` and the files beside it, and the barometer of `dataset`.
    pub(super) fn read(trajectory: &Path, dataset: Option<&Path>) -> Result<Self, FigureError> {
        let poses = read_tum(open(trajectory)?).map_err(|e| bad(trajectory, e))?;
        let beside = |name: &str| Some(trajectory.with_file_name(name)).filter(|p| p.is_file());
        let covariances = match beside(COVARIANCE_FILE) {
            Some(path) => read_position_covariance(open(&path)?)
                .map_err(|e| bad(&path, e))?
                .into_iter()
                .map(|(t, c)| (t.as_secs_f64(), c))
                .collect(),
            None => Vec::new(),
        };
        let aps = match beside(APS_FILE) {
            Some(path) => read_estimated_aps(open(&path)?).map_err(|e| bad(&path, e))?,
            None => Vec::new(),
        };
        let stats: Stats = match beside(STATS_FILE) {
            Some(path) => serde_json::from_reader(open(&path)?).map_err(|e| bad(&path, e))?,
            None => Stats::default(),
        };
        let names: Vec<String> = stats
            .packets
            .as_ref()
            .map(|p| p.per_ap.iter().map(|a| a.name.clone()).collect())
            .unwrap_or_default();
        let aoa = match beside(AOA_FILE) {
            Some(path) => read_aoa(&path, &names)?,
            None => Vec::new(),
        };
        let baro = match dataset {
            Some(dir) => read_baro(dir)?,
            None => Vec::new(),
        };
        Ok(Self {
            poses,
            covariances,
            aps,
            aoa,
            events: events(&stats),
            baro,
        })
    }
}

/// `aoa.csv` per AP: fed packets at their AoA, dropped ones at theirs or at the predicted one.
fn read_aoa(path: &Path, names: &[String]) -> Result<Vec<AoaFigure>, FigureError> {
    let mut out: Vec<AoaFigure> = Vec::new();
    for (i, row) in csv::Reader::from_reader(open(path)?)
        .deserialize()
        .enumerate()
    {
        let row: AoaRow = row.map_err(|e| bad(path, format!("row {}: {e}", i + 1)))?;
        while out.len() <= row.ap {
            let k = out.len();
            out.push(AoaFigure {
                name: names.get(k).cloned().unwrap_or_else(|| format!("AP {k}")),
                fed: Vec::new(),
                dropped: Vec::new(),
                dropped_without_aoa: Vec::new(),
                truth: Vec::new(),
            });
        }
        let ap = &mut out[row.ap];
        let t_s = row.t_ns as f64 * 1e-9;
        match (row.status.as_str(), row.aoa_deg, row.predicted_aoa_deg) {
            // SpotFi's acquisition packets are neither fed nor dropped.
            ("acquisition", _, _) => {}
            ("fed" | "ok", Some(a), _) => ap.fed.push((t_s, a)),
            (_, Some(a), _) => ap.dropped.push((t_s, a)),
            (_, None, Some(p)) => ap.dropped_without_aoa.push((t_s, p)),
            (_, None, None) => {}
        }
    }
    Ok(out)
}

/// Convergence, losses and recoveries from the phases (the paper's estimator has none: its
/// convergence time alone).
fn events(stats: &Stats) -> Vec<Event> {
    let mut out = Vec::new();
    let mut converged = false;
    for p in &stats.phases {
        let Some(t_s) = p.t_s else { continue };
        let kind = match (p.phase.as_str(), converged) {
            ("tracking", false) => EventKind::Converged,
            ("tracking", true) => EventKind::Recovered,
            ("recovering", _) => EventKind::Lost,
            _ => continue,
        };
        converged |= kind == EventKind::Converged;
        out.push(Event { t_s, kind });
    }
    if out.is_empty()
        && let Some(t_s) = stats.converged_at_s
    {
        out.push(Event {
            t_s,
            kind: EventKind::Converged,
        });
    }
    out
}

/// The dataset's barometer, when its manifest names one.
fn read_baro(dir: &Path) -> Result<Vec<(f64, f64)>, FigureError> {
    let manifest = read_manifest(dir).map_err(|e| bad(dir, e))?;
    let Some(entry) = manifest.baro else {
        return Ok(Vec::new());
    };
    let path = dir.join(&entry.file);
    let samples = baro_csv::read(open(&path)?).map_err(|e| bad(&path, e))?;
    Ok(samples
        .iter()
        .map(|s| (s.t.as_secs_f64(), s.altitude_m))
        .collect())
}
