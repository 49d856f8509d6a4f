//! The rotors' vibration on the IMU, as a multirotor's flight controller delivers it (TOML
//! `[imu.vibration]`).
//!
//! Spinning rotors shake the frame at their rotation rate (the rotor's imbalance) and at its
//! multiples (blade passes, motor poles, the frame's response): narrow lines that move with the
//! throttle, on a broadband floor (airflow, the frame's resonances). The sensor samples this fast,
//! the flight controller low-pass filters it at the sensor's rate and hands on one sample in `k`
//! at the IMU's output rate, so what the filter leaves above the output's Nyquist frequency
//! folds down (aliases). The model, per IMU sample, in the body (IMU) frame `b`:
//!
//! ```text
//! u     = |f_b| / g                       thrust per weight (|f_b|: the true specific force)
//! f_r   = f_hover · √u                    rotor rate: thrust T ∝ Ω² (T = C_T ρ n² D⁴)
//! δ_m                                     motor m's speed offset: Gauss–Markov, σ_δ, τ_δ
//! φ_m  += 2π f_r (1 + δ_m) Δt_s           motor m's phase, each sensor step Δt_s
//! x_c   = u Σ_m Σ_h (a_mhc sin hφ_m + b_mhc cos hφ_m) + σ_c n     channel c, at the sensor rate
//! y_c   = Butterworth₂(x_c; f_cut)        the flight controller's low-pass, at the sensor rate
//! out_c = y_c at the IMU's sample times   every k-th sensor sample, k = round(f_sensor / f_imu)
//! ```
//!
//! for the six channels `c` (accelerometer x, y, z in m/s², gyro x, y, z in rad/s), `h = 1…H`
//! with the relative amplitudes `harmonic_amplitudes`, and `n ~ N(0, 1)` per channel and step. The
//! line amplitudes grow with `u` (an imbalance's force `m e Ω²` is proportional to the thrust);
//! the broadband floor does not. Motors out of tune beat against each other, so each line's
//! amplitude wanders, and the speed offsets' walk makes its phase wander.
//!
//! **Calibration.** `accel_rms_m_s2` and `gyro_rms_rad_s` are the RMS *per axis over the three
//! axes*, `√(E|out|²/3)`, of what lands in the IMU samples at hover (`u = 1`); the axis weights
//! split it (axis `j` gets `rms · w_j / √(mean w²)`), so with equal weights every axis has that
//! RMS. The broadband noise carries `broadband_fraction` of each axis's power: its σ is
//! `√(β P / Σ h_k²)` (the filter's noise gain). The lines carry the rest: harmonic `h` has the
//! amplitude `A_h = c · r_h` at the sensor, shared among the motors at random, with
//! `c² = 2 (1 − β) P / Σ_h r_h² |H(h f_hover)|²`, `H` the filter's response at the sensor rate.
//! Sampling one sample in `k` of a stationary signal keeps its variance, so the RMS in the IMU
//! samples is the configured one, up to the motors' speed spread (`|H|` is taken at the nominal
//! line frequencies).
//!
//! **Sources.** Flight controllers filter the IMU with a second-order Butterworth low-pass
//! (PX4's `IMU_ACCEL_CUTOFF`, 30 Hz by default, and `IMU_GYRO_CUTOFF`, 30 Hz from PX4 1.9 and
//! 40 Hz in later releases; ArduPilot's `INS_ACCEL_FILTER` and `INS_GYRO_FILTER`, 20 Hz on a
//! copter). PX4 documents its cutoffs as affecting the data sent to the controllers, not the
//! estimator's; a log or a stream of less filtered data is modelled by a higher cutoff. Raw
//! accelerometer vibration on a well-mounted flight controller is of order 10 m/s² (ArduPilot,
//! "Measuring Vibration": the `VIBE` standard deviation mostly under 15 m/s² on a 3DR IRIS, under
//! 30 m/s² acceptable; PX4 user guide, "Vibration Isolation" and "Log Analysis using Flight Review
//! → Vibration"); a 20–30 Hz two-pole filter takes a line near 100 Hz down by 20–30 dB, which
//! leaves the 0.1–1.0 m/s² and 0.005–0.03 rad/s per axis this model is meant for. The hover rotor
//! rate, the harmonics' amplitudes and the axis weights are typical values, not measurements.

use serde::{Deserialize, Serialize};

use super::ConfigError;

mod butterworth;
mod generator;
#[cfg(test)]
mod tests;

pub use generator::{VibrationGenerator, VibrationSample, aliased_hz, broadband_density};

/// Most thrust per weight a scenario's flight asks for: its acceleration stays under 0.9 g
/// ([`super::Scenario::validate`]), so `|a + g e_z| ≤ 1.9 g`.
pub const MAX_THRUST_PER_WEIGHT: f64 = 1.9;

/// The rotors' vibration on the IMU (TOML `[imu.vibration]`; every key optional). See the module
/// documentation for the model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VibrationConfig {
    /// RMS of the accelerometer disturbance per axis over the three axes, `√(E|a|²/3)`, after
    /// the filter, at hover, m/s². Default 0.3 (realistic: 0.1–1.0).
    pub accel_rms_m_s2: f64,
    /// RMS of the gyro disturbance per axis over the three axes, after the filter, at hover,
    /// rad/s. Default 0.01 (realistic: 0.005–0.03).
    pub gyro_rms_rad_s: f64,
    /// The rotors' rotation rate at hover (thrust = weight), Hz. Default 95 (5700 rpm: a
    /// 450–500 mm quadrotor on 10-inch propellers). It grows as `√(thrust / weight)`.
    pub rotor_hover_hz: f64,
    /// Amplitudes of the lines at 1×, 2×, 3×… the rotor rate, relative to each other, at the
    /// sensor (before the filter). Default `[1.0, 0.5, 0.25]`.
    pub harmonic_amplitudes: Vec<f64>,
    /// Share of each axis's power (after the filter) in broadband noise, the rest in the lines,
    /// in [0, 1]. Default 0.3.
    pub broadband_fraction: f64,
    /// Number of motors, each with its own speed offset and phase. Default 4.
    pub motor_count: u32,
    /// 1σ of each motor's speed about the mean, as a fraction of it. Default 0.02.
    pub motor_speed_spread: f64,
    /// Correlation time of each motor's speed offset (a first-order Gauss–Markov process), s.
    /// Default 2.
    pub motor_speed_time_constant_s: f64,
    /// Relative accelerometer vibration along body x, y, z (scaled to a mean square of 1).
    /// Default `[1.0, 1.0, 1.5]`: the thrust axis shakes most.
    pub accel_axis_weights: [f64; 3],
    /// Relative gyro vibration about body x, y, z (scaled to a mean square of 1). Default
    /// `[1.0, 1.0, 0.5]`: roll and pitch shake more than yaw.
    pub gyro_axis_weights: [f64; 3],
    /// Cutoff (−3 dB) of the flight controller's second-order Butterworth low-pass on the
    /// accelerometer, Hz. Default 30 (PX4's `IMU_ACCEL_CUTOFF`).
    pub accel_cutoff_hz: f64,
    /// Cutoff of the low-pass on the gyro, Hz. Default 30 (PX4's `IMU_GYRO_CUTOFF` from 1.9).
    pub gyro_cutoff_hz: f64,
    /// Rate at which the sensor samples and the filter runs, Hz, rounded to a whole multiple of
    /// the IMU's rate (at least once it). Default 1600 (a BMI088 accelerometer's data rate;
    /// 8 sensor samples per IMU sample at 200 Hz).
    pub sensor_rate_hz: f64,
}

impl Default for VibrationConfig {
    /// [`VibrationConfig::typical`] with 0.3 m/s² and 0.01 rad/s.
    fn default() -> Self {
        Self::typical(0.3, 0.01)
    }
}

impl VibrationConfig {
    /// A typical multirotor (every other field at its default) with RMS `accel_rms_m_s2` on the
    /// accelerometer and `gyro_rms_rad_s` on the gyro, per axis over the three axes, after the
    /// filter, at hover.
    pub fn typical(accel_rms_m_s2: f64, gyro_rms_rad_s: f64) -> Self {
        Self {
            accel_rms_m_s2,
            gyro_rms_rad_s,
            rotor_hover_hz: 95.0,
            harmonic_amplitudes: vec![1.0, 0.5, 0.25],
            broadband_fraction: 0.3,
            motor_count: 4,
            motor_speed_spread: 0.02,
            motor_speed_time_constant_s: 2.0,
            accel_axis_weights: [1.0, 1.0, 1.5],
            gyro_axis_weights: [1.0, 1.0, 0.5],
            accel_cutoff_hz: 30.0,
            gyro_cutoff_hz: 30.0,
            sensor_rate_hz: 1600.0,
        }
    }

    /// Whether it shakes anything (an RMS above zero).
    pub fn is_active(&self) -> bool {
        self.accel_rms_m_s2 > 0.0 || self.gyro_rms_rad_s > 0.0
    }

    /// Sensor samples per IMU sample of period `imu_period_s`: `sensor_rate_hz · period`,
    /// rounded, at least 1.
    pub fn sensor_steps(&self, imu_period_s: f64) -> usize {
        (self.sensor_rate_hz * imu_period_s).round().max(1.0) as usize
    }

    /// Checks every field; `field` is the table's path (`imu.vibration`), `imu_period_s` the
    /// IMU's sample period, which sets the sensor's rate and so the filter's Nyquist frequency.
    pub fn validate(&self, field: &str, imu_period_s: f64) -> Result<(), ConfigError> {
        let key = |name: &str| format!("{field}.{name}");
        let in_range = |name: &str, x: f64, lo: f64, hi: f64, unit: &str| {
            if x.is_finite() && (lo..=hi).contains(&x) {
                Ok(())
            } else {
                Err(ConfigError::new(
                    key(name),
                    format!("{x} is not in [{lo}, {hi}]{unit}"),
                ))
            }
        };
        in_range("accel_rms_m_s2", self.accel_rms_m_s2, 0.0, 50.0, " m/s²")?;
        in_range("gyro_rms_rad_s", self.gyro_rms_rad_s, 0.0, 10.0, " rad/s")?;
        in_range("rotor_hover_hz", self.rotor_hover_hz, 1.0, 2000.0, " Hz")?;
        in_range("broadband_fraction", self.broadband_fraction, 0.0, 1.0, "")?;
        in_range("motor_speed_spread", self.motor_speed_spread, 0.0, 0.2, "")?;
        in_range(
            "motor_speed_time_constant_s",
            self.motor_speed_time_constant_s,
            0.01,
            1000.0,
            " s",
        )?;
        in_range("sensor_rate_hz", self.sensor_rate_hz, 1.0, 100_000.0, " Hz")?;
        if !(1..=16).contains(&self.motor_count) {
            return Err(ConfigError::new(
                key("motor_count"),
                format!("{} is not in [1, 16]", self.motor_count),
            ));
        }
        let h = &self.harmonic_amplitudes;
        let valid = |x: &f64| x.is_finite() && *x >= 0.0;
        if h.is_empty() || h.len() > 8 || !h.iter().all(valid) || h.iter().sum::<f64>() <= 0.0 {
            return Err(ConfigError::new(
                key("harmonic_amplitudes"),
                format!("{h:?}: needs 1 to 8 finite amplitudes ≥ 0, not all zero"),
            ));
        }
        for (name, w) in [
            ("accel_axis_weights", self.accel_axis_weights),
            ("gyro_axis_weights", self.gyro_axis_weights),
        ] {
            if !w.iter().all(valid) || w.iter().sum::<f64>() <= 0.0 {
                return Err(ConfigError::new(
                    key(name),
                    format!("{w:?}: needs finite weights ≥ 0, not all zero"),
                ));
            }
        }
        let sensor_hz = self.sensor_steps(imu_period_s) as f64 / imu_period_s;
        let nyquist_hz = sensor_hz / 2.0;
        for (name, cutoff) in [
            ("accel_cutoff_hz", self.accel_cutoff_hz),
            ("gyro_cutoff_hz", self.gyro_cutoff_hz),
        ] {
            if !(cutoff.is_finite() && cutoff > 0.0 && cutoff < nyquist_hz) {
                return Err(ConfigError::new(
                    key(name),
                    format!(
                        "{cutoff} Hz is not in (0, {nyquist_hz}) Hz: the filter runs at the \
                         sensor's rate, {sensor_hz} Hz (sensor_rate_hz rounded to a multiple of \
                         the IMU's rate), and its cutoff must stay below half of it"
                    ),
                ));
            }
        }
        let top_hz = h.len() as f64 * self.rotor_hover_hz * MAX_THRUST_PER_WEIGHT.sqrt();
        if top_hz >= nyquist_hz {
            return Err(ConfigError::new(
                key("sensor_rate_hz"),
                format!(
                    "the sensor's rate, {sensor_hz} Hz, does not sample harmonic {} of the \
                     rotor at full thrust ({top_hz:.0} Hz); raise it above {:.0} Hz or lower \
                     rotor_hover_hz",
                    h.len(),
                    2.0 * top_hz
                ),
            ));
        }
        Ok(())
    }
}
