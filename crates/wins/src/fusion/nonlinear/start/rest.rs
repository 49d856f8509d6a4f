//! Static initialization: while the IMU is at rest it measures gravity and its gyro bias, so
//! roll, pitch and the gyro bias are known before the first motion (yaw and position are the
//! gauge).
//!
//! A sample is at rest when, averaged over [`SMOOTHING_S`] (a single noisy sample of a MEMS IMU
//! must not end the rest), two things hold:
//! - **the means are those of a still sensor**: the rate's norm and the specific force's distance
//!   to gravity within [`NonlinearConfig::rest_max_gyro_rad_s`] and
//!   [`NonlinearConfig::rest_max_accel_deviation_m_s2`] *beyond what the sensor's own turn-on
//!   biases may add* ([`BIAS_SIGMAS`] σ of the dataset's `gyro_turn_on_bias_rad_s` per axis,
//!   `accel_turn_on_bias_m_s2` along gravity). A consumer accelerometer's bias is 0.2 m/s² (1σ):
//!   without it, one flight in several read 0.3 m/s² more than gravity on the ground, its rest was
//!   never found, and its start was left to the airborne solver;
//! - **the means stay put**: they move by no more than the same two thresholds from the rest's own
//!   means so far (the biases cancel), so the motion's onset is found as soon as for an ideal
//!   sensor.
//!
//! The averages exclude the last [`ONSET_MARGIN_S`] before the motion was detected: a smooth
//! take-off starts below any threshold.

use std::collections::VecDeque;

use nalgebra::{UnitQuaternion, Vector3};

use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::imu::ImuSample;
use crate::rig::ImuNoise;
use crate::time::Timestamp;

/// Averaging window of the rest test, s.
pub const SMOOTHING_S: f64 = 0.1;
/// Samples this close before the detected motion are left out of the rest's averages, s.
pub const ONSET_MARGIN_S: f64 = 0.3;
/// The turn-on biases a still sensor's means may show, in σ of the dataset's.
pub const BIAS_SIGMAS: f64 = 3.0;

/// What unknown turn-on biases may add to a still sensor's means: [`BIAS_SIGMAS`] σ of those
/// `noise` states, (rate's norm over the gyro's three axes rad/s, specific force along gravity
/// m/s²).
pub fn bias_allowance(noise: &ImuNoise) -> (f64, f64) {
    (
        BIAS_SIGMAS * 3f64.sqrt() * noise.gyro_turn_on_bias_rad_s,
        BIAS_SIGMAS * noise.accel_turn_on_bias_m_s2,
    )
}

/// Whether [`SMOOTHING_S`] means of the rate `w` and the specific force `f` can be a still
/// sensor's: the rate's norm below [`NonlinearConfig::rest_max_gyro_rad_s`], the specific
/// force's within [`NonlinearConfig::rest_max_accel_deviation_m_s2`] of gravity, each widened
/// by `allowance` (what biases not yet known may add, [`bias_allowance`]; none when the means
/// are corrected by measured biases).
pub fn means_at_rest(
    config: &NonlinearConfig,
    allowance: (f64, f64),
    gravity_m_s2: f64,
    w: &Vector3<f64>,
    f: &Vector3<f64>,
) -> bool {
    w.norm() < config.rest_max_gyro_rad_s + allowance.0
        && (f.norm() - gravity_m_s2).abs() < config.rest_max_accel_deviation_m_s2 + allowance.1
}

/// What a rest gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticInit {
    /// When the motion was detected.
    pub t: Timestamp,
    /// The last sample of the rest used (the body was still until then; the motion started
    /// between this and `t`).
    pub rest_end: Timestamp,
    /// Gyro bias (mean rate at rest), rad/s.
    pub gyro_bias_rad_s: Vector3<f64>,
    /// Roll and pitch (yaw 0): the rotation taking the mean specific force to +z.
    pub world_from_body: UnitQuaternion<f64>,
    /// Mean specific force at rest (body), m/s².
    pub specific_force_m_s2: Vector3<f64>,
    /// The accelerometer bias along gravity, `(|f| − g) f̂` (body), m/s²: the only part a rest
    /// shows (a bias across gravity is indistinguishable from a tilt).
    pub accel_bias_m_s2: Vector3<f64>,
    /// Length of the rest used, s.
    pub duration_s: f64,
    /// Samples averaged.
    pub samples: usize,
}

/// Watches the IMU for a rest followed by motion.
#[derive(Clone, Debug)]
pub struct RestDetector {
    config: NonlinearConfig,
    /// What the sensor's unknown turn-on biases may add to its means ([`bias_allowance`]).
    allowance: (f64, f64),
    gravity_m_s2: f64,
    /// Samples of the current rest (bounded by the start window's length).
    rest: VecDeque<ImuSample>,
    /// Their sums of the rate and the specific force.
    rest_sums: (Vector3<f64>, Vector3<f64>),
    /// The last [`SMOOTHING_S`] of samples (the test's average).
    recent: VecDeque<ImuSample>,
    /// Motion seen without a rest before it.
    moved: bool,
}

impl RestDetector {
    /// A detector for a sensor of noise `noise` (its turn-on biases).
    pub fn new(config: NonlinearConfig, noise: ImuNoise, gravity_m_s2: f64) -> Self {
        Self {
            config,
            allowance: bias_allowance(&noise),
            gravity_m_s2,
            rest: VecDeque::new(),
            rest_sums: (Vector3::zeros(), Vector3::zeros()),
            recent: VecDeque::new(),
            moved: false,
        }
    }

    /// Whether the IMU has moved (with or without a rest before).
    pub fn moved(&self) -> bool {
        self.moved
    }

    /// Takes one sample; returns the static initialization when the first motion after a long
    /// enough rest is detected.
    pub fn push(&mut self, s: &ImuSample) -> Option<StaticInit> {
        if self.moved {
            return None;
        }
        self.recent.push_back(*s);
        while self
            .recent
            .front()
            .is_some_and(|f| s.t.secs_since(f.t) > SMOOTHING_S)
        {
            self.recent.pop_front();
        }
        let n = self.recent.len() as f64;
        let w = self
            .recent
            .iter()
            .map(|r| r.gyro_rad_s)
            .sum::<Vector3<f64>>()
            / n;
        let f = self
            .recent
            .iter()
            .map(|r| r.accel_m_s2)
            .sum::<Vector3<f64>>()
            / n;
        let stays_put = self.rest.is_empty() || {
            let n = self.rest.len() as f64;
            (w - self.rest_sums.0 / n).norm() < self.config.rest_max_gyro_rad_s
                && (f - self.rest_sums.1 / n).norm() < self.config.rest_max_accel_deviation_m_s2
        };
        if stays_put && means_at_rest(&self.config, self.allowance, self.gravity_m_s2, &w, &f) {
            self.rest.push_back(*s);
            self.rest_sums.0 += s.gyro_rad_s;
            self.rest_sums.1 += s.accel_m_s2;
            let keep = self.config.max_start_window_s;
            while let Some(old) = self.rest.front().copied() {
                if s.t.secs_since(old.t) <= keep {
                    break;
                }
                self.rest.pop_front();
                self.rest_sums.0 -= old.gyro_rad_s;
                self.rest_sums.1 -= old.accel_m_s2;
            }
            return None;
        }
        self.moved = true;
        let until = s.t.0 - (ONSET_MARGIN_S * 1e9) as i64;
        let used: Vec<&ImuSample> = self.rest.iter().filter(|r| r.t.0 <= until).collect();
        let (first, last) = (used.first()?, used.last()?);
        let duration_s = last.t.secs_since(first.t);
        if duration_s < self.config.rest_min_s {
            return None;
        }
        let n = used.len() as f64;
        let gyro = used.iter().map(|r| r.gyro_rad_s).sum::<Vector3<f64>>() / n;
        let force = used.iter().map(|r| r.accel_m_s2).sum::<Vector3<f64>>() / n;
        let level = UnitQuaternion::rotation_between(&force, &Vector3::z())
            .unwrap_or_else(UnitQuaternion::identity);
        Some(StaticInit {
            t: s.t,
            rest_end: last.t,
            gyro_bias_rad_s: gyro,
            world_from_body: level,
            specific_force_m_s2: force,
            accel_bias_m_s2: force.normalize() * (force.norm() - self.gravity_m_s2),
            duration_s,
            samples: used.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imu::STANDARD_GRAVITY_M_S2;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A consumer MEMS IMU's datasheet (turn-on biases 0.5°/s and 20 mg, 1σ), as the simulator
    /// flies it.
    fn consumer() -> ImuNoise {
        crate::sim::imu::ImuModel::ConsumerMems.noise()
    }

    /// A rest with turn-on biases of `gyro_bias` and `accel_bias` (m/s², along gravity and
    /// across it), then a push along x of `push_m_s2` from sample 600: the static
    /// initialization, and the sample at which the motion was found.
    fn rest_then_push(
        gyro_bias: Vector3<f64>,
        accel_bias: Vector3<f64>,
        push_m_s2: f64,
    ) -> (Option<StaticInit>, Option<i64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.02).unwrap();
        let tilt = UnitQuaternion::from_euler_angles(0.05, -0.08, 1.0);
        let g_in_b = tilt.inverse() * Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2);
        let mut det = RestDetector::new(
            NonlinearConfig::default(),
            consumer(),
            STANDARD_GRAVITY_M_S2,
        );
        let (mut found, mut moved_at) = (None, None);
        for i in 0..800 {
            let moving = i >= 600;
            let s = ImuSample {
                t: Timestamp(i * 5_000_000),
                gyro_rad_s: gyro_bias + Vector3::from_fn(|_, _| noise.sample(&mut rng) * 0.1),
                accel_m_s2: g_in_b
                    + accel_bias
                    + Vector3::from_fn(|_, _| noise.sample(&mut rng))
                    + Vector3::x() * if moving { push_m_s2 } else { 0.0 },
            };
            if let Some(init) = det.push(&s) {
                found = Some(init);
            }
            if det.moved() && moved_at.is_none() {
                moved_at = Some(i);
            }
        }
        (found, moved_at)
    }

    /// A consumer IMU whose biases read 0.35 m/s² more than gravity and 0.03 rad/s at rest (1.8
    /// and 2 σ of its datasheet's): the rest is found (it was not when only the means' distance
    /// to an ideal sensor's was tested), its bias along gravity measured, and a push of 0.5 m/s²
    /// ends it within the smoothing as for a sensor without biases.
    #[test]
    fn a_biased_consumer_imus_rest_is_found_and_its_end_as_soon() {
        let tilt = UnitQuaternion::from_euler_angles(0.05, -0.08, 1.0);
        let up_in_b = tilt.inverse() * Vector3::z();
        let (gyro_bias, accel_bias) = (Vector3::new(0.02, -0.015, 0.015), up_in_b * 0.35);
        let (init, moved_at) = rest_then_push(gyro_bias, accel_bias, 0.5);
        let init = init.expect("the biased rest is found");
        assert!((init.gyro_bias_rad_s - gyro_bias).norm() < 3e-4);
        assert!(
            (init.accel_bias_m_s2 - accel_bias).norm() < 3e-3,
            "{}",
            init.accel_bias_m_s2
        );
        let (_, unbiased_moved_at) = rest_then_push(Vector3::zeros(), Vector3::zeros(), 0.5);
        let (moved_at, unbiased) = (moved_at.unwrap_or(0), unbiased_moved_at.unwrap_or(0));
        assert!(
            (600..625).contains(&moved_at) && moved_at <= unbiased + 2,
            "motion found at sample {moved_at} (without biases {unbiased})"
        );
    }

    #[test]
    fn a_tilted_rest_gives_roll_pitch_and_gyro_bias_then_motion_ends_it() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.02).unwrap();
        let tilt = UnitQuaternion::from_euler_angles(0.05, -0.08, 1.0);
        let bias = Vector3::new(0.004, -0.002, 0.003);
        let accel_bias = Vector3::new(0.01, 0.02, -0.03);
        let g_in_b = tilt.inverse() * Vector3::new(0.0, 0.0, STANDARD_GRAVITY_M_S2);
        let mut det = RestDetector::new(
            NonlinearConfig::default(),
            consumer(),
            STANDARD_GRAVITY_M_S2,
        );
        let mut found = None;
        for i in 0..800 {
            let t = Timestamp(i * 5_000_000);
            let moving = i >= 600;
            let accel = g_in_b
                + accel_bias
                + Vector3::from_fn(|_, _| noise.sample(&mut rng))
                + if moving {
                    Vector3::x() * 2.0
                } else {
                    Vector3::zeros()
                };
            let s = ImuSample {
                t,
                gyro_rad_s: bias + Vector3::from_fn(|_, _| noise.sample(&mut rng) * 0.1),
                accel_m_s2: accel,
            };
            if let Some(init) = det.push(&s) {
                found = Some(init);
            }
        }
        let init = found.expect("the rest is found");
        assert!(det.moved());
        assert!((init.gyro_bias_rad_s - bias).norm() < 3e-4);
        // Roll and pitch: the body's up direction in w is +z.
        let up = init.world_from_body * g_in_b.normalize();
        assert!((up - Vector3::z()).norm() < 6e-3, "{up}");
        // The accelerometer bias along gravity, not across it.
        let along = g_in_b.normalize();
        let seen = init.accel_bias_m_s2.dot(&along);
        assert!((seen - accel_bias.dot(&along)).abs() < 2e-3, "{seen}");
        assert!((init.accel_bias_m_s2 - along * seen).norm() < 1e-3);
        assert!(
            init.duration_s > 2.5 && init.duration_s < 3.0,
            "{}",
            init.duration_s
        );
        assert!(init.t.0 >= 600 * 5_000_000);
    }

    #[test]
    fn motion_from_the_start_gives_no_static_initialization() {
        let mut det = RestDetector::new(
            NonlinearConfig::default(),
            consumer(),
            STANDARD_GRAVITY_M_S2,
        );
        let mut any = false;
        for i in 0..400 {
            let s = ImuSample {
                t: Timestamp(i * 5_000_000),
                gyro_rad_s: Vector3::new(0.0, 0.0, 0.5),
                accel_m_s2: Vector3::new(1.0, 0.0, STANDARD_GRAVITY_M_S2),
            };
            any |= det.push(&s).is_some();
        }
        assert!(!any);
        assert!(det.moved());
    }
}
