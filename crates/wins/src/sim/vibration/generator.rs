//! The vibration generator: motors, lines and broadband noise at the sensor's rate, filtered,
//! one sample per IMU sample (the model is in the parent module's documentation).

use std::f64::consts::TAU;

use nalgebra::Vector3;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::butterworth::Butterworth2;
use super::{MAX_THRUST_PER_WEIGHT, VibrationConfig};

/// Accelerometer x, y, z, then gyro x, y, z.
const CHANNELS: usize = 6;

/// The disturbance one IMU sample carries, in the body (IMU) frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VibrationSample {
    /// Added to the specific force, m/s².
    pub accel_m_s2: Vector3<f64>,
    /// Added to the angular rate, rad/s.
    pub gyro_rad_s: Vector3<f64>,
}

/// One motor: where its rotor is and how far its speed is off the mean.
#[derive(Clone, Copy, Debug)]
struct Motor {
    phase_rad: f64,
    speed_offset: f64,
}

/// Rotor vibration for one flight, from its own random stream.
#[derive(Clone, Debug)]
pub struct VibrationGenerator {
    /// Sensor samples per IMU sample.
    steps: usize,
    /// Sensor sample period, s.
    step_s: f64,
    rotor_hover_hz: f64,
    harmonics: usize,
    motors: Vec<Motor>,
    /// Per motor `m` and harmonic `h` (index `m · harmonics + h`): the sine and cosine
    /// coefficients of each channel, at hover.
    lines: Vec<[[f64; CHANNELS]; 2]>,
    /// σ of each channel's white noise at the sensor's rate.
    broadband: [f64; CHANNELS],
    filters: [Butterworth2; CHANNELS],
    /// Per IMU sample: the speed offsets' decay `e^{−Δt/τ}` and the σ of their innovation.
    speed_decay: f64,
    speed_kick: f64,
    rng: ChaCha8Rng,
}

impl VibrationGenerator {
    /// The generator for an IMU sampled every `imu_period_ns` (a validated `config`): draws
    /// each motor's phase and speed offset and how each line reaches each channel.
    pub fn new(config: &VibrationConfig, imu_period_ns: i64, mut rng: ChaCha8Rng) -> Self {
        let period_s = imu_period_ns as f64 * 1e-9;
        let steps = config.sensor_steps(period_s);
        let step_s = period_s / steps as f64;
        let sensor_hz = 1.0 / step_s;
        let spread = config.motor_speed_spread;
        let motors: Vec<Motor> = (0..config.motor_count)
            .map(|_| Motor {
                phase_rad: rng.random::<f64>() * TAU,
                speed_offset: spread * normal(&mut rng),
            })
            .collect();
        let rel = &config.harmonic_amplitudes;
        let harmonics = rel.len();
        let filters = channel_filters(config, sensor_hz);
        // Per channel: its power P after the filter, split between broadband and lines.
        let power = channel_powers(config);
        let beta = config.broadband_fraction;
        let broadband = broadband_sigmas(config, &filters);
        let mut line_scale = [0.0; CHANNELS];
        for c in 0..CHANNELS {
            let f = &filters[c];
            let through: f64 = (0..harmonics)
                .map(|h| {
                    let g = f.gain_at((h + 1) as f64 * config.rotor_hover_hz, sensor_hz);
                    (rel[h] * g).powi(2)
                })
                .sum();
            line_scale[c] = if through > 0.0 {
                (2.0 * (1.0 - beta) * power[c] / through).sqrt()
            } else {
                0.0
            };
        }
        // Each line's amplitude A_h = c·r_h shared among the motors at random phases and weights:
        // Σ_m (a² + b²) = A_h².
        let mut lines = vec![[[0.0; CHANNELS]; 2]; motors.len() * harmonics];
        for h in 0..harmonics {
            for c in 0..CHANNELS {
                let draws: Vec<(f64, f64)> = motors
                    .iter()
                    .map(|_| (normal(&mut rng), normal(&mut rng)))
                    .collect();
                let norm = draws.iter().map(|(a, b)| a * a + b * b).sum::<f64>().sqrt();
                let amplitude = line_scale[c] * rel[h];
                let k = if norm > 0.0 { amplitude / norm } else { 0.0 };
                for (m, (a, b)) in draws.into_iter().enumerate() {
                    lines[m * harmonics + h][0][c] = a * k;
                    lines[m * harmonics + h][1][c] = b * k;
                }
            }
        }
        let speed_decay = (-period_s / config.motor_speed_time_constant_s).exp();
        Self {
            steps,
            step_s,
            rotor_hover_hz: config.rotor_hover_hz,
            harmonics,
            motors,
            lines,
            broadband,
            filters,
            speed_decay,
            speed_kick: spread * (1.0 - speed_decay * speed_decay).sqrt(),
            rng,
        }
    }

    /// The sensor's rate, Hz: the IMU's rate times the sensor samples per IMU sample.
    pub fn sensor_rate_hz(&self) -> f64 {
        1.0 / self.step_s
    }

    /// The mean rotor rate at `thrust_per_weight` (`|f_b| / g`, clamped to
    /// [0, [`MAX_THRUST_PER_WEIGHT`]]), Hz.
    pub fn rotor_hz(&self, thrust_per_weight: f64) -> f64 {
        self.rotor_hover_hz * thrust_per_weight.clamp(0.0, MAX_THRUST_PER_WEIGHT).sqrt()
    }

    /// The disturbance of the next IMU sample, with the rotors pushing `thrust_per_weight` times
    /// the weight (`|f_b| / g` of the true motion): moves the motors' speed offsets one IMU
    /// period on, runs the sensor's samples since the last IMU sample through the filter and
    /// returns the last one.
    pub fn next(&mut self, thrust_per_weight: f64) -> VibrationSample {
        let u = thrust_per_weight.clamp(0.0, MAX_THRUST_PER_WEIGHT);
        let rotor_hz = self.rotor_hover_hz * u.sqrt();
        for m in &mut self.motors {
            m.speed_offset =
                self.speed_decay * m.speed_offset + self.speed_kick * normal(&mut self.rng);
        }
        let mut y = [0.0; CHANNELS];
        for _ in 0..self.steps {
            let mut x = [0.0; CHANNELS];
            for (m, motor) in self.motors.iter_mut().enumerate() {
                let advance = TAU * rotor_hz * (1.0 + motor.speed_offset) * self.step_s;
                motor.phase_rad = (motor.phase_rad + advance).rem_euclid(TAU);
                let (s1, c1) = motor.phase_rad.sin_cos();
                let (mut s, mut c) = (s1, c1);
                for line in &self.lines[m * self.harmonics..(m + 1) * self.harmonics] {
                    for ch in 0..CHANNELS {
                        x[ch] += u * (line[0][ch] * s + line[1][ch] * c);
                    }
                    // sin, cos of (h + 1)φ from hφ.
                    (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
                }
            }
            for ch in 0..CHANNELS {
                let xi = x[ch] + self.broadband[ch] * normal(&mut self.rng);
                y[ch] = self.filters[ch].step(xi);
            }
        }
        VibrationSample {
            accel_m_s2: Vector3::new(y[0], y[1], y[2]),
            gyro_rad_s: Vector3::new(y[3], y[4], y[5]),
        }
    }
}

/// Where a tone at `f_hz` lands when sampled at `rate_hz`: folded into [0, rate/2].
pub fn aliased_hz(f_hz: f64, rate_hz: f64) -> f64 {
    let r = f_hz.rem_euclid(rate_hz);
    r.min(rate_hz - r)
}

/// Each channel's filters at the sensor's rate `sensor_hz`: the accelerometer's, then the gyro's.
fn channel_filters(config: &VibrationConfig, sensor_hz: f64) -> [Butterworth2; CHANNELS] {
    let mut filters = [Butterworth2::new(config.accel_cutoff_hz, sensor_hz); CHANNELS];
    for f in &mut filters[3..] {
        *f = Butterworth2::new(config.gyro_cutoff_hz, sensor_hz);
    }
    filters
}

/// σ of each channel's white noise at the sensor's rate: `√(β P / Σ h²)`, the broadband's share
/// `β` of the channel's power `P` through the filter's noise gain `Σ h²`.
fn broadband_sigmas(
    config: &VibrationConfig,
    filters: &[Butterworth2; CHANNELS],
) -> [f64; CHANNELS] {
    let power = channel_powers(config);
    std::array::from_fn(|c| (config.broadband_fraction * power[c] / filters[c].noise_gain()).sqrt())
}

/// The broadband vibration's density at low frequencies, per channel (accelerometer x, y, z in
/// m/s²/√Hz, then gyro x, y, z in rad/s/√Hz), for an IMU of period `imu_period_s`.
///
/// The broadband is white at the sensor's rate `f_s` with σ per sample, `σ/√f_s` as a density;
/// the low-pass passes it unchanged near 0 Hz (a Butterworth's gain there is 1), and taking one
/// sample in `k` keeps it (what folds down from above the IMU's Nyquist frequency is the filter's
/// stop band). This is what an integration over a keyframe sees of the vibration: its lines sit
/// far above and integrate to almost nothing. `√(β P / 2B)` with `B` the filter's equivalent
/// noise bandwidth: 0.020 m/s²/√Hz for the default 0.3 m/s², 30 % broadband and a 30 Hz cutoff.
pub fn broadband_density(config: &VibrationConfig, imu_period_s: f64) -> [f64; CHANNELS] {
    let step_s = imu_period_s / config.sensor_steps(imu_period_s) as f64;
    let filters = channel_filters(config, 1.0 / step_s);
    broadband_sigmas(config, &filters).map(|s| s * step_s.sqrt())
}

/// Each channel's power after the filter at hover: `(rms · w_j / √(mean w²))²`.
fn channel_powers(config: &VibrationConfig) -> [f64; CHANNELS] {
    let mut p = [0.0; CHANNELS];
    for (offset, rms, w) in [
        (0, config.accel_rms_m_s2, config.accel_axis_weights),
        (3, config.gyro_rms_rad_s, config.gyro_axis_weights),
    ] {
        let mean_square = w.iter().map(|x| x * x).sum::<f64>() / 3.0;
        for j in 0..3 {
            p[offset + j] = if mean_square > 0.0 {
                rms * rms * w[j] * w[j] / mean_square
            } else {
                0.0
            };
        }
    }
    p
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}
