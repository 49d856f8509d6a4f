//! Per-receive-chain phase offsets: the constant phase each RF chain adds (docs/DESIGN.md §3). Applied to
//! the raw CSI before everything else; without it MUSIC's angles are wrong by tens of degrees.
//!
//! The file is TOML:
//!
//! ```toml
//! # phase each chain adds, rad; CSI of antenna m is multiplied by exp(−j·offset[m])
//! phase_offsets_rad = [0.0, 1.234, -2.345]
//! ```
//!
//! Only differences between chains matter (a common phase cancels), so offsets are reported with
//! antenna 0 at 0. Estimating them from a capture at a known angle is [`crate::aoa::measure_chains`].

use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Phase offsets of the receive chains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainCalibration {
    /// Phase chain `m` adds to its CSI, rad (antenna order after the permutation).
    pub phase_offsets_rad: Vec<f64>,
    /// Where the numbers came from (free text, e.g. the capture and the known angle).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Per-chain circular spread of the per-packet estimates, rad (diagnostic; empty if unknown).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spread_rad: Vec<f64>,
    /// Packets the estimate used.
    #[serde(default)]
    pub packets: usize,
}

/// A calibration file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The TOML is malformed or has unknown keys.
    #[error("{path}: {reason}")]
    Parse {
        /// The file.
        path: String,
        /// What the parser said.
        reason: String,
    },
    /// The offsets do not fit the CSI (count or non-finite values).
    #[error("calibration has {given} finite offsets, the CSI has {antennas} antennas")]
    Mismatch {
        /// Offsets in the calibration (finite ones).
        given: usize,
        /// Antennas in the CSI.
        antennas: usize,
    },
}

impl ChainCalibration {
    /// No correction for `num_antennas` chains.
    pub fn identity(num_antennas: usize) -> Self {
        Self {
            phase_offsets_rad: vec![0.0; num_antennas],
            source: String::new(),
            spread_rad: Vec::new(),
            packets: 0,
        }
    }

    /// Reads a calibration file.
    pub fn load(path: &Path) -> Result<Self, CalibrationError> {
        let text = std::fs::read_to_string(path).map_err(|source| CalibrationError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let c: Self = toml::from_str(&text).map_err(|e| CalibrationError::Parse {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        if c.phase_offsets_rad.iter().any(|v| !v.is_finite()) {
            return Err(CalibrationError::Parse {
                path: path.display().to_string(),
                reason: "phase_offsets_rad holds a non-finite value".into(),
            });
        }
        Ok(c)
    }

    /// Writes the calibration as TOML, with a header comment saying how it is applied.
    pub fn save(&self, path: &Path) -> Result<(), CalibrationError> {
        let body = toml::to_string(self).map_err(|e| CalibrationError::Parse {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        let text = format!(
            "# wins receive-chain calibration: CSI of antenna m is multiplied by \
             exp(-j*phase_offsets_rad[m]) before sanitization.\n{body}"
        );
        std::fs::write(path, text).map_err(|source| CalibrationError::Io {
            path: path.display().to_string(),
            source,
        })
    }

    /// Removes the offsets from `csi` (row-major, `num_antennas` rows of equal length).
    pub fn apply(
        &self,
        csi: &mut [Complex64],
        num_antennas: usize,
    ) -> Result<(), CalibrationError> {
        if self.phase_offsets_rad.len() != num_antennas
            || num_antennas == 0
            || !csi.len().is_multiple_of(num_antennas)
        {
            return Err(CalibrationError::Mismatch {
                given: self.phase_offsets_rad.len(),
                antennas: num_antennas,
            });
        }
        let k = csi.len() / num_antennas;
        for (row, &offset) in csi.chunks_mut(k).zip(&self.phase_offsets_rad) {
            let undo = Complex64::from_polar(1.0, -offset);
            row.iter_mut().for_each(|v| *v *= undo);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apply_undoes_the_chain_phase_and_round_trips_through_toml() {
        let cal = ChainCalibration {
            phase_offsets_rad: vec![0.0, 1.0, -2.0],
            source: "test".into(),
            spread_rad: vec![0.0, 0.1, 0.1],
            packets: 3,
        };
        let mut csi: Vec<Complex64> = (0..6)
            .map(|i| Complex64::from_polar(1.0, cal.phase_offsets_rad[i / 2] + 0.5))
            .collect();
        cal.apply(&mut csi, 3).unwrap();
        for v in &csi {
            assert!((v.arg() - 0.5).abs() < 1e-12);
        }
        assert!(cal.apply(&mut csi, 2).is_err());
        let dir = std::env::temp_dir().join(format!("wins-cal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("calib.toml");
        cal.save(&path).unwrap();
        assert_eq!(ChainCalibration::load(&path).unwrap(), cal);
        std::fs::write(&path, "phase_offsets = [1]").unwrap();
        assert!(matches!(
            ChainCalibration::load(&path),
            Err(CalibrationError::Parse { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
