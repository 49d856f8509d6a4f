//! The simulated IMU: perfect specific force and angular rate plus white noise, bias random walks
//! and turn-on biases, discretized from continuous densities (docs/DESIGN.md §2).
//!
//! Measurement model (both sensors, per axis): `y_k = x(t_k) + b_k + σ/√Δt · n_k`, with
//! `b_0 ~ N(0, σ_turn-on²)` and `b_{k+1} = b_k + σ_rw·√Δt · n'_k`, `n, n' ~ N(0, 1)`.

use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use super::ConfigError;
use super::motion::{BodyState, specific_force_in_b};
use super::vibration::VibrationConfig;
pub use crate::imu::ImuBiases;
use crate::imu::ImuSample;
pub use crate::rig::ImuNoise;
use crate::time::Timestamp;

const DEG: f64 = std::f64::consts::PI / 180.0;
const MICRO_G: f64 = 9.806_65e-6;
const SECONDS_PER_HOUR: f64 = 3600.0;
/// In-run bias stability is turned into a bias random walk that wanders by about that much over
/// this interval (a common, rough conversion; datasheets give no random-walk figure).
const BIAS_STABILITY_INTERVAL_S: f64 = 100.0;

/// Which noise model the IMU has.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "preset", rename_all = "kebab-case")]
pub enum ImuModel {
    /// The paper's IMU, a LORD MicroStrain 3DM-GX4-25, from its datasheet: gyro noise
    /// 0.005 °/s/√Hz, in-run bias stability 10 °/h, initial bias ±0.08 °/s; accelerometer noise
    /// 100 µg/√Hz, in-run bias stability 0.04 mg, initial bias ±0.002 g (the ± figures taken as 1σ).
    #[serde(rename = "microstrain-3dm-gx4-25")]
    Microstrain3dmGx4_25,
    /// A consumer MEMS part of the BMI088 / ICM-42688 class on a drone frame: gyro 0.014 °/s/√Hz,
    /// bias stability 20 °/h, turn-on ±0.5 °/s; accelerometer 175 µg/√Hz, 0.1 mg, turn-on ±20 mg.
    ConsumerMems,
    /// No noise and no bias (for checking the geometry).
    Ideal,
    /// Explicit densities.
    Custom(ImuNoise),
}

impl ImuModel {
    /// The continuous-time parameters of this model.
    pub fn noise(&self) -> ImuNoise {
        let from_datasheet = |gyro_dps_rthz: f64,
                              gyro_stab_dph: f64,
                              gyro_on_dps: f64,
                              acc_ug_rthz: f64,
                              acc_stab_mg: f64,
                              acc_on_mg: f64| ImuNoise {
            gyro_noise_density_rad_s_sqrt_hz: gyro_dps_rthz * DEG,
            gyro_bias_random_walk_rad_s2_sqrt_hz: gyro_stab_dph * DEG
                / SECONDS_PER_HOUR
                / BIAS_STABILITY_INTERVAL_S.sqrt(),
            gyro_turn_on_bias_rad_s: gyro_on_dps * DEG,
            accel_noise_density_m_s2_sqrt_hz: acc_ug_rthz * MICRO_G,
            accel_bias_random_walk_m_s3_sqrt_hz: acc_stab_mg * 1e3 * MICRO_G
                / BIAS_STABILITY_INTERVAL_S.sqrt(),
            accel_turn_on_bias_m_s2: acc_on_mg * 1e3 * MICRO_G,
        };
        match self {
            Self::Microstrain3dmGx4_25 => from_datasheet(0.005, 10.0, 0.08, 100.0, 0.04, 2.0),
            Self::ConsumerMems => from_datasheet(0.014, 20.0, 0.5, 175.0, 0.1, 20.0),
            Self::Ideal => from_datasheet(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            Self::Custom(n) => n.clone(),
        }
    }
}

/// The IMU of a scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuConfig {
    /// Sample rate, Hz. Default 200 (the paper's estimator assumes 100–200 Hz).
    pub rate_hz: f64,
    /// Noise model. Default: the paper's MicroStrain 3DM-GX4-25.
    pub model: ImuModel,
    /// Deprecated: `[imu.vibration]` replaces it. A value above 0 stands for
    /// `[imu.vibration]` with `accel_rms_m_s2` = this value, `gyro_rms_rad_s` = 0 and every other
    /// key at its default ([`VibrationConfig::typical`]), m/s²; setting both is an error.
    /// Default 0 (and then not written out).
    #[serde(skip_serializing_if = "is_zero")]
    pub vibration_m_s2: f64,
    /// The rotors' vibration on the accelerometer and the gyro while they spin (from the
    /// take-off's start to the landing's end; the whole flight without `[phases]`): lines at the
    /// rotor rate and its harmonics and broadband noise, through the flight controller's
    /// low-pass, from its own random stream ([`super::vibration`]). Absent (the default): none.
    /// The estimator does not model it; it is what tells a drone on the ground from one in the
    /// air.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vibration: Option<VibrationConfig>,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self {
            rate_hz: 200.0,
            model: ImuModel::Microstrain3dmGx4_25,
            vibration_m_s2: 0.0,
            vibration: None,
        }
    }
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl ImuConfig {
    /// Checks rates and densities.
    pub fn validate(&self, field: &str) -> Result<(), ConfigError> {
        if !(self.rate_hz.is_finite() && (1.0..=10_000.0).contains(&self.rate_hz)) {
            return Err(ConfigError::new(
                format!("{field}.rate_hz"),
                format!("{} is not in [1, 10000] Hz", self.rate_hz),
            ));
        }
        if !(self.vibration_m_s2.is_finite() && (0.0..=50.0).contains(&self.vibration_m_s2)) {
            return Err(ConfigError::new(
                format!("{field}.vibration_m_s2"),
                format!("{} is not in [0, 50] m/s²", self.vibration_m_s2),
            ));
        }
        if let Some(v) = &self.vibration {
            if self.vibration_m_s2 > 0.0 {
                return Err(ConfigError::new(
                    format!("{field}.vibration_m_s2"),
                    "deprecated, and [imu.vibration] is set too: move its value to \
                     [imu.vibration] accel_rms_m_s2 and drop it",
                ));
            }
            v.validate(
                &format!("{field}.vibration"),
                self.period_ns() as f64 * 1e-9,
            )?;
        }
        let problems = self.model.noise().problems(&format!("{field}.model"));
        if let Some(p) = problems.0.first() {
            return Err(ConfigError::new(p.key.clone(), p.message.clone()));
        }
        Ok(())
    }

    /// The vibration the flight gets: `[imu.vibration]`, or the deprecated `vibration_m_s2` as
    /// [`VibrationConfig::typical`] on the accelerometer alone; `None` when neither shakes
    /// anything (then the flight draws nothing for it).
    pub fn vibration_model(&self) -> Option<VibrationConfig> {
        match &self.vibration {
            Some(v) => v.is_active().then(|| v.clone()),
            None if self.vibration_m_s2 > 0.0 => {
                Some(VibrationConfig::typical(self.vibration_m_s2, 0.0))
            }
            None => None,
        }
    }

    /// Sample period in integer nanoseconds.
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }
}

/// A noisy IMU driven by the true body motion, sampled every `period_ns`.
#[derive(Clone, Debug)]
pub struct ImuSimulator {
    noise: ImuNoise,
    dt_s: f64,
    rng: ChaCha8Rng,
    biases: ImuBiases,
}

impl ImuSimulator {
    /// A simulator with its own random stream; draws the turn-on biases.
    pub fn new(config: &ImuConfig, mut rng: ChaCha8Rng) -> Self {
        let noise = config.model.noise();
        let biases = ImuBiases {
            gyro_rad_s: normal3(&mut rng) * noise.gyro_turn_on_bias_rad_s,
            accel_m_s2: normal3(&mut rng) * noise.accel_turn_on_bias_m_s2,
        };
        Self {
            noise,
            dt_s: config.period_ns() as f64 * 1e-9,
            rng,
            biases,
        }
    }

    /// The biases the next sample will carry.
    pub fn biases(&self) -> ImuBiases {
        self.biases
    }

    /// Measures the state at time `t`, then advances the bias random walk by one period.
    pub fn measure(&mut self, t: Timestamp, state: &BodyState, gravity_m_s2: f64) -> ImuSample {
        let n = &self.noise;
        let sqrt_dt = self.dt_s.sqrt();
        let gyro_white = normal3(&mut self.rng) * (n.gyro_noise_density_rad_s_sqrt_hz / sqrt_dt);
        let accel_white = normal3(&mut self.rng) * (n.accel_noise_density_m_s2_sqrt_hz / sqrt_dt);
        let sample = ImuSample {
            t,
            gyro_rad_s: state.omega_b_in_b + self.biases.gyro_rad_s + gyro_white,
            accel_m_s2: specific_force_in_b(state, gravity_m_s2)
                + self.biases.accel_m_s2
                + accel_white,
        };
        self.biases.gyro_rad_s +=
            normal3(&mut self.rng) * (n.gyro_bias_random_walk_rad_s2_sqrt_hz * sqrt_dt);
        self.biases.accel_m_s2 +=
            normal3(&mut self.rng) * (n.accel_bias_random_walk_m_s3_sqrt_hz * sqrt_dt);
        sample
    }
}

/// Three independent standard normal draws.
pub(crate) fn normal3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    Vector3::new(
        StandardNormal.sample(rng),
        StandardNormal.sample(rng),
        StandardNormal.sample(rng),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::motion::{STANDARD_GRAVITY_M_S2, body_state};
    use crate::sim::rng;
    use crate::sim::trajectory::Translation;

    fn hover() -> BodyState {
        let tr = Translation {
            p_b_in_w: Vector3::new(1.0, 2.0, 1.5),
            v_b_in_w: Vector3::zeros(),
            a_b_in_w: Vector3::zeros(),
            j_b_in_w: Vector3::zeros(),
        };
        body_state(&tr, 0.0, 0.0, STANDARD_GRAVITY_M_S2, 0.0)
    }

    fn custom(white: f64, rw: f64, on: f64) -> ImuConfig {
        ImuConfig {
            rate_hz: 200.0,
            model: ImuModel::Custom(ImuNoise {
                gyro_noise_density_rad_s_sqrt_hz: white,
                gyro_bias_random_walk_rad_s2_sqrt_hz: rw,
                gyro_turn_on_bias_rad_s: on,
                accel_noise_density_m_s2_sqrt_hz: 10.0 * white,
                accel_bias_random_walk_m_s3_sqrt_hz: 10.0 * rw,
                accel_turn_on_bias_m_s2: 10.0 * on,
            }),
            vibration_m_s2: 0.0,
            vibration: None,
        }
    }

    #[test]
    fn ideal_imu_at_hover_reads_plus_g_and_no_rotation() {
        let mut imu = ImuSimulator::new(
            &ImuConfig {
                model: ImuModel::Ideal,
                ..ImuConfig::default()
            },
            rng::stream(1, "imu"),
        );
        let s = imu.measure(Timestamp(0), &hover(), STANDARD_GRAVITY_M_S2);
        assert_eq!(s.accel_m_s2, Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2));
        assert_eq!(s.gyro_rad_s, Vector3::zeros());
    }

    #[test]
    fn white_noise_is_density_over_root_dt() {
        let mut imu = ImuSimulator::new(&custom(0.01, 0.0, 0.0), rng::stream(2, "imu"));
        let state = hover();
        let n = 40_000;
        let (mut sg, mut sa) = (0.0, 0.0);
        for k in 0..n {
            let s = imu.measure(Timestamp(k * 5_000_000), &state, STANDARD_GRAVITY_M_S2);
            sg += s.gyro_rad_s.norm_squared();
            sa += (s.accel_m_s2 - Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2)).norm_squared();
        }
        let sd_g = (sg / (3 * n) as f64).sqrt();
        let sd_a = (sa / (3 * n) as f64).sqrt();
        // σ_d = σ_c·√(rate) = 0.01·√200 = 0.1414 (and 10× for the accelerometer).
        assert!((sd_g / (0.01 * 200f64.sqrt()) - 1.0).abs() < 0.01, "{sd_g}");
        assert!((sd_a / (0.1 * 200f64.sqrt()) - 1.0).abs() < 0.01, "{sd_a}");
    }

    #[test]
    fn bias_random_walk_and_turn_on_bias_have_the_configured_spread() {
        // Over 400 seeds: turn-on bias spread = σ_on; after T = 10 s the walk adds σ_rw²·T.
        let (on, rw, steps) = (0.002, 0.0005, 2000);
        let (mut v0, mut v_t) = (0.0, 0.0);
        let seeds = 400;
        for seed in 0..seeds {
            let mut imu = ImuSimulator::new(&custom(0.0, rw, on), rng::stream(seed, "imu"));
            let b0 = imu.biases().gyro_rad_s;
            for k in 0..steps {
                imu.measure(Timestamp(k * 5_000_000), &hover(), STANDARD_GRAVITY_M_S2);
            }
            v0 += b0.norm_squared() / 3.0;
            v_t += (imu.biases().gyro_rad_s - b0).norm_squared() / 3.0;
        }
        let sd0 = (v0 / seeds as f64).sqrt();
        let sd_t = (v_t / seeds as f64).sqrt();
        // 1200 draws each: the sample σ is within ~6% (3σ of its own spread).
        assert!((sd0 / on - 1.0).abs() < 0.06, "{sd0}");
        assert!((sd_t / (rw * 10f64.sqrt()) - 1.0).abs() < 0.06, "{sd_t}");
    }

    #[test]
    fn presets_match_their_datasheets() {
        let n = ImuModel::Microstrain3dmGx4_25.noise();
        assert!((n.gyro_noise_density_rad_s_sqrt_hz - 8.7266e-5).abs() < 1e-8);
        assert!((n.accel_noise_density_m_s2_sqrt_hz - 9.80665e-4).abs() < 1e-9);
        assert!((n.accel_turn_on_bias_m_s2 - 0.0196133).abs() < 1e-7);
        let c = ImuModel::ConsumerMems.noise();
        assert!(c.gyro_noise_density_rad_s_sqrt_hz > n.gyro_noise_density_rad_s_sqrt_hz);
        assert!(ImuConfig::default().validate("imu").is_ok());
        let bad = custom(-1.0, 0.0, 0.0);
        assert_eq!(
            bad.validate("imu").unwrap_err().field,
            "imu.model.gyro_noise_density_rad_s_sqrt_hz"
        );
    }
}
