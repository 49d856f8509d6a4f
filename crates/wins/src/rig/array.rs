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
}

/// A steering ambiguity of an array wider than half a wavelength.
#[derive(Clone, Debug, PartialEq)]
pub struct Ambiguity {
    /// The spacing, m.
    pub spacing_m: f64,
    /// λ/2 at the carrier, m.
    pub half_wavelength_m: f64,
    /// The carrier, Hz.
    pub center_freq_hz: f64,
    /// The broadside direction's aliases, rad (the angles with the same phases as 0°).
    pub broadside_aliases_rad: Vec<f64>,
}

impl std::fmt::Display for Ambiguity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let list: Vec<String> = self
            .broadside_aliases_rad
            .iter()
            .map(|a| format!("{:+.1}°", a.to_degrees()))
            .collect();
        write!(
            f,
            "antenna spacing {} m is wider than half a wavelength ({:.4} m at {} GHz): every \
             direction has alias directions with the same phases (grating lobes; 0° looks the \
             same as {}): each peak is reported with its aliases, and the motion chooses among \
             them",
            self.spacing_m,
            self.half_wavelength_m,
            self.center_freq_hz / 1e9,
            if list.is_empty() {
                "nothing".to_string()
            } else {
                list.join(", ")
            }
        )
    }
}

impl ArrayGeometry {
    /// Position of antenna `m` on `a_y`, metres: `y_m = (m − (M−1)/2)·d`.
    pub fn antenna_y_m(&self, m: usize) -> f64 {
        (m as f64 - (self.num_antennas as f64 - 1.0) / 2.0) * self.spacing_m
    }

    /// The one rule for an array on a carrier: 2–3 antennas, a positive spacing and a Wi-Fi
    /// carrier given in Hz. A spacing wider than λ/2 is accepted; [`ArrayGeometry::ambiguity`]
    /// says what it costs.
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
        Ok(())
    }

    /// `λ/d` at the carrier: two directions whose sines differ by a multiple of it have the same
    /// phases on every antenna.
    pub fn alias_period(&self, center_freq_hz: f64) -> f64 {
        2.0 * half_wavelength_m(center_freq_hz) / self.spacing_m
    }

    /// The ambiguity of an array wider than λ/2 at the carrier (1 % slack, for spacings rounded to
    /// a tenth of a millimetre), `None` when every angle has its own phases.
    pub fn ambiguity(&self, center_freq_hz: f64) -> Option<Ambiguity> {
        let half = half_wavelength_m(center_freq_hz);
        (self.spacing_m > half * (1.0 + HALF_WAVELENGTH_SLACK)).then(|| Ambiguity {
            spacing_m: self.spacing_m,
            half_wavelength_m: half,
            center_freq_hz,
            broadside_aliases_rad: self.aliases_rad(0.0, center_freq_hz),
        })
    }

    /// The other angles in [−90°, 90°] with the same phases as `aoa_rad` (`sin θ' = sin θ + k·λ/d`,
    /// k ≠ 0), increasing; empty for an array of at most λ/2.
    pub fn aliases_rad(&self, aoa_rad: f64, center_freq_hz: f64) -> Vec<f64> {
        let period = self.alias_period(center_freq_hz);
        if !(period.is_finite() && period > 0.0) || period >= 2.0 * (1.0 - 1e-12) {
            return Vec::new();
        }
        let s = aoa_rad.sin();
        let k_max = (2.0 / period).ceil() as i64;
        (-k_max..=k_max)
            .filter(|&k| k != 0)
            .map(|k| s + k as f64 * period)
            .filter(|v| v.abs() <= 1.0)
            .map(f64::asin)
            .collect()
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
        assert!(g.ambiguity(2.412e9).is_none());
        assert!(g.ambiguity(CHANNEL_64_HZ).is_none());
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

    #[test]
    fn a_wide_array_is_accepted_with_its_alias_families() {
        let g = ArrayGeometry::default();
        // The same array on channel 165 (5.825 GHz) is 9 % wider than λ/2 there: only angles
        // near endfire have an alias.
        let a = g.ambiguity(5.825e9).expect("ambiguous");
        assert!(a.broadside_aliases_rad.is_empty());
        assert_eq!(g.aliases_rad(80f64.to_radians(), 5.825e9).len(), 1);
        // A rig at 10 cm (the lgtm captures): sin θ repeats every λ/d = 0.563.
        let wide = ArrayGeometry {
            spacing_m: 0.1,
            ..g
        };
        assert_eq!(wide.validate(CHANNEL_64_HZ), Ok(()));
        let a = wide.ambiguity(CHANNEL_64_HZ).expect("ambiguous");
        let deg: Vec<f64> = a
            .broadside_aliases_rad
            .iter()
            .map(|r| r.to_degrees())
            .collect();
        assert_eq!(deg.len(), 2, "{deg:?}");
        assert!(
            (deg[1] - 34.3).abs() < 0.1 && (deg[0] + deg[1]).abs() < 1e-9,
            "{deg:?}"
        );
        assert!(a.to_string().contains("grating lobes"), "{a}");
        // Every alias has the same phase on every antenna as the angle itself.
        let theta = 10f64.to_radians();
        for alias in wide.aliases_rad(theta, CHANNEL_64_HZ) {
            for m in 0..3 {
                let d = wide.antenna_phase_rad(m, CHANNEL_64_HZ, alias.sin())
                    - wide.antenna_phase_rad(m, CHANNEL_64_HZ, theta.sin());
                let r = d.rem_euclid(std::f64::consts::TAU);
                assert!(r.min(std::f64::consts::TAU - r) < 1e-9, "{alias}: {d}");
            }
        }
    }
}
