//! What the user of a long flight watches: the position error in the last minute (under the
//! global alignment, and under an alignment fixed on the first minute only), the heading error's
//! drift rate and the jumps of the estimated position. The definitions are on the fields of
//! [`super::Metrics`]. The evaluation computes them in passes ([`super::stream`]) with this
//! file's steps; the whole-trajectory formulas here are the reference it is checked against.

use nalgebra::UnitQuaternion;

#[cfg(test)]
use super::{AlignMode, Alignment, align_poses};
#[cfg(test)]
use crate::dataset::truth::Pose;
#[cfg(test)]
use crate::time::{NANOS_PER_SEC, Timestamp};

/// Length of the first and last windows of the drift metrics, s: a minute, the time scale on
/// which a flight controller notices drift.
pub const DRIFT_WINDOW_S: f64 = 60.0;

/// Two consecutive estimated poses farther apart than this are a jump, m. At 50 estimated poses
/// per second it is a speed of 15 m/s, far above a small drone's; an estimate written at a rate
/// `f` counts honest motion faster than `0.3·f` m/s as jumps.
pub const JUMP_THRESHOLD_M: f64 = 0.3;

/// Seconds per minute (the heading drift is reported per minute).
pub(crate) const SECONDS_PER_MINUTE: f64 = 60.0;

#[cfg(test)]
/// The drift numbers of one evaluation (the fields of the same names in [`super::Metrics`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Drift {
    /// RMSE of the globally aligned `‖e_i‖` over the last [`DRIFT_WINDOW_S`], m.
    pub(crate) position_error_last_60s_rmse_m: f64,
    /// RMSE over the last window of `‖e_i‖` under the alignment of the first window, m.
    pub(crate) drift_last_60s_m: Option<f64>,
    /// Slope of the unwrapped heading error against time, deg/min.
    pub(crate) heading_drift_deg_per_min: f64,
    /// Consecutive estimated poses more than [`JUMP_THRESHOLD_M`] apart.
    pub(crate) jumps: usize,
}

#[cfg(test)]
/// The drift numbers of `est` against `truth`: `pairs` are the associated `(estimate, truth)`
/// indices in time order, `alignment` the global one and `error_norms_m[k]` the globally aligned
/// `‖e_k‖` of `pairs[k]`.
pub(crate) fn drift_metrics(
    est: &[Pose],
    truth: &[Pose],
    pairs: &[(usize, usize)],
    alignment: &Alignment,
    error_norms_m: &[f64],
    mode: AlignMode,
) -> Drift {
    let window_ns = (DRIFT_WINDOW_S * NANOS_PER_SEC as f64).round() as i64;
    let times: Vec<Timestamp> = pairs.iter().map(|&(i, _)| est[i].t).collect();
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else {
        return Drift {
            position_error_last_60s_rmse_m: 0.0,
            drift_last_60s_m: None,
            heading_drift_deg_per_min: 0.0,
            jumps: count_jumps(est),
        };
    };
    let in_last: Vec<bool> = times.iter().map(|t| t.0 >= last.0 - window_ns).collect();
    let last_norms = error_norms_m
        .iter()
        .zip(&in_last)
        .filter(|&(_, &keep)| keep)
        .map(|(e, _)| *e);
    let drift_last_60s_m =
        if last.0 - first.0 < 2 * window_ns {
            None
        } else {
            let (est_p, truth_p): (Vec<_>, Vec<_>) = pairs
                .iter()
                .zip(&times)
                .filter(|&(_, t)| t.0 <= first.0 + window_ns)
                .map(|(&(i, j), _)| (&est[i], &truth[j]))
                .unzip();
            // A first minute that cannot fix an alignment (its positions on one line or still, and
            // its attitudes in disagreement) has no drift.
            align_poses(&est_p, &truth_p, mode)
                .ok()
                .map(|first_minute| {
                    rms(pairs.iter().zip(&in_last).filter(|&(_, &keep)| keep).map(
                        |(&(i, j), _)| {
                            (first_minute.apply_point(&est[i].p_b_in_w) - truth[j].p_b_in_w).norm()
                        },
                    ))
                })
        };
    let heading_rad: Vec<f64> = pairs
        .iter()
        .map(|&(i, j)| {
            let aligned = alignment.apply_pose(&est[i]);
            heading_error_rad(&truth[j].world_from_body, &aligned.world_from_body)
        })
        .collect();
    let t_s: Vec<f64> = times.iter().map(|t| t.secs_since(first)).collect();
    let slope_rad_s = least_squares_slope(&t_s, &unwrap_rad(&heading_rad));
    Drift {
        position_error_last_60s_rmse_m: rms(last_norms),
        drift_last_60s_m,
        heading_drift_deg_per_min: slope_rad_s.to_degrees() * SECONDS_PER_MINUTE,
        jumps: count_jumps(est),
    }
}

/// Heading error of one pose, rad in (−π, π]: the yaw about the world's z (vertical) axis of the
/// error rotation `R_err = R_aligned · R_truthᵀ`, `atan2(R_err[1,0], R_err[0,0])`, with
/// `R_aligned = R_align · R_est` and `R_truth` the `world_from_body` rotations in the truth
/// world. `R_err` takes the true attitude onto the estimated one and is expressed in the world:
/// an estimate turned by `δ` about the vertical has a heading error of `+δ` (counter-clockwise
/// seen from above), whatever its roll and pitch and whatever world-frame tilt error it has.
pub(crate) fn heading_error_rad(
    truth_world_from_body: &UnitQuaternion<f64>,
    aligned_world_from_body: &UnitQuaternion<f64>,
) -> f64 {
    let r_err = (aligned_world_from_body * truth_world_from_body.inverse()).to_rotation_matrix();
    let m = r_err.matrix();
    m[(1, 0)].atan2(m[(0, 0)])
}

#[cfg(test)]
/// Angles with every step between neighbours brought into [−π, π), rad (as numpy's `unwrap`):
/// the first angle is kept, each next one is its predecessor plus the wrapped difference.
pub(crate) fn unwrap_rad(angles_rad: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(angles_rad.len());
    let mut previous: Option<(f64, f64)> = None; // (raw, unwrapped)
    for &a in angles_rad {
        out.push(unwrap_step(&mut previous, a));
    }
    out
}

/// One step of [`unwrap_rad`]: `a` unwrapped after `previous` (raw, unwrapped), which becomes
/// `a`'s.
pub(crate) fn unwrap_step(previous: &mut Option<(f64, f64)>, a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let unwrapped = match *previous {
        Some((raw, u)) => u + ((a - raw + PI).rem_euclid(TAU) - PI),
        None => a,
    };
    *previous = Some((a, unwrapped));
    unwrapped
}

#[cfg(test)]
/// Least-squares slope `Σ(t − t̄)(y − ȳ) / Σ(t − t̄)²` of `y` against `t` (0 for fewer than two
/// points or a single time).
pub(crate) fn least_squares_slope(t: &[f64], y: &[f64]) -> f64 {
    let n = t.len().min(y.len());
    if n < 2 {
        return 0.0;
    }
    let (t, y) = (&t[..n], &y[..n]);
    let t_mean = t.iter().sum::<f64>() / n as f64;
    let y_mean = y.iter().sum::<f64>() / n as f64;
    let (num, den) = t.iter().zip(y).fold((0.0, 0.0), |(num, den), (ti, yi)| {
        let dt = ti - t_mean;
        (num + dt * (yi - y_mean), den + dt * dt)
    });
    if den > 0.0 { num / den } else { 0.0 }
}

#[cfg(test)]
/// Consecutive poses of `est` (in the order given) whose positions are more than
/// [`JUMP_THRESHOLD_M`] apart.
pub(crate) fn count_jumps(est: &[Pose]) -> usize {
    est.windows(2)
        .filter(|w| (w[1].p_b_in_w - w[0].p_b_in_w).norm() > JUMP_THRESHOLD_M)
        .count()
}

#[cfg(test)]
/// `√(Σ x²/n)` (0 for none).
fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum_sq, n) = values.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        0.0
    } else {
        (sum_sq / n as f64).sqrt()
    }
}

#[cfg(test)]
mod tests;
