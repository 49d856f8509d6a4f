//! The receive antenna array: a uniform linear array along the array frame's `a_y` axis, and the
//! one rule its geometry must meet. The steering vector over this geometry is
//! [`crate::aoa::steering`]'s.

use serde::{Deserialize, Serialize};

/// Speed of light in vacuum, m/s (the simulator propagates in air at this speed too).
pub const SPEED_OF_LIGHT_M_S: f64 = 299_792_458.0;

/// Centre frequency of 5 GHz Wi-Fi channel 64, the paper's channel.
pub const CHANNEL_64_HZ: f64 = 5.32e9;

/// Lowest carrier accepted, Hz (Wi-Fi's 2.4 GHz band starts at 2.401 GHz).
pub const MIN_CARRIER_HZ: f64 = 2.4e9;
/// Highest carrier accepted, Hz (Wi-Fi's 6 GHz band ends at 7.125 GHz).
pub const MAX_CARRIER_HZ: f64 = 7.125e9;

/// Antennas the estimator handles: MUSIC needs two, the Intel 5300 has three chains.
pub const ANTENNAS: std::ops::RangeInclusive<usize> = 2..=3;

/// Relative slack on the λ/2 rule, for spacings rounded to a tenth of a millimetre.
const HALF_WAVELENGTH_SLACK: f64 = 0.01;

/// A uniform linear array along `a_y`, centred on the frame origin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrayGeometry {
    /// Number of antennas M (the Intel 5300 has 3).
    pub num_antennas: usize,
    /// Spacing d between neighbouring antennas, metres. At most λ/2 at the carrier
    /// ([`ArrayGeometry::validate`]).
    pub spacing_m: f64,
}

impl Default for ArrayGeometry {
    /// Three antennas at half a wavelength of Wi-Fi channel 64 (5.32 GHz): 2.818 cm.
    fn default() -> Self {
        Self {
            num_antennas: 3,
            spacing_m: half_wavelength_m(CHANNEL_64_HZ),
        }
    }
}

/// Half the free-space wavelength at `freq_hz`.
pub fn half_wavelength_m(freq_hz: f64) -> f64 {
    0.5 * SPEED_OF_LIGHT_M_S / freq_hz
}

/// Why an array geometry or carrier cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// Not 2 or 3 antennas.
    #[error("{0} antennas: the array must have 2 or 3 (MUSIC needs two; the Intel 5300 has three)")]
    Antennas(usize),
    /// The spacing is not a positive finite length.
    #[error("antenna spacing {0} m is not a positive length")]
    Spacing(f64),
    /// The carrier is not a Wi-Fi frequency in Hz.
    #[error(
        "carrier {0} Hz is not a Wi-Fi frequency (2.4–7.125 GHz); it is given in Hz, e.g. 5.32e9"
    )]
    Carrier(f64),
    /// The antennas are further apart than half a wavelength: the spectrum has grating lobes.
    #[error(
        "antenna spacing {spacing_m} m is wider than half a wavelength ({half_wavelength_m:.4} m at \
         {freq_ghz} GHz): every direction has alias directions with the same phases (grating \
         lobes), which a linear array cannot tell apart; arrays wider than λ/2 are not supported"
    )]
    WiderThanHalfWavelength {
        /// The spacing, m.
        spacing_m: f64,
        /// λ/2 at the carrier, m.
        half_wavelength_m: f64,
        /// The carrier, GHz.
        freq_ghz: f64,
    },
}

impl ArrayGeometry {
    /// Position of antenna `m` on `a_y`, metres: `y_m = (m − (M−1)/2)·d`.
    pub fn antenna_y_m(&self, m: usize) -> f64 {
        (m as f64 - (self.num_antennas as f64 - 1.0) / 2.0) * self.spacing_m
    }

    /// The one rule for an array on a carrier: 2–3 antennas, a Wi-Fi carrier given in Hz, and a
    /// spacing of at most λ/2 (1 % slack), so that every angle in [−90°, 90°] has its own phase
    /// difference between neighbouring antennas.
    pub fn validate(&self, center_freq_hz: f64) -> Result<(), GeometryError> {
        if !ANTENNAS.contains(&self.num_antennas) {
            return Err(GeometryError::Antennas(self.num_antennas));
        }
        if !(self.spacing_m.is_finite() && self.spacing_m > 0.0) {
            return Err(GeometryError::Spacing(self.spacing_m));
        }
        if !(MIN_CARRIER_HZ..=MAX_CARRIER_HZ).contains(&center_freq_hz) {
            return Err(GeometryError::Carrier(center_freq_hz));
        }
        let half = half_wavelength_m(center_freq_hz);
        if self.spacing_m > half * (1.0 + HALF_WAVELENGTH_SLACK) {
            return Err(GeometryError::WiderThanHalfWavelength {
                spacing_m: self.spacing_m,
                half_wavelength_m: half,
                freq_ghz: center_freq_hz / 1e9,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_spacing_is_half_wavelength_at_channel_64() {
        let g = ArrayGeometry::default();
        assert!((g.spacing_m - 0.028_176).abs() < 1e-6, "{}", g.spacing_m);
        assert_eq!(g.antenna_y_m(0), -g.spacing_m);
        assert_eq!(g.antenna_y_m(1), 0.0);
        assert_eq!(g.antenna_y_m(2), g.spacing_m);
        assert_eq!(g.validate(CHANNEL_64_HZ), Ok(()));
    }

    #[test]
    fn the_one_rule_refuses_what_music_cannot_use() {
        let g = ArrayGeometry::default();
        // λ/2 at 5.32 GHz is fine on 5.32 GHz and on every lower carrier.
        assert_eq!(g.validate(2.412e9), Ok(()));
        // The same array on channel 165 (5.825 GHz) is 9 % wider than λ/2 there.
        assert!(matches!(
            g.validate(5.825e9),
            Err(GeometryError::WiderThanHalfWavelength { .. })
        ));
        // A rig at 10 cm (several public captures) aliases.
        let wide = ArrayGeometry {
            spacing_m: 0.1,
            ..g
        };
        let e = wide.validate(CHANNEL_64_HZ).unwrap_err();
        assert!(e.to_string().contains("grating lobes"), "{e}");
        // GHz typed for Hz.
        assert_eq!(g.validate(5.32), Err(GeometryError::Carrier(5.32)));
        assert!(g.validate(f64::NAN).is_err());
        for n in [0, 1, 4] {
            let bad = ArrayGeometry {
                num_antennas: n,
                ..g
            };
            assert_eq!(bad.validate(CHANNEL_64_HZ), Err(GeometryError::Antennas(n)));
        }
        for d in [0.0, -0.01, f64::NAN, f64::INFINITY] {
            let bad = ArrayGeometry { spacing_m: d, ..g };
            assert!(matches!(
                bad.validate(CHANNEL_64_HZ),
                Err(GeometryError::Spacing(_))
            ));
        }
    }
}
