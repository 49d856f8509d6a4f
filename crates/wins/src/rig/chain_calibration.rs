//! Per-receive-chain phase offsets: the constant phase each RF chain adds (docs/DESIGN.md §3). Applied to
//! the raw CSI before everything else; without it MUSIC's angles are wrong by tens of degrees.
//!
//! The file is TOML:
//!
//! ```toml
//! # phase each chain adds, rad; CSI of antenna m is multiplied by exp(−j·offset[m])
//! phase_offsets_rad = [0.0, 1.234, -2.345]
//!
//! [made_for]              # the set-up it was measured on (written by `wins calibrate`)
//! center_freq_hz = 5.32e9
//! spacing_m = 0.02818
//! bandwidths = ["ht20"]
//! ```
//!
//! Chain offsets belong to one carrier and one array: a calibration that says what it was made for
//! is refused on another carrier or spacing ([`ChainCalibration::check_setup`]), and its packets of
//! another bandwidth are refused one by one. A file without `made_for` (written by hand, or by an
//! older version) is applied as it is.
//!
//! Only differences between chains matter (a common phase cancels), so offsets are reported with
//! antenna 0 at 0. Estimating them from a capture at a known angle is [`crate::aoa::measure_chains`].

use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::csi::Bandwidth;

/// Carriers closer than this are the same channel, Hz (Wi-Fi channels are 5 MHz apart).
const SAME_CARRIER_HZ: f64 = 1e6;
/// Spacings closer than this fraction are the same array.
const SAME_SPACING_FRACTION: f64 = 0.01;

/// The set-up a calibration was measured on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationSetup {
    /// Channel centre frequency, Hz.
    pub center_freq_hz: f64,
    /// Antenna spacing, m.
    pub spacing_m: f64,
    /// Bandwidths of the packets it was measured on.
    pub bandwidths: Vec<Bandwidth>,
}

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
    /// The set-up it was measured on (`None`: not recorded; applied anywhere).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub made_for: Option<CalibrationSetup>,
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
    /// The calibration was measured on another carrier or array.
    #[error(
        "the chain calibration was made for {made_for}, this set-up is {used}: chain offsets do not \
         carry over (calibrate on this set-up, or leave the calibration out)"
    )]
    OtherSetup {
        /// What the calibration was made for.
        made_for: String,
        /// What it is used with.
        used: String,
    },
    /// A chain's per-packet offsets disagree too much for their mean to mean anything.
    #[error(
        "chain {chain}'s per-packet offsets spread {spread_deg:.0}° (more than {max_deg:.0}°): the \
         capture is not static at the given angle, or the direct path is not the strongest"
    )]
    Spread {
        /// The chain.
        chain: usize,
        /// Its circular spread, deg.
        spread_deg: f64,
        /// The bound, deg.
        max_deg: f64,
    },
    /// A packet's bandwidth is not one the calibration was measured on.
    #[error("{bandwidth:?} packet: the chain calibration was measured on {made_for:?} only")]
    OtherBandwidth {
        /// The packet's bandwidth.
        bandwidth: Bandwidth,
        /// The calibration's.
        made_for: Vec<Bandwidth>,
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
            made_for: None,
        }
    }

    /// Refuses a calibration made for another carrier or antenna spacing than
    /// `center_freq_hz` (Hz) and `spacing_m` (m); one that does not say is accepted.
    pub fn check_setup(&self, center_freq_hz: f64, spacing_m: f64) -> Result<(), CalibrationError> {
        let Some(m) = &self.made_for else {
            return Ok(());
        };
        let same = (m.center_freq_hz - center_freq_hz).abs() <= SAME_CARRIER_HZ
            && (m.spacing_m - spacing_m).abs() <= SAME_SPACING_FRACTION * spacing_m.abs();
        if same {
            return Ok(());
        }
        let text = |f: f64, d: f64| format!("{:.3} GHz with {:.2} mm spacing", f * 1e-9, d * 1e3);
        Err(CalibrationError::OtherSetup {
            made_for: text(m.center_freq_hz, m.spacing_m),
            used: text(center_freq_hz, spacing_m),
        })
    }

    /// Refuses a calibration whose per-chain spread ([`Self::spread_rad`]) exceeds `max_rad`.
    pub fn check_spread(&self, max_rad: f64) -> Result<(), CalibrationError> {
        match self
            .spread_rad
            .iter()
            .enumerate()
            .find(|(_, s)| s.is_nan() || s.abs() > max_rad)
        {
            Some((chain, s)) => Err(CalibrationError::Spread {
                chain,
                spread_deg: s.abs().to_degrees(),
                max_deg: max_rad.to_degrees(),
            }),
            None => Ok(()),
        }
    }

    /// Refuses a packet of a bandwidth the calibration was not measured on (one that does not say
    /// which is accepted).
    pub fn check_bandwidth(&self, bandwidth: Bandwidth) -> Result<(), CalibrationError> {
        match &self.made_for {
            Some(m) if !m.bandwidths.contains(&bandwidth) => {
                Err(CalibrationError::OtherBandwidth {
                    bandwidth,
                    made_for: m.bandwidths.clone(),
                })
            }
            _ => Ok(()),
        }
    }

    /// Reads a calibration file.
    pub fn load(path: &Path) -> Result<Self, CalibrationError> {
        let text = crate::io_safety::read_text(path).map_err(|source| CalibrationError::Io {
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
        let mut text = format!(
            "# wins receive-chain calibration: CSI of antenna m is multiplied by \
             exp(-j*phase_offsets_rad[m]) before sanitization.\n{body}"
        );
        if !text.ends_with('\n') {
            text.push('\n');
        }
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
            made_for: Some(CalibrationSetup {
                center_freq_hz: 5.32e9,
                spacing_m: 0.028,
                bandwidths: vec![Bandwidth::Ht20],
            }),
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

    #[test]
    fn a_calibration_for_another_set_up_is_refused() {
        let mut cal = ChainCalibration::identity(3);
        cal.made_for = Some(CalibrationSetup {
            center_freq_hz: 5.32e9,
            spacing_m: 0.028,
            bandwidths: vec![Bandwidth::Ht20],
        });
        assert!(cal.check_setup(5.32e9 + 0.5e6, 0.0281).is_ok());
        // Channel 165 instead of 64; a 6 cm array instead of 2.8 cm.
        let e = cal.check_setup(5.825e9, 0.028).unwrap_err().to_string();
        assert!(e.contains("5.320 GHz") && e.contains("5.825 GHz"), "{e}");
        assert!(cal.check_setup(5.32e9, 0.06).is_err());
        assert!(cal.check_bandwidth(Bandwidth::Ht20).is_ok());
        let e = cal
            .check_bandwidth(Bandwidth::Ht40)
            .unwrap_err()
            .to_string();
        assert!(e.contains("Ht40"), "{e}");
        // One that does not say is applied anywhere.
        cal.spread_rad = vec![0.0, 0.2, 0.6];
        assert!(cal.check_spread(0.7).is_ok());
        let e = cal.check_spread(0.5).unwrap_err().to_string();
        assert!(e.contains("chain 2") && e.contains("34°"), "{e}");
        cal.spread_rad[1] = f64::NAN;
        assert!(cal.check_spread(0.7).is_err());
        let anywhere = ChainCalibration::identity(3);
        assert!(anywhere.check_setup(2.412e9, 0.06).is_ok());
        assert!(anywhere.check_bandwidth(Bandwidth::Ht40).is_ok());
    }
}
