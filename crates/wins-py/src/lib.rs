//! `wins._wins`: the native half of the Python package `wins` (python/wins/ is the other half,
//! which turns what these functions return into numpy arrays and dicts). Every function calls
//! the `wins` library as the command line does; every error is raised as `wins.WinsError` with
//! the library's message and its causes.

mod cards;
mod csi;
mod runs;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    wins,
    WinsError,
    PyException,
    "An error of wins, with its message and causes."
);

/// `WinsError` of a library error.
fn raise(e: impl std::error::Error + 'static) -> PyErr {
    WinsError::new_err(wins::run::with_causes(&e))
}

/// `WinsError` of a message.
fn raise_text(text: impl Into<String>) -> PyErr {
    WinsError::new_err(text.into())
}

/// The native module.
#[pymodule]
fn _wins(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("WinsError", m.py().get_type::<WinsError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(csi::read_csi, m)?)?;
    m.add_class::<csi::CsiChunks>()?;
    m.add_function(wrap_pyfunction!(cards::read_nexmon, m)?)?;
    m.add_function(wrap_pyfunction!(cards::read_feitcsi, m)?)?;
    m.add_function(wrap_pyfunction!(cards::read_packets, m)?)?;
    m.add_function(wrap_pyfunction!(cards::read_atheros, m)?)?;
    m.add_function(wrap_pyfunction!(cards::read_picoscenes, m)?)?;
    m.add_function(wrap_pyfunction!(cards::check, m)?)?;
    m.add_function(wrap_pyfunction!(csi::aoa, m)?)?;
    m.add_function(wrap_pyfunction!(runs::run, m)?)?;
    m.add_function(wrap_pyfunction!(runs::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(runs::default_config, m)?)?;
    m.add_function(wrap_pyfunction!(runs::scenarios, m)?)?;
    Ok(())
}
