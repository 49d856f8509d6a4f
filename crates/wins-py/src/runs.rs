//! Runs of a dataset into a run folder (`run`), simulated flights (`simulate`), the shipped
//! settings and the built-in flights.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use wins::config::DEFAULT_TOML;
use wins::csi::format::CaptureFormat;
use wins::rig::ChainCalibration;
use wins::run::folder::run_into_folder;
use wins::run::replay::Evaluation;
use wins::run::run_dir::{RunDir, RunInputs};
use wins::sim::family::{FAMILIES, Family};
use wins::sim::{self, Scenario};
use wins::{Config, RunOptions};

use crate::{raise, raise_text};

/// Runs a dataset into a run folder as `wins run --no-plots` does (see python/wins/__init__.py,
/// `run`); returns what the folder holds and what the run said.
#[pyfunction]
#[pyo3(signature = (dataset, out, config = None, calibration = None, no_calibration = false))]
pub fn run(
    py: Python<'_>,
    dataset: PathBuf,
    out: PathBuf,
    config: Option<PathBuf>,
    calibration: Option<PathBuf>,
    no_calibration: bool,
) -> PyResult<Py<PyDict>> {
    if no_calibration && calibration.is_some() {
        return Err(raise_text(
            "a calibration and no_calibration together: choose one",
        ));
    }
    let settings = match &config {
        Some(p) => Config::from_toml_file(p).map_err(raise)?,
        None => Config::default(),
    };
    let options = RunOptions {
        calibration: match &calibration {
            Some(p) => Some(ChainCalibration::load(p).map_err(raise)?),
            None => None,
        },
        imu_noise: None,
        no_calibration,
    };
    let inputs = RunInputs {
        dataset: &dataset,
        config_file: config.as_deref(),
        calibration_file: calibration.as_deref(),
    };
    let done = py
        .detach(|| {
            let dir = RunDir::prepare(&out, &inputs)?;
            run_into_folder(&dir, &inputs, &settings, &options, &mut |_, _| {
                Ok(Vec::new())
            })
        })
        .map_err(raise)?;
    let result = PyDict::new(py);
    result.set_item("out", out)?;
    let written: Vec<PathBuf> = done.written;
    result.set_item("written", written)?;
    result.set_item("warnings", done.run.warnings.clone())?;
    result.set_item("evaluation", done.run.evaluation.to_string())?;
    if let Evaluation::Failed(why) = &done.run.evaluation {
        return Err(raise_text(format!(
            "evaluation failed (the estimate is written): {why}"
        )));
    }
    Ok(result.unbind())
}

/// Simulates a built-in flight or a family's drawn flight into a dataset folder (see
/// python/wins/__init__.py, `simulate`); returns the simulator's summary.
#[pyfunction]
#[pyo3(signature = (out, scenario = None, family = None, seed = None, duration_s = None,
                    airborne = false, card = None))]
// The keyword arguments of `wins.simulate`, one for each option of `wins simulate`.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    out: PathBuf,
    scenario: Option<String>,
    family: Option<String>,
    seed: Option<u64>,
    duration_s: Option<f64>,
    airborne: bool,
    card: Option<String>,
) -> PyResult<String> {
    let card: Option<CaptureFormat> = card.map(|c| c.parse()).transpose().map_err(raise_text)?;
    let (scenario, mut draw) = match (&scenario, &family) {
        (Some(_), Some(_)) => {
            return Err(raise_text("a scenario or a family, not both"));
        }
        (_, Some(name)) => {
            let draw = Family::from_name(name)
                .and_then(|f| f.draw(seed.unwrap_or(1)))
                .and_then(|d| d.with_overrides(duration_s, airborne))
                .map_err(raise)?;
            (draw.scenario.clone(), Some(draw))
        }
        (name, None) => (
            Scenario::built_in(name.as_deref().unwrap_or("paper-circle"))
                .map_err(raise)?
                .with_overrides(seed, duration_s, airborne),
            None,
        ),
    };
    let scenario = match card {
        Some(card) => {
            if let Some(d) = &mut draw {
                d.scenario = d.scenario.clone().with_card(card);
            }
            scenario.with_card(card)
        }
        None => scenario,
    };
    py.detach(|| -> Result<String, String> {
        let output = sim::simulate(&scenario, &mut |_| {}).map_err(|e| e.to_string())?;
        sim::write_dataset(&out, &scenario, &output).map_err(|e| e.to_string())?;
        if let Some(d) = &draw {
            d.write_files(&out).map_err(|e| e.to_string())?;
        }
        Ok(output.summary().to_string())
    })
    .map_err(raise_text)
}

/// The shipped settings, as `wins config` prints them (TOML).
#[pyfunction]
pub fn default_config() -> &'static str {
    DEFAULT_TOML
}

/// The built-in flights and the families: `(name, description)`.
#[pyfunction]
pub fn scenarios() -> PyResult<Vec<(String, String)>> {
    let mut out = Vec::new();
    for (name, text) in sim::scenario::BUILT_IN {
        let scenario = Scenario::from_toml(text, name).map_err(raise)?;
        out.push((name.to_string(), scenario.description));
    }
    for family in FAMILIES {
        out.push((
            format!("family:{}", family.name()),
            family.description().to_string(),
        ));
    }
    Ok(out)
}
