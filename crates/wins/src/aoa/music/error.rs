//! Why MUSIC cannot run (its own file: the smoothing and subspace stages report it too).

use crate::check::Problems;
use crate::rig::GeometryError;

/// Why MUSIC cannot run on a packet or with a configuration.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MusicError {
    /// The smoothing windows do not fit the subcarriers or antennas.
    #[error("smoothing layout: {0}")]
    Layout(String),
    /// The CSI has the wrong number of entries.
    #[error("{len} CSI entries, expected {expected}")]
    CsiLength {
        /// Entries given.
        len: usize,
        /// Antennas × subcarriers of the layout.
        expected: usize,
    },
    /// The CSI holds NaN or infinity.
    #[error("CSI holds a non-finite value")]
    NonFinite,
    /// The CSI is all zeros (or the covariance has no positive eigenvalue).
    #[error("CSI has no signal (zero covariance)")]
    NoSignal,
    /// The eigensolver gave up (an iteration cap; never reached on finite input so far).
    #[error("eigensolver: {stage} did not converge in {iterations} iterations")]
    NoConvergence {
        /// Which part of the eigensolver.
        stage: &'static str,
        /// Iterations spent.
        iterations: usize,
    },
    /// Settings out of range (every one listed).
    #[error("{0}")]
    Config(Problems),
    /// The array does not fit its carrier.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
}
