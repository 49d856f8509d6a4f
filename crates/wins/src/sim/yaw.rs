//! Yaw profile ψ(t) of a flight and its exact derivative ψ̇(t).
//!
//! ψ is the heading of the body x axis, measured in the horizontal plane of the world frame `w`
//! from +x toward +y. The profile is a base mode plus a constant offset plus an oscillation:
//!
//! ```text
//! ψ(t) = ψ_mode(t) + ψ_offset + A sin(2π t / T)
//! ψ̇(t) = ψ̇_mode(t)            + A (2π / T) cos(2π t / T)
//! ```
//!
//! ψ is returned on any branch (no wrapping); callers only use cos ψ and sin ψ.

use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

use super::trajectory::Translation;
use super::{ConfigError, check_finite};

/// Below this squared horizontal distance, m², [`YawMode::TowardPoint`] treats the body as
/// standing at the point's bearing singularity and returns ψ = 0, ψ̇ = 0.
const TOWARD_POINT_MIN_DIST2_M2: f64 = 1e-12;

/// Below this horizontal speed, m/s, [`YawMode::Tangent`] has no direction and returns ψ = 0,
/// ψ̇ = 0.
const TANGENT_MIN_SPEED_M_S: f64 = 1e-9;

/// How the base heading ψ_mode is chosen.
///
/// In TOML the variant is chosen by `mode`: `"fixed"`, `"toward-point"` or `"tangent"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "kebab-case", deny_unknown_fields)]
pub enum YawMode {
    /// A constant heading: ψ = `yaw_deg`, ψ̇ = 0.
    Fixed {
        /// Heading, degrees from world +x toward +y.
        yaw_deg: f64,
    },
    /// Body x axis toward a point (horizontal bearing), with d = point − p and ḋ = −v:
    /// ψ = atan2(d_y, d_x), ψ̇ = (d_x ḋ_y − d_y ḋ_x) / (d_x² + d_y²).
    ///
    /// Directly above or below the point (d_x² + d_y² < 1e-12 m²) the bearing is undefined and
    /// ψ = 0, ψ̇ = 0 are returned.
    TowardPoint {
        /// The point to face, in `w`, m (its z is ignored).
        point_m: [f64; 3],
    },
    /// Along the horizontal velocity:
    /// ψ = atan2(v_y, v_x), ψ̇ = (v_x a_y − v_y a_x) / (v_x² + v_y²).
    ///
    /// When the horizontal speed is below 1e-9 m/s (hover, vertical flight) the heading is
    /// undefined and ψ = 0, ψ̇ = 0 are returned; a flight that stops and starts again therefore
    /// snaps its heading. Use it with flights that keep moving (circle, figure-eight).
    Tangent,
}

impl Default for YawMode {
    /// Fixed heading along world +x.
    fn default() -> Self {
        Self::Fixed { yaw_deg: 0.0 }
    }
}

/// Yaw profile of a scenario: a base mode, a constant offset and a sinusoidal oscillation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct YawConfig {
    /// Base heading ψ_mode.
    pub mode: YawMode,
    /// Constant added to the heading, degrees.
    pub offset_deg: f64,
    /// Amplitude A of the sinusoidal oscillation, degrees (0 = none).
    pub oscillation_amplitude_deg: f64,
    /// Period T of the oscillation, s (> 0, used only when the amplitude is non-zero).
    pub oscillation_period_s: f64,
}

impl Default for YawConfig {
    /// Fixed heading along world +x, no offset, no oscillation (period 10 s). Wrong whenever
    /// the gyro's yaw axis should be excited, which a real flight always does.
    fn default() -> Self {
        Self {
            mode: YawMode::default(),
            offset_deg: 0.0,
            oscillation_amplitude_deg: 0.0,
            oscillation_period_s: 10.0,
        }
    }
}

impl YawConfig {
    /// Checks that every number is finite and the oscillation period is > 0.
    ///
    /// `field` is the dotted prefix used in error messages, e.g. `"yaw"`.
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        let finite = |name: &str, values: &[f64]| check_finite(field, name, values);
        match &self.mode {
            YawMode::Fixed { yaw_deg } => finite("mode.yaw_deg", &[*yaw_deg])?,
            YawMode::TowardPoint { point_m } => finite("mode.point_m", point_m)?,
            YawMode::Tangent => {}
        }
        finite("offset_deg", &[self.offset_deg])?;
        finite(
            "oscillation_amplitude_deg",
            &[self.oscillation_amplitude_deg],
        )?;
        if !(self.oscillation_period_s.is_finite() && self.oscillation_period_s > 0.0) {
            return Err(ConfigError::new(
                format!("{field}.oscillation_period_s"),
                format!("must be finite and > 0, got {}", self.oscillation_period_s),
            ));
        }
        Ok(())
    }

    /// ψ (rad, any branch; callers use only cos/sin) and ψ̇ (rad/s) at `t_s`, for the body at
    /// translational state `tr` (see the module doc for the equations).
    pub fn yaw(&self, t_s: f64, tr: &Translation) -> (f64, f64) {
        let (base_rad, base_rate_rad_s) = match &self.mode {
            YawMode::Fixed { yaw_deg } => (yaw_deg.to_radians(), 0.0),
            YawMode::TowardPoint { point_m } => {
                let dx = point_m[0] - tr.p_b_in_w.x;
                let dy = point_m[1] - tr.p_b_in_w.y;
                let (ddx, ddy) = (-tr.v_b_in_w.x, -tr.v_b_in_w.y);
                let dist2 = dx * dx + dy * dy;
                if dist2 < TOWARD_POINT_MIN_DIST2_M2 {
                    (0.0, 0.0)
                } else {
                    (dy.atan2(dx), (dx * ddy - dy * ddx) / dist2)
                }
            }
            YawMode::Tangent => {
                let (vx, vy) = (tr.v_b_in_w.x, tr.v_b_in_w.y);
                let (ax, ay) = (tr.a_b_in_w.x, tr.a_b_in_w.y);
                let speed2 = vx * vx + vy * vy;
                if speed2 < TANGENT_MIN_SPEED_M_S * TANGENT_MIN_SPEED_M_S {
                    (0.0, 0.0)
                } else {
                    (vy.atan2(vx), (vx * ay - vy * ax) / speed2)
                }
            }
        };
        let amplitude_rad = self.oscillation_amplitude_deg.to_radians();
        let omega_rad_s = TAU / self.oscillation_period_s;
        let (s, c) = (omega_rad_s * t_s).sin_cos();
        (
            base_rad + self.offset_deg.to_radians() + amplitude_rad * s,
            base_rate_rad_s + amplitude_rad * omega_rad_s * c,
        )
    }

    /// Peak yaw rate of the oscillation term alone, rad/s: 2π·|A|/T.
    pub fn oscillation_peak_rate_rad_s(&self) -> f64 {
        TAU * self.oscillation_amplitude_deg.to_radians().abs() / self.oscillation_period_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::trajectory::TrajectoryConfig;
    use nalgebra::Vector3;
    use std::f64::consts::PI;

    /// `a − b` wrapped to (−π, π].
    fn wrapped_diff(a: f64, b: f64) -> f64 {
        let d = (a - b).rem_euclid(TAU);
        if d > PI { d - TAU } else { d }
    }

    fn circle() -> TrajectoryConfig {
        TrajectoryConfig::default()
    }

    fn configs() -> Vec<YawConfig> {
        let osc = |mode| YawConfig {
            mode,
            offset_deg: 12.0,
            oscillation_amplitude_deg: 30.0,
            oscillation_period_s: 5.0,
        };
        vec![
            osc(YawMode::Fixed { yaw_deg: 170.0 }),
            osc(YawMode::TowardPoint {
                point_m: [1.0, 4.0, 1.5],
            }),
            osc(YawMode::Tangent),
            YawConfig {
                mode: YawMode::Tangent,
                ..YawConfig::default()
            },
        ]
    }

    #[test]
    fn rate_matches_wrapped_central_difference() {
        let h = 1e-5;
        let trajectories = [
            circle().build(0, 200.0),
            TrajectoryConfig::FigureEight {
                center_m: [5.0, 5.0, 1.5],
                half_length_m: 3.0,
                half_width_m: 1.5,
                period_s: 20.0,
            }
            .build(0, 200.0),
        ];
        for traj in &trajectories {
            for yaw in configs() {
                yaw.validate("yaw").unwrap();
                for &t in &[0.0, 1.3, 4.9, 12.2, 33.3, 59.0] {
                    let psi = |t: f64| yaw.yaw(t, &traj.at(t)).0;
                    let numeric = wrapped_diff(psi(t + h), psi(t - h)) / (2.0 * h);
                    let (_, exact) = yaw.yaw(t, &traj.at(t));
                    assert!(
                        (numeric - exact).abs() < 1e-6,
                        "{yaw:?} t={t}: {numeric} vs {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn toward_point_faces_the_point() {
        let yaw = YawConfig {
            mode: YawMode::TowardPoint {
                point_m: [1.0, 4.0, 1.5],
            },
            ..YawConfig::default()
        };
        let traj = circle().build(0, 200.0);
        for i in 0..100 {
            let tr = traj.at(0.3 * i as f64);
            let (psi, _) = yaw.yaw(0.3 * i as f64, &tr);
            let heading = Vector3::new(psi.cos(), psi.sin(), 0.0);
            let mut d = Vector3::new(1.0, 4.0, 1.5) - tr.p_b_in_w;
            d.z = 0.0;
            let d = d.normalize();
            assert!((heading - d).norm() < 1e-12, "{heading:?} vs {d:?}");
        }
    }

    #[test]
    fn tangent_follows_velocity() {
        let yaw = YawConfig {
            mode: YawMode::Tangent,
            ..YawConfig::default()
        };
        let traj = circle().build(0, 200.0);
        for i in 0..100 {
            let tr = traj.at(0.3 * i as f64);
            let (psi, rate) = yaw.yaw(0.0, &tr);
            let heading = Vector3::new(psi.cos(), psi.sin(), 0.0);
            assert!((heading - tr.v_b_in_w.normalize()).norm() < 1e-12);
            // Counter-clockwise circle: heading turns at v/r.
            assert!((rate - 1.27 / 2.5).abs() < 1e-12);
        }
    }

    #[test]
    fn singular_points_give_zero() {
        let hover = TrajectoryConfig::Hover {
            position_m: [1.0, 4.0, 3.0],
        }
        .build(0, 200.0)
        .at(0.0);
        for mode in [
            YawMode::Tangent,
            YawMode::TowardPoint {
                point_m: [1.0, 4.0, 0.0],
            },
        ] {
            let yaw = YawConfig {
                mode,
                ..YawConfig::default()
            };
            assert_eq!(yaw.yaw(3.0, &hover), (0.0, 0.0));
        }
    }

    #[test]
    fn fixed_offset_and_oscillation() {
        let yaw = YawConfig {
            mode: YawMode::Fixed { yaw_deg: 90.0 },
            offset_deg: 10.0,
            oscillation_amplitude_deg: 30.0,
            oscillation_period_s: 4.0,
        };
        let tr = TrajectoryConfig::Hover {
            position_m: [0.0; 3],
        }
        .build(0, 200.0)
        .at(0.0);
        let (psi, rate) = yaw.yaw(1.0, &tr);
        assert!((psi - 130f64.to_radians()).abs() < 1e-12);
        assert!(rate.abs() < 1e-12);
        let (psi, rate) = yaw.yaw(0.0, &tr);
        assert!((psi - 100f64.to_radians()).abs() < 1e-12);
        let peak = yaw.oscillation_peak_rate_rad_s();
        assert!((peak - TAU * 30f64.to_radians() / 4.0).abs() < 1e-15);
        assert!((rate - peak).abs() < 1e-12);
    }

    #[test]
    fn config_toml_and_validation() {
        let text = r#"
            offset_deg = 5.0
            oscillation_amplitude_deg = 30.0
            oscillation_period_s = 5.0
            [mode]
            mode = "toward-point"
            point_m = [1.0, 4.0, 1.5]
        "#;
        let yaw: YawConfig = toml::from_str(text).unwrap();
        assert_eq!(
            yaw.mode,
            YawMode::TowardPoint {
                point_m: [1.0, 4.0, 1.5]
            }
        );
        assert_eq!(
            toml::from_str::<YawConfig>("").unwrap(),
            YawConfig::default()
        );
        for config in configs() {
            let back: YawConfig = toml::from_str(&toml::to_string(&config).unwrap()).unwrap();
            assert_eq!(back, config);
        }
        assert!(toml::from_str::<YawConfig>("offset = 1.0").is_err());
        assert!(toml::from_str::<YawConfig>("[mode]\nmode = \"fixed\"\nyaw = 1.0").is_err());
        let bad = YawConfig {
            oscillation_period_s: 0.0,
            ..YawConfig::default()
        };
        assert_eq!(
            bad.validate("yaw").unwrap_err().field,
            "yaw.oscillation_period_s"
        );
        let bad = YawConfig {
            mode: YawMode::Fixed { yaw_deg: f64::NAN },
            ..YawConfig::default()
        };
        assert_eq!(bad.validate("yaw").unwrap_err().field, "yaw.mode.yaw_deg");
    }
}
