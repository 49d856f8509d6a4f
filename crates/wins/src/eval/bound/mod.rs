//! How well could any estimator have done on this flight? A lower bound on the error of the
//! trajectory, from the flight's own geometry, IMU and bearings (the Cramér–Rao bound,
//! linearized at the truth).
//!
//! The unknowns are the body's attitude, velocity and position at keyframes every
//! [`BoundConfig::keyframe_s`], the IMU's biases, every AP's position and the barometer's offset.
//! The measurements are the IMU between keyframes (`model.rs`), every received packet's bearing
//! `sin θ` with white errors of [`BoundConfig::bearing_sigma_rad`] at broadside (an array
//! measures `sin θ`: the angle's error grows as `1/cos θ` towards the array's axis), the
//! barometer's samples, and, while the truth is at rest, the velocity. The information matrix
//! `J` is summed at the truth and inverted (`normal.rs`); `J⁻¹` bounds the covariance of any
//! unbiased estimate from below. The expected error the scoring's alignment (a heading and a
//! translation) leaves is then `tr((I − P) J⁻¹ (I − P))` over the keyframes' positions, `P` the
//! projection onto what the alignment absorbs.
//!
//! Everything here is generous to the estimator, so that the bound stays below what any
//! estimator can reach: the bearings' errors are white (a real AoA error persists for seconds
//! and a reflection biases it), the chain offsets and the mirror side are known, the biases do
//! not walk, the IMU's noise is what `dataset.toml` states with, on a simulated flight, the rotors'
//! vibration its truth records (its broadband near 0 Hz; the rotor lines, which integrate to
//! almost nothing over a keyframe, counted as none), the motion between a keyframe and a packet adds no uncertainty, the estimator sees the whole flight
//! (a smoother; the poses sent to a flight controller are causal), and the start at rest gives the
//! tilt to the accelerometer's bias over `g`. A flight whose bound is above a target cannot meet
//! it, whatever the estimator.

mod events;
mod load;
mod model;
mod normal;
#[cfg(test)]
mod tests;

use nalgebra::{Isometry3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

pub use load::load_bound_input;

use crate::dataset::truth::Pose;
use crate::fusion::nonlinear::solve::shares::variance_ratio;
use crate::rig::ImuNoise;
use crate::time::Timestamp;
use events::{Event, events_by_pose};
pub use model::ImuVibration;
use model::{Mat9, Mat9x6, POS, Row9, Step, VEL};
use normal::{Layout, Normal, Rows};

/// Settings of [`flight_bound`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoundConfig {
    /// Standard deviation of one bearing's `sin θ` (its angle at broadside), white, rad. The
    /// default 1° is under what the AoA stage delivers in the simulated rooms (1.1° median,
    /// 3.2° at the 90th percentile, persisting over seconds).
    pub bearing_sigma_rad: f64,
    /// Correlation time of each AP's bearing error, s (a first-order Gauss–Markov process; 0:
    /// white). Correlated bearings are worth `1/R` of an independent one each,
    /// `R = coth(1/(2λτ))` at the AP's packet rate `λ`
    /// ([`crate::fusion::nonlinear::solve::shares`]): the effective sample size of the mean, not
    /// a strict bound (a smoother could separate a slowly moving error a little better).
    pub bearing_correlation_s: f64,
    /// The scored part of the flight starts here, s after the first pose.
    pub from_s: f64,
    /// Keyframe spacing, s (lengthened to keep at most [`BoundConfig::max_keyframes`]).
    pub keyframe_s: f64,
    /// Most keyframes (the information matrix is dense: 9 unknowns each).
    pub max_keyframes: usize,
    /// Standard deviation of one barometer sample, m (white; its drift is taken as none).
    pub baro_sigma_m: f64,
    /// Below this true speed the body is at rest and its velocity known, m/s.
    pub rest_speed_m_s: f64,
    /// Counts the rotors' vibration the input records ([`BoundInput::vibration`]) in the IMU's
    /// noise; `false` bounds the flight as if the IMU were on a bench.
    pub imu_vibration: bool,
}

impl Default for BoundConfig {
    fn default() -> Self {
        Self {
            bearing_sigma_rad: 1f64.to_radians(),
            bearing_correlation_s: 0.0,
            from_s: 0.0,
            keyframe_s: 0.5,
            max_keyframes: 240,
            baro_sigma_m: 0.25,
            rest_speed_m_s: 0.005,
            imu_vibration: true,
        }
    }
}

/// One flight, as the bound needs it: the truth and what the sensors gave.
#[derive(Clone, Debug)]
pub struct BoundInput {
    /// True body poses at the IMU's samples, increasing in time.
    pub poses: Vec<Pose>,
    /// The IMU's noise, as the dataset states it.
    pub noise: ImuNoise,
    /// The rotors' vibration on top of it, when the truth records it.
    pub vibration: Option<ImuVibration>,
    /// `body_from_array`.
    pub body_from_array: Isometry3<f64>,
    /// True AP positions in the world, m.
    pub aps: Vec<Vector3<f64>>,
    /// Per AP, the times of the received packets.
    pub packets: Vec<Vec<Timestamp>>,
    /// Barometer sample times (empty without one).
    pub baro: Vec<Timestamp>,
    /// Gravity, m/s².
    pub gravity_m_s2: f64,
}

/// The bound at one keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct KeyframeBound {
    /// Time on the IMU clock.
    pub t: Timestamp,
    /// `√tr Σ_p`: position, relative to the first keyframe's position and heading, m.
    pub position_sigma_m: f64,
}

/// The bound of one flight.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FlightBound {
    /// Expected ATE RMSE after the heading-and-translation alignment, over the keyframes from
    /// [`BoundConfig::from_s`], m: no estimator's is lower (in expectation).
    pub ate_rmse_m: f64,
    /// Every keyframe's position bound.
    pub keyframes: Vec<KeyframeBound>,
    /// Per AP, `√tr Σ` of its position, m (relative to the first keyframe).
    pub ap_sigma_m: Vec<f64>,
    /// Bearings counted.
    pub bearings: usize,
}

/// Why a bound cannot be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum BoundError {
    /// The input does not describe a flight.
    #[error("{0}")]
    Input(String),
    /// The information matrix is singular: something is not observed at all.
    #[error("the flight's information is singular (an unknown no measurement reaches)")]
    Singular,
}

/// The bound of one flight ([module docs](self)).
pub fn flight_bound(input: &BoundInput, config: &BoundConfig) -> Result<FlightBound, BoundError> {
    let truth = Linearization::new(input, config)?;
    let layout = Layout {
        keyframes: truth.keyframes.len(),
        aps: input.aps.len(),
        baro: !input.baro.is_empty(),
    };
    let mut normal = Normal::new(layout, &truth.attitude[0]);
    let bearings = truth.sum(input, config, &mut normal)?;
    truth.priors(input, config, &mut normal);

    let t0 = input.poses[0].t;
    let scored: Vec<usize> = (0..layout.keyframes)
        .filter(|&k| input.poses[truth.keyframes[k]].t.secs_since(t0) >= config.from_s)
        .collect();
    let mut wanted = Vec::new();
    let mut slots = Vec::new();
    for k in 0..layout.keyframes {
        for i in normal::position_indices(&layout, k) {
            slots.push(i.map(|i| {
                wanted.push(i);
                wanted.len() - 1
            }));
        }
    }
    let ap_base = wanted.len();
    for a in 0..layout.aps {
        for j in 0..3 {
            wanted.push(layout.ap(a, j));
        }
    }
    let cov = normal.covariance_of(&wanted).ok_or(BoundError::Singular)?;
    let pos_cov =
        |k: usize, a: usize, l: usize, b: usize| match (slots[3 * k + a], slots[3 * l + b]) {
            (Some(i), Some(j)) => cov[(i, j)],
            _ => 0.0,
        };
    let keyframes = (0..layout.keyframes)
        .map(|k| KeyframeBound {
            t: input.poses[truth.keyframes[k]].t,
            position_sigma_m: (0..3)
                .map(|a| pos_cov(k, a, k, a))
                .sum::<f64>()
                .max(0.0)
                .sqrt(),
        })
        .collect();
    let n = scored.len();
    let mut sigma = nalgebra::DMatrix::zeros(3 * n, 3 * n);
    for (r, &k) in scored.iter().enumerate() {
        for (c, &l) in scored.iter().enumerate() {
            for a in 0..3 {
                for b in 0..3 {
                    sigma[(3 * r + a, 3 * c + b)] = pos_cov(k, a, l, b);
                }
            }
        }
    }
    let positions: Vec<Vector3<f64>> = scored
        .iter()
        .map(|&k| input.poses[truth.keyframes[k]].p_b_in_w)
        .collect();
    let ate_rmse_m = if n == 0 {
        0.0
    } else {
        (normal::aligned_sum_of_squares(&sigma, &positions) / n as f64)
            .max(0.0)
            .sqrt()
    };
    let ap_sigma_m = (0..layout.aps)
        .map(|a| {
            (0..3)
                .map(|j| cov[(ap_base + 3 * a + j, ap_base + 3 * a + j)])
                .sum::<f64>()
                .max(0.0)
                .sqrt()
        })
        .collect();
    Ok(FlightBound {
        ate_rmse_m,
        keyframes,
        ap_sigma_m,
        bearings,
    })
}

/// The truth the models are linearized at.
struct Linearization {
    /// Attitude at each pose.
    attitude: Vec<Rotation3<f64>>,
    /// Specific force in `b` at each pose, m/s².
    f_b: Vec<Vector3<f64>>,
    /// Speed at each pose, m/s.
    speed: Vec<f64>,
    /// The poses that are keyframes (the first is pose 0).
    keyframes: Vec<usize>,
}

impl Linearization {
    fn new(input: &BoundInput, config: &BoundConfig) -> Result<Self, BoundError> {
        let bad = |s: &str| Err(BoundError::Input(s.to_string()));
        let poses = &input.poses;
        if poses.len() < 3 {
            return bad("fewer than 3 true poses");
        }
        if poses.windows(2).any(|w| w[1].t <= w[0].t) {
            return bad("the true poses' times do not increase");
        }
        if input.aps.len() != input.packets.len() {
            return bad("a packet list per AP is needed");
        }
        let n = &input.noise;
        if !(n.gyro_noise_density_rad_s_sqrt_hz > 0.0 && n.accel_noise_density_m_s2_sqrt_hz > 0.0) {
            return bad("the IMU's noise densities must be > 0");
        }
        if !(config.bearing_sigma_rad > 0.0 && config.baro_sigma_m > 0.0 && config.keyframe_s > 0.0)
        {
            return bad("the bearing's and barometer's σ and the keyframe spacing must be > 0");
        }
        if !(config.bearing_correlation_s >= 0.0 && config.bearing_correlation_s.is_finite()) {
            return bad("the bearing's correlation time must be finite and ≥ 0");
        }
        let attitude: Vec<Rotation3<f64>> = poses
            .iter()
            .map(|p| p.world_from_body.to_rotation_matrix())
            .collect();
        let last = poses.len() - 1;
        let mut f_b = Vec::with_capacity(poses.len());
        let mut speed = Vec::with_capacity(poses.len());
        for (i, r) in attitude.iter().enumerate() {
            let k = i.clamp(1, last - 1);
            let (p0, p1, p2) = (&poses[k - 1], &poses[k], &poses[k + 1]);
            let dt0 = p1.t.secs_since(p0.t);
            let dt1 = p2.t.secs_since(p1.t);
            let v0 = (p1.p_b_in_w - p0.p_b_in_w) / dt0;
            let v1 = (p2.p_b_in_w - p1.p_b_in_w) / dt1;
            let a = 2.0 * (v1 - v0) / (dt0 + dt1);
            f_b.push(r.transpose() * (a + Vector3::z() * input.gravity_m_s2));
            speed.push(if i == 0 {
                v1.norm()
            } else {
                v0.norm().max(v1.norm())
            });
        }
        let t0 = poses[0].t;
        let duration = poses[last].t.secs_since(t0);
        let spacing = config
            .keyframe_s
            .max(duration / config.max_keyframes.max(2) as f64);
        let mut keyframes = vec![0];
        for (i, p) in poses.iter().enumerate().skip(1) {
            if p.t.secs_since(t0) >= spacing * keyframes.len() as f64 {
                keyframes.push(i);
            }
        }
        Ok(Self {
            attitude,
            f_b,
            speed,
            keyframes,
        })
    }

    /// Walks the flight: the IMU's links between keyframes, the bearings and the barometer.
    /// Returns the bearings counted.
    fn sum(
        &self,
        input: &BoundInput,
        config: &BoundConfig,
        normal: &mut Normal,
    ) -> Result<usize, BoundError> {
        let poses = &input.poses;
        let events = events_by_pose(input);
        let layout = *normal.layout();
        let mut k = 0;
        let mut next_keyframe = self.keyframes.get(1).copied();
        let (mut phi, mut gamma, mut q) = (Mat9::identity(), Mat9x6::zeros(), Mat9::zeros());
        let span_s = poses[poses.len() - 1].t.secs_since(poses[0].t);
        let bearing_w: Vec<nalgebra::Matrix1<f64>> = input
            .packets
            .iter()
            .map(|list| {
                let rate_hz = list.len() as f64 / span_s.max(f64::MIN_POSITIVE);
                let ratio = variance_ratio(rate_hz, config.bearing_correlation_s);
                nalgebra::Matrix1::new(1.0 / (config.bearing_sigma_rad.powi(2) * ratio))
            })
            .collect();
        let baro_w = nalgebra::Matrix1::new(1.0 / config.baro_sigma_m.powi(2));
        let mut bearings = 0;
        let mut event = events.iter().peekable();
        for i in 0..poses.len() {
            if Some(i) == next_keyframe {
                let q_inv = q
                    .cholesky()
                    .map(|c| c.inverse())
                    .ok_or(BoundError::Singular)?;
                normal.add(&normal::link_rows(k, &phi, &gamma), &q_inv);
                k += 1;
                next_keyframe = self.keyframes.get(k + 1).copied();
                (phi, gamma, q) = (Mat9::identity(), Mat9x6::zeros(), Mat9::zeros());
            }
            if self.speed[i] < config.rest_speed_m_s && self.keyframes[k] == i {
                for j in 0..3 {
                    if let Some(v) = layout.keyframe(k, VEL + j) {
                        normal.add_prior(v, REST_VELOCITY_SIGMA_M_S);
                    }
                }
            }
            while let Some(&&(pose, what)) = event.peek() {
                if pose != i {
                    break;
                }
                event.next();
                let (h, single): (Row9, Vec<(usize, nalgebra::Matrix1<f64>)>) = match what {
                    Event::Packet(a) => {
                        let Some(lin) = model::bearing(
                            &self.attitude[i],
                            &poses[i].p_b_in_w,
                            &input.body_from_array,
                            &input.aps[a],
                        ) else {
                            continue;
                        };
                        bearings += 1;
                        let aps = (0..3)
                            .map(|j| (layout.ap(a, j), nalgebra::Matrix1::new(lin.h_ap[j])))
                            .collect();
                        (lin.h_state, aps)
                    }
                    Event::Baro => {
                        let mut h = Row9::zeros();
                        h[POS + 2] = 1.0;
                        let offset = layout
                            .baro_offset()
                            .map(|o| (o, nalgebra::Matrix1::new(1.0)));
                        (h, offset.into_iter().collect())
                    }
                };
                let rows = Rows {
                    keyframes: vec![(k, h * phi)],
                    bias: Some(h * gamma),
                    singles: single,
                };
                let w = match what {
                    Event::Baro => &baro_w,
                    Event::Packet(a) => &bearing_w[a],
                };
                normal.add(&rows, w);
            }
            if i + 1 < poses.len() {
                let step = Step {
                    world_from_body: self.attitude[i],
                    delta: self.attitude[i].transpose() * self.attitude[i + 1],
                    f_b: self.f_b[i],
                    dt_s: poses[i + 1].t.secs_since(poses[i].t),
                };
                let (a, b) = step.transition();
                phi = a * phi;
                gamma = a * gamma + b;
                let vibration = input.vibration.as_ref().filter(|_| config.imu_vibration);
                let (gyro, accel) = model::densities(&input.noise, vibration, poses[i].t);
                q = a * q * a.transpose() + model::step_noise(gyro, accel, step.dt_s);
            }
        }
        Ok(bearings)
    }

    /// The biases' turn-on spread, the start's tilt and velocity, loose priors on the APs and
    /// the barometer's offset (which keep a flight that never sees an AP invertible).
    fn priors(&self, input: &BoundInput, config: &BoundConfig, normal: &mut Normal) {
        let layout = *normal.layout();
        let n = &input.noise;
        for j in 0..3 {
            normal.add_prior(layout.bias(j), n.gyro_turn_on_bias_rad_s.max(MIN_SIGMA));
            normal.add_prior(layout.bias(3 + j), n.accel_turn_on_bias_m_s2.max(MIN_SIGMA));
            for a in 0..layout.aps {
                normal.add_prior(layout.ap(a, j), LOOSE_SIGMA_M);
            }
        }
        let at_rest = self.speed[0] < config.rest_speed_m_s;
        let tilt = if at_rest {
            (n.accel_turn_on_bias_m_s2 / input.gravity_m_s2).max(MIN_SIGMA)
        } else {
            LOOSE_TILT_RAD
        };
        for j in 0..2 {
            if let Some(i) = layout.keyframe(0, j) {
                normal.add_prior(i, tilt);
            }
        }
        if !at_rest {
            for j in 0..3 {
                if let Some(i) = layout.keyframe(0, VEL + j) {
                    normal.add_prior(i, LOOSE_SIGMA_M);
                }
            }
        }
        if let Some(o) = layout.baro_offset() {
            normal.add_prior(o, LOOSE_SIGMA_M);
        }
    }
}

/// The velocity's σ at rest, m/s.
const REST_VELOCITY_SIGMA_M_S: f64 = 0.01;
/// A prior that only keeps the information invertible (m, or m/s).
const LOOSE_SIGMA_M: f64 = 100.0;
/// The start's tilt when it is not at rest, rad.
const LOOSE_TILT_RAD: f64 = 0.5;
/// Smallest σ of a prior (an ideal sensor's zero would be infinite information).
const MIN_SIGMA: f64 = 1e-6;
