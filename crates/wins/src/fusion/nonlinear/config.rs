//! Settings of the nonlinear estimator (the `[nonlinear]` table of a configuration).

use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use crate::check::Problems;
use crate::imu::ImuGap;
use crate::rig::ImuNoise;

/// Settings of the nonlinear window and its start (the `[nonlinear]` table).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NonlinearConfig {
    /// A new keyframe when this long has passed since the last one, s. Bearings and barometer
    /// samples in between are tied to the keyframe before them.
    pub keyframe_period_s: f64,
    /// Keyframes in the window; older ones are marginalized into the prior.
    pub max_keyframes: usize,
    /// Solver iterations per keyframe once converged.
    pub iterations: usize,
    /// Iterations over the whole start window when the linear solution is refined.
    pub iterations_at_start: usize,
    /// Scale of the Cauchy loss on the AoA factors, in units of the bearing's σ.
    pub cauchy_scale: f64,
    /// The bearings' errors persist over this correlation time, s (a first-order Gauss–Markov
    /// error per AP): an AP's bearings at λ per second each carry `1 / coth(1/(2λτ))` of an
    /// independent one's information ([`super::solve::shares`]) once tracking; the start's window
    /// weighs them as independent (its acceptance bounds were set so). 0 (the default):
    /// independent everywhere (measured: on drawn room flights the tracked covariance became
    /// honest on the runs that work, but fewer runs stayed within 2 m).
    pub bearing_correlation_s: f64,
    /// Barometer white noise 1σ, m.
    pub baro_sigma_m: f64,
    /// Barometer offset random walk, m/√s (the drift of a still room's pressure).
    pub baro_offset_walk_m_sqrt_s: f64,
    /// Prior σ of a common offset β of every bearing's `sin θ`, estimated with the trajectory:
    /// what an error `Δφ` in the receive chains' uniform phase step does (`β = Δφ·λ/(2πd)`;
    /// 0.03 is 5.4° of phase at half-wavelength spacing). 0 (the default): not estimated with a
    /// calibration (measured: the extra freedom doubled the median error of calibrated flights);
    /// without one the chain resolution estimates it with a σ of half its hypotheses' spacing
    /// ([`crate::pipeline::chains`]).
    pub sin_bias_sigma: f64,
    /// Significance of the χ² tests (start acceptance and loss): a correct solution fails with
    /// this probability.
    pub chi2_significance: f64,
    /// A start is accepted only when every AP's largest horizontal marginal σ is below this, m
    /// (its height is weakly seen when it is near the array's: see
    /// [`super::NonlinearWindow::ap_horizontal_sigma_m`]).
    pub max_ap_sigma_m: f64,
    /// … and below this fraction of its smallest range from the start's keyframes (a wrong scale
    /// puts the AP close, where its bearings pin it: a linearized σ alone then looks fine).
    pub max_ap_sigma_fraction: f64,
    /// At rest, for the static start and the stillness of the zero-velocity updates alike
    /// ([`crate::fusion::nonlinear::start::rest::means_at_rest`]): the gyro's 0.1 s mean norm below this
    /// beyond what its turn-on bias may add, rad/s …
    pub rest_max_gyro_rad_s: f64,
    /// … and the 0.1 s mean specific force's norm within this of gravity beyond the same, m/s².
    pub rest_max_accel_deviation_m_s2: f64,
    /// At least this long at rest (the means alone, up to [`crate::fusion::nonlinear::start::rest::ONSET_MARGIN_S`] before
    /// the first motion) gives a static initialization, s.
    pub rest_min_s: f64,
    /// Zero-velocity updates: a keyframe while the IMU is still (on the ground) holds its
    /// velocity at zero ([`crate::fusion::nonlinear::start::still`], [`crate::fusion::nonlinear::factors::zero_velocity`]).
    pub zero_velocity: bool,
    /// 1σ of that zero velocity, per axis, m/s.
    pub zero_velocity_sigma_m_s: f64,
    /// The IMU still ([`crate::fusion::nonlinear::start::still`]: at rest, and its samples' scatter and means steady) for
    /// at least this long before the keyframe, s.
    pub zero_velocity_min_still_s: f64,
    /// … and the window's predicted speed at the keyframe below this, m/s (a last bound: an IMU
    /// reads the same at rest and at a constant velocity).
    pub zero_velocity_max_speed_m_s: f64,
    /// Still: each axis's sample scatter over 0.1 s at most this many times the sensor's white
    /// noise per sample (rotor vibration is far above it).
    pub still_max_noise_ratio: f64,
    /// Motion (after a rest, or from the start) for at least this long before the first start
    /// attempt, s.
    pub start_after_motion_s: f64,
    /// Time between start attempts, s, at least.
    pub start_retry_s: f64,
    /// … and at least this share of the start window's span: an attempt costs in proportion to
    /// the window, and a long window gains little from one more second, so a start that keeps
    /// failing spends a bounded share of the flight's time on its attempts.
    pub start_retry_share: f64,
    /// The inertial start (the IMU's dead reckoning from the rest or the last good state, the APs
    /// triangulated against it) is tried up to this long after that state, s; then only the
    /// linear window's proposal.
    pub inertial_start_max_s: f64,
    /// The start window keeps at most this many seconds of keyframes.
    pub max_start_window_s: f64,
    /// The loss test runs over the bearings of this many seconds.
    pub loss_window_s: f64,
    /// The longest the pose is carried by the IMU alone after the newest keyframe (a CSI
    /// outage), s; past it the window ends and restarts at the next bearings, placed by its APs
    /// (docs/CONFIG.md `[imu_gap]`).
    pub max_dead_reckoning_s: f64,
    /// Measure the IMU's white noise from its samples and integrate with the larger of it and
    /// the dataset's densities ([`crate::imu::noise_meter`]); off: the dataset's densities only.
    pub imu_noise_from_data: bool,
    /// The measured noise follows the samples with this time constant, s.
    pub imu_noise_time_constant_s: f64,
    /// Triangulate an AP the start left out from the bearings of the keyframes in the window
    /// too, every few solves, not only from those that have left it
    /// (docs/ESTIMATOR.md, "APs placed from the window's own bearings"; on by default; off: the
    /// latter alone, 25 at a time).
    pub late_aps_from_window: bool,
}

impl Default for NonlinearConfig {
    fn default() -> Self {
        Self {
            keyframe_period_s: 0.1,
            max_keyframes: 20,
            iterations: 2,
            iterations_at_start: 15,
            cauchy_scale: 2.0,
            bearing_correlation_s: 0.0,
            baro_sigma_m: 0.3,
            baro_offset_walk_m_sqrt_s: 0.04,
            sin_bias_sigma: 0.0,
            chi2_significance: 1e-3,
            max_ap_sigma_m: 1.0,
            max_ap_sigma_fraction: 0.2,
            rest_max_gyro_rad_s: 0.05,
            rest_max_accel_deviation_m_s2: 0.3,
            rest_min_s: 1.0,
            zero_velocity: true,
            zero_velocity_sigma_m_s: 0.02,
            zero_velocity_min_still_s: 0.5,
            zero_velocity_max_speed_m_s: 0.5,
            still_max_noise_ratio: 3.0,
            start_after_motion_s: 4.0,
            start_retry_s: 1.0,
            start_retry_share: 0.1,
            inertial_start_max_s: 25.0,
            max_start_window_s: 30.0,
            loss_window_s: 2.0,
            max_dead_reckoning_s: 10.0,
            imu_noise_from_data: true,
            imu_noise_time_constant_s: 1.0,
            late_aps_from_window: true,
        }
    }
}

impl NonlinearConfig {
    /// Whether an AP's horizontal σ passes the start's bounds at its smallest `range_m` from the
    /// keyframes ([`Self::max_ap_sigma_m`], [`Self::max_ap_sigma_fraction`]).
    pub fn ap_sigma_ok(&self, sigma_m: f64, range_m: f64) -> bool {
        sigma_m < self.max_ap_sigma_m && sigma_m < self.max_ap_sigma_fraction * range_m
    }

    /// Every setting in its range, under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.in_range(
            prefix,
            "keyframe_period_s",
            self.keyframe_period_s,
            0.0,
            2.0,
        );
        p.require(
            (3..=500).contains(&self.max_keyframes),
            prefix,
            "max_keyframes",
            format!("{} is not in [3, 500]", self.max_keyframes),
        );
        p.require(
            (1..=50).contains(&self.iterations),
            prefix,
            "iterations",
            format!("{} is not in [1, 50]", self.iterations),
        );
        p.require(
            (1..=200).contains(&self.iterations_at_start),
            prefix,
            "iterations_at_start",
            format!("{} is not in [1, 200]", self.iterations_at_start),
        );
        p.in_range(prefix, "cauchy_scale", self.cauchy_scale, 0.1, 100.0);
        p.in_range(
            prefix,
            "bearing_correlation_s",
            self.bearing_correlation_s,
            0.0,
            60.0,
        );
        p.in_range(prefix, "baro_sigma_m", self.baro_sigma_m, 1e-3, 100.0);
        p.in_range(prefix, "sin_bias_sigma", self.sin_bias_sigma, 0.0, 2.0);
        p.in_range(
            prefix,
            "baro_offset_walk_m_sqrt_s",
            self.baro_offset_walk_m_sqrt_s,
            0.0,
            10.0,
        );
        p.in_range(
            prefix,
            "chi2_significance",
            self.chi2_significance,
            1e-9,
            0.5,
        );
        p.in_range(prefix, "max_ap_sigma_m", self.max_ap_sigma_m, 1e-3, 100.0);
        p.in_range(
            prefix,
            "max_ap_sigma_fraction",
            self.max_ap_sigma_fraction,
            1e-3,
            1.0,
        );
        p.in_range(
            prefix,
            "rest_max_gyro_rad_s",
            self.rest_max_gyro_rad_s,
            1e-4,
            1.0,
        );
        p.in_range(
            prefix,
            "rest_max_accel_deviation_m_s2",
            self.rest_max_accel_deviation_m_s2,
            1e-3,
            5.0,
        );
        p.in_range(prefix, "rest_min_s", self.rest_min_s, 0.05, 60.0);
        p.in_range(
            prefix,
            "zero_velocity_sigma_m_s",
            self.zero_velocity_sigma_m_s,
            1e-4,
            10.0,
        );
        p.in_range(
            prefix,
            "zero_velocity_min_still_s",
            self.zero_velocity_min_still_s,
            0.1,
            60.0,
        );
        p.in_range(
            prefix,
            "zero_velocity_max_speed_m_s",
            self.zero_velocity_max_speed_m_s,
            0.0,
            10.0,
        );
        p.in_range(
            prefix,
            "still_max_noise_ratio",
            self.still_max_noise_ratio,
            1.0,
            100.0,
        );
        p.in_range(
            prefix,
            "start_after_motion_s",
            self.start_after_motion_s,
            0.0,
            600.0,
        );
        p.in_range(prefix, "start_retry_s", self.start_retry_s, 0.05, 600.0);
        p.in_range(
            prefix,
            "start_retry_share",
            self.start_retry_share,
            0.0,
            1.0,
        );
        p.in_range(
            prefix,
            "imu_noise_time_constant_s",
            self.imu_noise_time_constant_s,
            0.1,
            600.0,
        );
        p.in_range(
            prefix,
            "inertial_start_max_s",
            self.inertial_start_max_s,
            0.0,
            600.0,
        );
        p.in_range(
            prefix,
            "max_start_window_s",
            self.max_start_window_s,
            1.0,
            600.0,
        );
        p.in_range(prefix, "loss_window_s", self.loss_window_s, 0.1, 60.0);
        p.in_range(
            prefix,
            "max_dead_reckoning_s",
            self.max_dead_reckoning_s,
            0.1,
            600.0,
        );
        p
    }
}

/// What the estimator knows of its sensors (from the rig).
#[derive(Clone, Debug, PartialEq)]
pub struct Sensors {
    /// IMU noise densities.
    pub imu_noise: ImuNoise,
    /// How a gap in the IMU stream is integrated.
    pub imu_gap: ImuGap,
    /// The antenna array's mounting.
    pub body_from_array: Isometry3<f64>,
}
