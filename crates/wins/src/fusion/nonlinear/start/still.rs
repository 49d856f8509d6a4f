//! Stillness: when the IMU shows the body at rest (on the ground before take-off or after
//! landing), the window may hold the keyframe's velocity at zero ([`crate::fusion::nonlinear::factors::zero_velocity`]).
//!
//! An IMU cannot tell rest from flight at a constant velocity: both read gravity and no rotation.
//! Three tests separate them in practice, and all are required:
//! - **the samples' scatter**: over the last [`SMOOTHING_S`], each axis of the specific force and
//!   of the rate scatters by no more than [`NonlinearConfig::still_max_noise_ratio`] times the
//!   sensor's own white noise per sample (`density / √Δt`, floored at [`MIN_ACCEL_SCATTER_M_S2`]
//!   and [`MIN_GYRO_SCATTER_RAD_S`]). Spinning rotors shake the airframe far above the sensor's
//!   noise, so a flying (or armed) drone is never still;
//! - **the means**, as for the static start ([`crate::fusion::nonlinear::start::rest`]): the rate's norm below
//!   [`NonlinearConfig::rest_max_gyro_rad_s`], the specific force's within
//!   [`NonlinearConfig::rest_max_accel_deviation_m_s2`] of gravity, once corrected by the biases
//!   the rest before take-off measured (no allowance for unknown biases, unlike the static
//!   start: a slow steady turn would pass for stillness);
//! - **the means stay put**: no axis of a 0.1 s mean moves from the means when the stillness
//!   began by more than [`MEAN_CHANGE_SIGMAS`] σ of the difference of two such means (floored as
//!   above). A smooth motion starts below any fixed threshold: a hover's descent accelerates by
//!   a few hundredths of m/s² in its first tenth of a second, and a rest that took it for
//!   stillness would hold the descent's first second still.
//!
//! The simulated IMU has no vibration: there the third test is what keeps a hover's descent, a
//! straight leg's slow start or a ramp from being held (`tests/it/zero_velocity.rs` checks every
//! built-in flight). The window adds a last bound: its own speed estimate is small
//! ([`NonlinearConfig::zero_velocity_max_speed_m_s`]).

use std::collections::VecDeque;

use nalgebra::Vector3;

use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::start::rest::{SMOOTHING_S, means_at_rest};
use crate::imu::ImuSample;
use crate::rig::ImuNoise;
use crate::time::Timestamp;

/// Least scatter bound of the specific force, m/s² (an ideal sensor's samples, a real one's
/// quantization).
pub const MIN_ACCEL_SCATTER_M_S2: f64 = 0.01;
/// Least scatter bound of the rate, rad/s.
pub const MIN_GYRO_SCATTER_RAD_S: f64 = 1e-3;
/// A 0.1 s mean that moves by more than this many σ of the difference of two such means (per
/// axis) from the means when the stillness began ends it.
pub const MEAN_CHANGE_SIGMAS: f64 = 5.0;

/// Running sums over the last [`SMOOTHING_S`] of samples.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    n: usize,
    f: Vector3<f64>,
    ff: Vector3<f64>,
    w: Vector3<f64>,
    ww: Vector3<f64>,
}

impl Sums {
    fn add(&mut self, s: &ImuSample, sign: f64) {
        let (f, w) = (s.accel_m_s2, s.gyro_rad_s);
        if sign > 0.0 {
            self.n += 1;
        } else {
            self.n = self.n.saturating_sub(1);
        }
        self.f += f * sign;
        self.ff += f.component_mul(&f) * sign;
        self.w += w * sign;
        self.ww += w.component_mul(&w) * sign;
    }

    /// Means and the largest per-axis sample variance of the specific force and of the rate.
    fn moments(&self) -> Option<(Vector3<f64>, f64, Vector3<f64>, f64)> {
        if self.n < 3 {
            return None;
        }
        let n = self.n as f64;
        let var = |sum: &Vector3<f64>, sq: &Vector3<f64>| {
            let mean = sum / n;
            let v = (sq / n - mean.component_mul(&mean)) * (n / (n - 1.0));
            (mean, v.max().max(0.0))
        };
        let (mf, vf) = var(&self.f, &self.ff);
        let (mw, vw) = var(&self.w, &self.ww);
        Some((mf, vf, mw, vw))
    }
}

/// Watches the IMU for stillness (module doc).
#[derive(Clone, Debug)]
pub struct StillDetector {
    config: NonlinearConfig,
    /// The gyro bias and the accelerometer bias along gravity a rest measured, when one did.
    biases: Option<(Vector3<f64>, Vector3<f64>)>,
    gravity_m_s2: f64,
    accel_density: f64,
    gyro_density: f64,
    recent: VecDeque<ImuSample>,
    sums: Sums,
    /// Since when the IMU has been still, when it is now.
    still_since: Option<Timestamp>,
    /// The means when the stillness began.
    reference: Option<Means>,
}

/// The 0.1 s means of a still IMU, and how far a later mean may move from them.
#[derive(Clone, Copy, Debug)]
struct Means {
    f: Vector3<f64>,
    w: Vector3<f64>,
    /// Largest change of a specific force mean's axis, m/s² …
    f_bound: f64,
    /// … and of a rate mean's, rad/s.
    w_bound: f64,
}

impl Means {
    fn moved_from(&self, reference: &Means) -> bool {
        (self.f - reference.f).amax() > reference.f_bound
            || (self.w - reference.w).amax() > reference.w_bound
    }
}

impl StillDetector {
    /// A detector with the thresholds of `config` and the sensor's noise `noise`.
    pub fn new(config: &NonlinearConfig, noise: &ImuNoise, gravity_m_s2: f64) -> Self {
        Self {
            config: config.clone(),
            gravity_m_s2,
            biases: None,
            accel_density: noise.accel_noise_density_m_s2_sqrt_hz,
            gyro_density: noise.gyro_noise_density_rad_s_sqrt_hz,
            recent: VecDeque::new(),
            sums: Sums::default(),
            still_since: None,
            reference: None,
        }
    }

    /// From now on the means are corrected by the biases a rest measured (`gyro_rad_s`, and the
    /// accelerometer's along gravity `accel_m_s2`).
    pub fn set_biases(&mut self, gyro_rad_s: Vector3<f64>, accel_m_s2: Vector3<f64>) {
        self.biases = Some((gyro_rad_s, accel_m_s2));
    }

    /// Takes one sample (in time order; a gap longer than [`SMOOTHING_S`] starts afresh).
    pub fn push(&mut self, s: &ImuSample) {
        if self
            .recent
            .back()
            .is_some_and(|b| s.t.secs_since(b.t) > SMOOTHING_S || s.t < b.t)
        {
            self.recent.clear();
            self.sums = Sums::default();
            self.still_since = None;
            self.reference = None;
        }
        self.recent.push_back(*s);
        self.sums.add(s, 1.0);
        while let Some(front) = self.recent.front().copied() {
            if s.t.secs_since(front.t) <= SMOOTHING_S {
                break;
            }
            self.recent.pop_front();
            self.sums.add(&front, -1.0);
        }
        let still = self.means_if_still();
        match (still, self.reference) {
            (Some(now), Some(reference)) if now.moved_from(&reference) => {
                // A smooth motion's onset (a hover's descent): the means have moved.
                self.still_since = None;
                self.reference = None;
            }
            (Some(now), None) => {
                self.still_since = self.recent.front().map(|f| f.t);
                self.reference = Some(now);
            }
            (Some(_), Some(_)) => {}
            (None, _) => {
                self.still_since = None;
                self.reference = None;
            }
        }
    }

    /// The means now when the samples in the average pass every per-window test (module doc).
    fn means_if_still(&self) -> Option<Means> {
        let (first, last) = (self.recent.front()?, self.recent.back()?);
        let span_s = last.t.secs_since(first.t);
        let (mean_f, var_f, mean_w, var_w) = self.sums.moments()?;
        if span_s < 0.5 * SMOOTHING_S {
            return None;
        }
        let dt_s = span_s / (self.sums.n - 1) as f64;
        // Each sample's white noise, and the bounds on the scatter and on a mean's change.
        let per_sample = |density: f64| density / dt_s.sqrt();
        let (sa, sg) = (
            per_sample(self.accel_density),
            per_sample(self.gyro_density),
        );
        let ratio = self.config.still_max_noise_ratio;
        let accel_bound = (ratio * sa).max(MIN_ACCEL_SCATTER_M_S2);
        let gyro_bound = (ratio * sg).max(MIN_GYRO_SCATTER_RAD_S);
        // In flight the biases' allowance would let a slow, steady turn pass for stillness: the
        // means are corrected by the biases the rest measured instead, when there was one.
        let (bg, ba) = self.biases.unwrap_or_default();
        let still = means_at_rest(
            &self.config,
            (0.0, 0.0),
            self.gravity_m_s2,
            &(mean_w - bg),
            &(mean_f - ba),
        ) && var_f <= accel_bound * accel_bound
            && var_w <= gyro_bound * gyro_bound;
        let change = |sigma: f64, floor: f64| {
            (MEAN_CHANGE_SIGMAS * std::f64::consts::SQRT_2 * sigma / (self.sums.n as f64).sqrt())
                .max(floor)
        };
        still.then(|| Means {
            f: mean_f,
            w: mean_w,
            f_bound: change(sa, MIN_ACCEL_SCATTER_M_S2),
            w_bound: change(sg, MIN_GYRO_SCATTER_RAD_S),
        })
    }

    /// How long the IMU has been still up to `t`, s (0 when it is not still now).
    pub fn still_for_s(&self, t: Timestamp) -> f64 {
        self.still_since
            .map_or(0.0, |since| t.secs_since(since).max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    use super::*;
    use crate::imu::STANDARD_GRAVITY_M_S2 as G;

    const RATE_HZ: f64 = 200.0;

    fn at(t_s: f64) -> Timestamp {
        Timestamp((t_s * 1e9).round() as i64)
    }

    fn noise() -> ImuNoise {
        ImuNoise {
            gyro_noise_density_rad_s_sqrt_hz: 1.7e-4,
            gyro_bias_random_walk_rad_s2_sqrt_hz: 2e-5,
            gyro_turn_on_bias_rad_s: 0.0,
            accel_noise_density_m_s2_sqrt_hz: 2e-3,
            accel_bias_random_walk_m_s3_sqrt_hz: 3e-3,
            accel_turn_on_bias_m_s2: 0.0,
        }
    }

    /// `seconds` of samples from `t0_s`: gravity (and `shake`, a 120 Hz vibration along x of that
    /// amplitude, m/s²) with the sensor's white noise.
    fn samples(t0_s: f64, seconds: f64, shake: f64, rng: &mut ChaCha8Rng) -> Vec<ImuSample> {
        let n = noise();
        let dt = 1.0 / RATE_HZ;
        let sa = Normal::new(0.0, n.accel_noise_density_m_s2_sqrt_hz / dt.sqrt()).unwrap();
        let sg = Normal::new(0.0, n.gyro_noise_density_rad_s_sqrt_hz / dt.sqrt()).unwrap();
        (0..(seconds * RATE_HZ) as usize)
            .map(|i| {
                let t = at(t0_s).0 + i as i64 * 5_000_000;
                let phase = 2.0 * std::f64::consts::PI * 120.0 * t as f64 * 1e-9;
                let vib = shake * (phase + 0.3).sin();
                ImuSample {
                    t: Timestamp(t),
                    gyro_rad_s: Vector3::from_fn(|_, _| sg.sample(rng)),
                    accel_m_s2: Vector3::new(vib, 0.0, G) + Vector3::from_fn(|_, _| sa.sample(rng)),
                }
            })
            .collect()
    }

    /// A detector that has seen `seconds` of samples with `shake` from t = 0, and its RNG.
    fn after(seed: u64, seconds: f64, shake: f64) -> (StillDetector, ChaCha8Rng) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut d = StillDetector::new(&NonlinearConfig::default(), &noise(), G);
        for s in samples(0.0, seconds, shake, &mut rng) {
            d.push(&s);
        }
        (d, rng)
    }

    #[test]
    fn a_quiet_imu_is_still_from_its_first_tenth_of_a_second() {
        let (d, _) = after(5, 2.0, 0.0);
        let held = d.still_for_s(at(2.0));
        assert!((1.85..=2.0).contains(&held), "{held}");
    }

    #[test]
    fn rotor_vibration_and_motion_are_not_still() {
        // A hover's vibration averages out of the 0.1 s mean, not out of the scatter.
        let (mut d, mut rng) = after(6, 1.0, 0.5);
        assert_eq!(d.still_for_s(at(1.0)), 0.0);
        // Quiet, then a turn.
        for s in samples(1.0, 1.0, 0.0, &mut rng) {
            d.push(&s);
        }
        assert!(d.still_for_s(at(2.0)) > 0.8);
        for mut s in samples(2.0, 0.2, 0.0, &mut rng) {
            s.gyro_rad_s.z += 0.2;
            d.push(&s);
        }
        assert_eq!(d.still_for_s(at(2.2)), 0.0);
    }

    /// A hover, then a smooth descent: its acceleration grows as `2.3 t²` m/s² (a 1.4 m septic
    /// move over 4 s), under the 0.3 m/s² of the means' test for its first 0.36 s. The
    /// stillness ends within 0.25 s (the descent then at 1 cm/s).
    #[test]
    fn a_smooth_descent_from_a_hover_ends_the_stillness_at_once() {
        let (mut d, mut rng) = after(8, 1.0, 0.0);
        assert!(d.still_for_s(at(1.0)) > 0.8);
        for mut s in samples(1.0, 1.0, 0.0, &mut rng) {
            let tau = s.t.secs_since(at(1.0));
            s.accel_m_s2.z -= 2.3 * tau * tau;
            d.push(&s);
            if tau > 0.25 {
                let held = d.still_for_s(s.t);
                assert!(held < 0.2, "still for {held} s at {tau} s into the descent");
            }
        }
    }

    #[test]
    fn a_gap_in_the_samples_starts_afresh() {
        let (mut d, mut rng) = after(7, 1.0, 0.0);
        for s in samples(3.0, 0.02, 0.0, &mut rng) {
            d.push(&s);
        }
        assert_eq!(d.still_for_s(at(3.02)), 0.0);
    }
}
