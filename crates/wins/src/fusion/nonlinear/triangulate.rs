//! An AP's position from cone angles measured along a known trajectory (the inertial start).
//!
//! Once a flight leaves a known state (the end of a rest: at rest, level from the static
//! initialization; or the last good state of a lost window), the IMU alone carries the
//! trajectory, with its metric scale, for the few seconds the start needs. Against those array
//! poses every AP is a separate, three-unknown problem: minimize the Cauchy-robust sum of the
//! cone residuals `r = ŷ_a · unit(R_waᵀ (c − p_a)) − sin θ` (the cone factor's model,
//! [`crate::fusion::nonlinear::factors::cone`]) over `c`. That cost is not convex (the range along the bearings is
//! weakly constrained, a linear array cannot tell the AP's mirror images apart), so it is searched
//! on a grid of directions and log-spaced ranges around the trajectory; the best candidates are
//! refined by Gauss–Newton with the Cauchy weights over the grid's subsample of the sights (at
//! most 120, evenly spaced), and the best of those over every sight; the lowest cost
//! wins. The joint window then refines the trajectory, biases and APs together.

use std::collections::VecDeque;

use nalgebra::{Isometry3, Matrix3, Rotation3, Vector3};

use crate::aoa::steering::sin_aoa;
use crate::fusion::bearing::Bearing;
use crate::fusion::nonlinear::factors::cone::cauchy;
use crate::fusion::nonlinear::factors::cone::sin_sigma;
use crate::fusion::nonlinear::solve::shares::measured_variance_ratio;
use crate::fusion::nonlinear::state::PoseAt;

/// One cone angle seen from a known array pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight {
    /// The array centre in `w`, m.
    pub p_a_in_w: Vector3<f64>,
    /// The array's attitude in `w`.
    pub world_from_array: Rotation3<f64>,
    /// The measured sin θ.
    pub sin_measured: f64,
    /// σ of the sin residual ([`crate::fusion::nonlinear::factors::cone::sin_sigma`]).
    pub sigma: f64,
}

impl Sight {
    /// The bearing `b` seen from the body pose `pose` with the array at `body_from_array`.
    pub fn of(pose: &PoseAt, body_from_array: &Isometry3<f64>, b: &Bearing) -> Self {
        Self {
            p_a_in_w: pose.p_b_in_w + pose.world_from_body * body_from_array.translation.vector,
            world_from_array: (pose.world_from_body * body_from_array.rotation)
                .to_rotation_matrix(),
            sin_measured: b.aoa_rad.sin(),
            sigma: sin_sigma(b.aoa_rad, b.sigma_rad),
        }
    }

    /// The residual `ŷ_a · unit(d_a) − sin θ` for an AP at `c`, and `∂r/∂c`; `None` at the
    /// array centre.
    pub(in crate::fusion::nonlinear) fn residual(
        &self,
        c: &Vector3<f64>,
    ) -> Option<(f64, Vector3<f64>)> {
        let d_a = self
            .world_from_array
            .inverse_transform_vector(&(c - self.p_a_in_w));
        let n = d_a.norm();
        if n < 1e-9 {
            return None;
        }
        let s = sin_aoa(&d_a);
        let ds_dd = (Vector3::y() - d_a * (s / n)) / n;
        Some((s - self.sin_measured, self.world_from_array * ds_dd))
    }
}

/// The sights of one AP not placed yet.
#[derive(Clone, Debug, Default)]
pub(in crate::fusion::nonlinear) struct LateSights {
    /// The newest ones (at most `late_ap::MAX_SIGHTS`).
    pub(in crate::fusion::nonlinear) sights: VecDeque<Sight>,
    /// Sights kept since the AP was first seen (the cadence of the attempts from them alone,
    /// also once the oldest leave).
    pub(in crate::fusion::nonlinear) seen: usize,
    /// Solves since the window met the AP (the cadence of the attempts with the window's).
    pub(in crate::fusion::nonlinear) solves: usize,
}

/// The solution for one AP.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangulated {
    /// The AP in `w`, m.
    pub c_in_w: Vector3<f64>,
    /// Its covariance from the Cauchy-weighted information, m².
    pub covariance: Matrix3<f64>,
    /// The robust cost at the solution.
    pub cost: f64,
}

/// Ranges of the grid search, m (log-spaced).
const RANGES_M: [f64; 10] = [0.7, 1.1, 1.6, 2.4, 3.5, 5.0, 7.5, 11.0, 17.0, 26.0];
/// Directions of the grid search (a Fibonacci sphere).
const DIRECTIONS: usize = 160;
/// At most this many sights score the grid (evenly spaced over the run).
const GRID_SIGHTS: usize = 120;
/// Grid candidates refined over the subsample of the sights.
const REFINED: usize = 6;
/// Of those, the ones with the lowest subsampled cost refined over every sight.
const REFINED_FULLY: usize = 2;
/// Gauss–Newton iterations per refinement.
const ITERATIONS: usize = 30;

/// The robust cost of `c` over `sights` (skipping every `stride`-th).
fn cost(sights: &[Sight], stride: usize, c: &Vector3<f64>, cauchy_scale: f64) -> f64 {
    sights
        .iter()
        .step_by(stride.max(1))
        .map(|s| match s.residual(c) {
            Some((r, _)) => cauchy((r / s.sigma).powi(2), cauchy_scale).0,
            None => f64::INFINITY,
        })
        .sum()
}

/// Gauss–Newton with Cauchy weights (IRLS) and step halving from `c` over every `stride`-th
/// sight: the solution, its information and cost (over those sights).
fn refine(
    sights: &[Sight],
    stride: usize,
    c: Vector3<f64>,
    cauchy_scale: f64,
) -> Option<Triangulated> {
    let mut c = c;
    let mut f = cost(sights, stride, &c, cauchy_scale);
    let mut info = Matrix3::zeros();
    for _ in 0..ITERATIONS {
        info = Matrix3::zeros();
        let mut g = Vector3::zeros();
        for s in sights.iter().step_by(stride.max(1)) {
            let (r, j) = s.residual(&c)?;
            let e2 = (r / s.sigma).powi(2);
            let w = cauchy(e2, cauchy_scale).1 / (s.sigma * s.sigma);
            info += j * j.transpose() * w;
            g += j * (w * r);
        }
        let Some(step) = (info + Matrix3::identity() * 1e-9).cholesky() else {
            break;
        };
        let dc = -step.solve(&g);
        let mut accepted = false;
        let mut scale = 1.0;
        for _ in 0..8 {
            let next = c + dc * scale;
            let fn_ = cost(sights, stride, &next, cauchy_scale);
            if fn_ < f {
                c = next;
                f = fn_;
                accepted = true;
                break;
            }
            scale *= 0.5;
        }
        if !accepted || dc.norm() * scale < 1e-5 {
            break;
        }
    }
    let covariance = info.try_inverse()?;
    Some(Triangulated {
        c_in_w: c,
        covariance,
        cost: f,
    })
}

/// Residuals beyond this many σ are clipped before their persistence is measured: an outlier is
/// one packet's and would otherwise dominate the autocorrelation.
const PERSISTENCE_CLIP_SIGMAS: f64 = 3.0;

impl Triangulated {
    /// The same solution with its covariance widened by the long-run variance ratio of the
    /// sights' own residuals at it, in their order
    /// ([`crate::fusion::nonlinear::solve::shares::measured_variance_ratio`]): the covariance of
    /// [`triangulate`] counts every sight as independent, while a reflection repeats much the
    /// same error for a second of packets (docs/ESTIMATOR.md, "The bearings' errors persist from
    /// packet to packet"). A wrong solution leaves smooth residuals and is widened the most.
    /// Returns the ratio too.
    pub fn counting_persistence(self, sights: &[Sight]) -> (Self, f64) {
        let series: Vec<f64> = sights
            .iter()
            .filter_map(|s| {
                let (r, _) = s.residual(&self.c_in_w)?;
                Some((r / s.sigma).clamp(-PERSISTENCE_CLIP_SIGMAS, PERSISTENCE_CLIP_SIGMAS))
            })
            .collect();
        let ratio = measured_variance_ratio(&series);
        let widened = Self {
            covariance: self.covariance * ratio,
            ..self
        };
        (widened, ratio)
    }
}

/// The AP seen by `sights` (module doc); `None` with fewer than 6 sights or no finite solution.
pub fn triangulate(sights: &[Sight], cauchy_scale: f64) -> Option<Triangulated> {
    if sights.len() < 6 {
        return None;
    }
    let centre = sights.iter().map(|s| s.p_a_in_w).sum::<Vector3<f64>>() / sights.len() as f64;
    let stride = sights.len().div_ceil(GRID_SIGHTS);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut scored: Vec<(f64, Vector3<f64>)> = Vec::with_capacity(DIRECTIONS * RANGES_M.len());
    for i in 0..DIRECTIONS {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / DIRECTIONS as f64;
        let rho = (1.0 - z * z).sqrt();
        let (sin, cos) = (golden * i as f64).sin_cos();
        let u = Vector3::new(rho * cos, rho * sin, z);
        for r in RANGES_M {
            let c = centre + u * r;
            scored.push((cost(sights, stride, &c, cauchy_scale), c));
        }
    }
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts: Vec<Vector3<f64>> = Vec::with_capacity(REFINED);
    for (_, c) in scored {
        // Distinct basins: skip a candidate near one already taken.
        if starts
            .iter()
            .all(|s| (s - c).norm() > 0.2 * (s - centre).norm())
        {
            starts.push(c);
        }
        if starts.len() == REFINED {
            break;
        }
    }
    let finite = |t: &Triangulated| t.c_in_w.iter().all(|v| v.is_finite()) && t.cost.is_finite();
    let mut coarse: Vec<Triangulated> = starts
        .into_iter()
        .filter_map(|c| refine(sights, stride, c, cauchy_scale))
        .filter(finite)
        .collect();
    coarse.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    coarse
        .into_iter()
        .take(REFINED_FULLY)
        .filter_map(|t| refine(sights, 1, t.c_in_w, cauchy_scale))
        .filter(finite)
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, StandardNormal};

    fn sight(p: Vector3<f64>, yaw: f64, c: &Vector3<f64>, noise: f64) -> Sight {
        let world_from_array = Rotation3::from_euler_angles(0.0, 0.0, yaw);
        let d_a = world_from_array.inverse_transform_vector(&(c - p));
        let theta = sin_aoa(&d_a).asin() + noise;
        Sight {
            p_a_in_w: p,
            world_from_array,
            sin_measured: theta.sin(),
            sigma: theta.cos().max(0.2) * 2f64.to_radians(),
        }
    }

    /// The array's position and yaw `t` s into a climb (4 s) then an arc, the yaw swinging.
    fn climb_and_arc(t: f64) -> (Vector3<f64>, f64) {
        let p = if t < 4.0 {
            Vector3::new(0.0, 0.0, 0.1 + 0.35 * t)
        } else {
            let a = 0.3 * (t - 4.0);
            Vector3::new(1.0 - a.cos(), a.sin(), 1.5)
        };
        (p, 2.2 + 0.5 * (t * 1.2).sin())
    }

    #[test]
    fn the_residual_jacobian_matches_finite_differences() {
        let s = sight(
            Vector3::new(0.3, -0.2, 1.0),
            0.4,
            &Vector3::new(4.0, 1.0, 2.0),
            0.0,
        );
        let c = Vector3::new(3.0, 2.0, 1.5);
        let (r, j) = s.residual(&c).unwrap();
        let h = 1e-6;
        for i in 0..3 {
            let mut d = Vector3::zeros();
            d[i] = h;
            let fd = (s.residual(&(c + d)).unwrap().0 - r) / h;
            assert!((fd - j[i]).abs() < 1e-6, "{i}: {fd} vs {}", j[i]);
        }
    }

    /// A climb then an arc with the yaw swinging, as a take-off and the first metres of a
    /// mission: the AP comes back from the grid search to within the bearings' noise, a tenth of
    /// its 5 m range, and the outliers (every tenth bearing 40° off) do not drag it.
    #[test]
    fn an_ap_is_found_from_bearings_along_a_climb_and_an_arc() {
        let mut rng = crate::sim::rng::stream(7, "triangulate");
        let c = Vector3::new(-3.0, 4.0, 2.2);
        let mut sights = Vec::new();
        for i in 0..400 {
            let t = i as f64 * 0.02;
            let (p, yaw) = climb_and_arc(t);
            let outlier = if i % 10 == 3 { 0.7 } else { 0.0 };
            sights.push(sight(
                p,
                yaw,
                &c,
                {
                    let n: f64 = StandardNormal.sample(&mut rng);
                    n
                } * 2f64.to_radians()
                    + outlier,
            ));
        }
        let t = triangulate(&sights, 2.0).unwrap();
        let err = (t.c_in_w - c).norm();
        assert!(err < 0.5, "AP off by {err} m at {:?}", t.c_in_w);
        let sigma = t.covariance.symmetric_eigenvalues().max().sqrt();
        assert!(
            err < 4.0 * sigma + 0.05,
            "error {err} m against σ {sigma} m"
        );
    }

    /// The climb and arc of the test above with an error that persists over 0.3 s (a
    /// Gauss–Markov process, as a reflection gives) and with a white one of the same size, over
    /// 40 seeds: counted as independent, the persistent ones claim an AP several times more
    /// certain than it is (the horizontal NEES far above its honest 2); counted with their
    /// measured persistence it comes back near 2 (the test fails without the widening), and the
    /// white ones are hardly widened.
    #[test]
    fn persistent_bearing_errors_widen_the_aps_covariance_to_an_honest_one() {
        let c = Vector3::new(-3.0, 4.0, 2.2);
        let (rate_hz, tau_s): (f64, f64) = (50.0, 0.3);
        let rho = (-1.0 / (rate_hz * tau_s)).exp();
        let innovation = (1.0 - rho * rho).sqrt();
        let horizontal_nees = |t: &Triangulated| {
            let d = (t.c_in_w - c).fixed_rows::<2>(0).into_owned();
            let cov = t.covariance.fixed_view::<2, 2>(0, 0).into_owned();
            (d.transpose() * cov.try_inverse().unwrap_or_default() * d)[(0, 0)]
        };
        let (mut counted, mut widened, mut white_ratio) = (0.0, 0.0, 0.0);
        let seeds = 40;
        for seed in 0..seeds {
            let mut rng = crate::sim::rng::stream(seed, "persistent sights");
            let mut e: f64 = StandardNormal.sample(&mut rng);
            let (mut persistent, mut white) = (Vec::new(), Vec::new());
            for i in 0..400 {
                let t = i as f64 / rate_hz;
                let (p, yaw) = climb_and_arc(t);
                let n: f64 = StandardNormal.sample(&mut rng);
                e = rho * e + innovation * n;
                let w: f64 = StandardNormal.sample(&mut rng);
                persistent.push(sight(p, yaw, &c, e * 2f64.to_radians()));
                white.push(sight(p, yaw, &c, w * 2f64.to_radians()));
            }
            let t = triangulate(&persistent, 2.0).unwrap();
            counted += horizontal_nees(&t);
            widened += horizontal_nees(&t.counting_persistence(&persistent).0);
            white_ratio += triangulate(&white, 2.0)
                .unwrap()
                .counting_persistence(&white)
                .1;
        }
        let n = seeds as f64;
        let (counted, widened, white_ratio) = (counted / n, widened / n, white_ratio / n);
        assert!(counted > 10.0, "counted as independent: NEES {counted}");
        assert!((0.7..5.0).contains(&widened), "widened: NEES {widened}");
        assert!(
            white_ratio < 1.5,
            "white errors widened {white_ratio} times"
        );
    }

    #[test]
    fn too_few_sights_give_none() {
        let c = Vector3::new(3.0, 0.0, 1.0);
        let sights: Vec<_> = (0..5)
            .map(|i| sight(Vector3::new(0.0, i as f64 * 0.1, 1.0), 0.0, &c, 0.0))
            .collect();
        assert!(triangulate(&sights, 2.0).is_none());
    }
}
