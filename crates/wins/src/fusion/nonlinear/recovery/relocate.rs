//! The start after a hole: the AP a lost window had placed, and the velocity and tilt the IMU
//! carried across the hole, found together from the bearings after it.
//!
//! After an IMU gap the carried state is a guess: its heading can be tens of degrees off (the
//! IMU's straight line across a turn), which turns the velocity the dead reckoning leaves with
//! against the body by as much, and its roll and pitch a degree or two, which adds a constant
//! acceleration `g δθ` to the dead reckoning. Both grow into metres within the seconds a start
//! needs, so the APs no longer triangulate against it ([`crate::fusion::nonlinear::triangulate`]). The dead
//! reckoning is linear in the initial velocity and, to first order, in a world-frame tilt error:
//! the array's true positions are `p_a(t) + δv t + ½ δa t²` (`t` since the hole's first frame,
//! `δa` horizontal). So the AP's position `c`, `δv` and `δa` are solved together, minimizing
//! the Cauchy-robust cone residuals `r = ŷ_a · unit(R_waᵀ (c − p_a − δv t − ½ δa t²)) − sin θ`
//! with weak priors on `δv` and `δa`, by Gauss–Newton from seeds: the AP where the lost window
//! had it, seen from where the IMU carried the drone (its range and height known, its bearing
//! not: the heading is what the hole lost), turned about the drone on a grid, times the carried
//! velocity turned on a grid.

use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector2, Vector3};

use crate::fusion::nonlinear::factors::cone::cauchy;
use crate::fusion::nonlinear::triangulate::Sight;

/// One sight and its time since the hole's first frame, s.
#[derive(Clone, Copy, Debug)]
pub(in crate::fusion::nonlinear) struct TimedSight {
    pub(in crate::fusion::nonlinear) sight: Sight,
    pub(in crate::fusion::nonlinear) t_s: f64,
}

/// What the lost window knew of the AP, seen from where the IMU carried the drone: its
/// horizontal range and height above the drone (the bearing is what the hole lost).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::fusion::nonlinear) struct ApFromDrone {
    /// The drone at the hole's first frame, m.
    pub(in crate::fusion::nonlinear) drone: Vector3<f64>,
    /// The AP from there, were the carried heading right, m.
    pub(in crate::fusion::nonlinear) offset: Vector3<f64>,
    /// 1σ of the range and of the height, m.
    pub(in crate::fusion::nonlinear) sigma_m: f64,
}

impl ApFromDrone {
    /// The residuals of an AP at `c` (range, height; whitened) and their gradients.
    fn residuals(&self, c: &Vector3<f64>) -> [(f64, Vector3<f64>); 2] {
        let d = (c - self.drone).xy();
        let rho = d.norm().max(1e-9);
        let r_range = (rho - self.offset.xy().norm()) / self.sigma_m;
        let j_range = Vector3::new(d.x / rho, d.y / rho, 0.0) / self.sigma_m;
        let r_z = (c.z - self.drone.z - self.offset.z) / self.sigma_m;
        [(r_range, j_range), (r_z, Vector3::z() / self.sigma_m)]
    }

    /// Their information on the AP at `c` (rank 2: range and height), 1/m².
    pub(in crate::fusion::nonlinear) fn information(
        &self,
        c: &Vector3<f64>,
    ) -> nalgebra::Matrix3<f64> {
        self.residuals(c)
            .iter()
            .map(|(_, j)| j * j.transpose())
            .sum()
    }
}

/// The joint solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::fusion::nonlinear) struct Relocated {
    /// The AP, in the dead reckoning's frame, m.
    pub(in crate::fusion::nonlinear) c: Vector3<f64>,
    /// The velocity correction at the hole's first frame, m/s.
    pub(in crate::fusion::nonlinear) dv: Vector3<f64>,
    /// The horizontal acceleration correction (tilt), m/s².
    pub(in crate::fusion::nonlinear) da: Vector2<f64>,
    /// The robust cost with the priors.
    pub(in crate::fusion::nonlinear) cost: f64,
    /// Horizontal σ of the AP, m (its largest).
    pub(in crate::fusion::nonlinear) ap_sigma_m: f64,
}

impl Relocated {
    /// The position correction at `t_s` after the hole's first frame, m.
    pub(in crate::fusion::nonlinear) fn dp(&self, t_s: f64) -> Vector3<f64> {
        self.dv * t_s + Vector3::new(self.da.x, self.da.y, 0.0) * (0.5 * t_s * t_s)
    }

    /// The velocity correction at `t_s`, m/s.
    pub(in crate::fusion::nonlinear) fn dvel(&self, t_s: f64) -> Vector3<f64> {
        self.dv + Vector3::new(self.da.x, self.da.y, 0.0) * t_s
    }
}

/// 1σ prior of the velocity correction, horizontal, m/s …
const DV_SIGMA_M_S: f64 = 1.5;
/// … and vertical (thrust holds the weight: the straight line errs little up or down; a cone
/// seen near the array's height tells the vertical least).
const DV_Z_SIGMA_M_S: f64 = 0.2;
/// 1σ prior of the acceleration correction, m/s² (a 2° tilt).
const DA_SIGMA_M_S2: f64 = 0.35;
/// Turns of the AP about the carried position tried, degrees step.
const AP_TURN_STEP_DEG: f64 = 15.0;
/// Turns of the carried velocity tried, degrees.
const VELOCITY_TURNS_DEG: [f64; 8] = [0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0];
/// At most this many sights in the seeds' solves (evenly spaced).
const SEED_SIGHTS: usize = 150;
/// Gauss–Newton iterations from a seed, and for the best seeds on every sight.
const SEED_ITERATIONS: usize = 8;
const FINAL_ITERATIONS: usize = 25;
/// Seeds solved again on every sight.
const FINAL_SEEDS: usize = 4;

type Vec8 = SVector<f64, 8>;
type Mat8 = SMatrix<f64, 8, 8>;

fn unpack(x: &Vec8) -> (Vector3<f64>, Vector3<f64>, Vector2<f64>) {
    (
        Vector3::new(x[0], x[1], x[2]),
        Vector3::new(x[3], x[4], x[5]),
        Vector2::new(x[6], x[7]),
    )
}

/// The sight `s` moved by the corrections in `x`.
fn moved(s: &TimedSight, x: &Vec8) -> Sight {
    let (_, dv, da) = unpack(x);
    let t = s.t_s;
    Sight {
        p_a_in_w: s.sight.p_a_in_w + dv * t + Vector3::new(da.x, da.y, 0.0) * (0.5 * t * t),
        ..s.sight
    }
}

/// The residual of `s` at `x` and `∂r/∂x`: `∂r/∂c = J_c` (the sight's), `∂r/∂δv = −J_c t`,
/// `∂r/∂δa = −J_c,xy t²/2` (the array moves by what the AP's offset loses).
fn residual(s: &TimedSight, x: &Vec8) -> Option<(f64, Vec8)> {
    let (c, _, _) = unpack(x);
    let (r, j_c) = moved(s, x).residual(&c)?;
    let t = s.t_s;
    let mut j = Vec8::zeros();
    j.fixed_rows_mut::<3>(0).copy_from(&j_c);
    j.fixed_rows_mut::<3>(3).copy_from(&(-j_c * t));
    j.fixed_rows_mut::<2>(6)
        .copy_from(&(-j_c.xy() * (0.5 * t * t)));
    Some((r, j))
}

fn prior_cost(x: &Vec8, ap: &ApFromDrone) -> f64 {
    let (c, dv, da) = unpack(x);
    let on_ap: f64 = ap.residuals(&c).iter().map(|(r, _)| r * r).sum();
    dv.xy().norm_squared() / DV_SIGMA_M_S.powi(2)
        + (dv.z / DV_Z_SIGMA_M_S).powi(2)
        + da.norm_squared() / DA_SIGMA_M_S2.powi(2)
        + on_ap
}

/// The robust cost of `x` over every `stride`-th sight, with the priors.
fn cost(
    sights: &[TimedSight],
    stride: usize,
    x: &Vec8,
    ap: &ApFromDrone,
    cauchy_scale: f64,
) -> f64 {
    let (c, _, _) = unpack(x);
    let data: f64 = sights
        .iter()
        .step_by(stride.max(1))
        .map(|s| match moved(s, x).residual(&c) {
            Some((r, _)) => cauchy((r / s.sight.sigma).powi(2), cauchy_scale).0,
            None => f64::INFINITY,
        })
        .sum();
    data + prior_cost(x, ap)
}

/// Gauss–Newton with Cauchy weights and step halving from `x`: the solution, its information
/// and cost.
fn solve(
    sights: &[TimedSight],
    stride: usize,
    x: Vec8,
    ap: &ApFromDrone,
    iterations: usize,
    cauchy_scale: f64,
) -> Option<(Vec8, Mat8, f64)> {
    let mut x = x;
    let mut f = cost(sights, stride, &x, ap, cauchy_scale);
    let mut info = Mat8::zeros();
    for _ in 0..=iterations {
        info = Mat8::zeros();
        let mut g = Vec8::zeros();
        let (c, dv, da) = unpack(&x);
        for (r, j) in ap.residuals(&c) {
            let j = j.fixed_resize::<8, 1>(0.0);
            info += j * j.transpose();
            g += j * r;
        }
        for s in sights.iter().step_by(stride.max(1)) {
            let (r, j) = residual(s, &x)?;
            let e2 = (r / s.sight.sigma).powi(2);
            let w = cauchy(e2, cauchy_scale).1 / s.sight.sigma.powi(2);
            info += j * j.transpose() * w;
            g += j * (w * r);
        }
        for (i, sigma) in [(3, DV_SIGMA_M_S), (4, DV_SIGMA_M_S), (5, DV_Z_SIGMA_M_S)] {
            info[(i, i)] += sigma.powi(-2);
            g[i] += dv[i - 3] * sigma.powi(-2);
        }
        for i in 6..8 {
            info[(i, i)] += DA_SIGMA_M_S2.powi(-2);
            g[i] += da[i - 6] * DA_SIGMA_M_S2.powi(-2);
        }
        let Some(chol) = (info + Mat8::identity() * 1e-9).cholesky() else {
            break;
        };
        let dx = -chol.solve(&g);
        let mut scale = 1.0;
        let mut accepted = false;
        for _ in 0..8 {
            let next = x + dx * scale;
            let fn_ = cost(sights, stride, &next, ap, cauchy_scale);
            if fn_ < f {
                (x, f) = (next, fn_);
                accepted = true;
                break;
            }
            scale *= 0.5;
        }
        if !accepted || dx.norm() * scale < 1e-6 {
            break;
        }
    }
    f.is_finite().then_some((x, info, f))
}

/// The AP, velocity and tilt corrections that best explain `sights` (module doc) with what the
/// lost window knew of the AP (`ap`, in the dead reckoning's frame, the heading unknown), seeded
/// by that AP turned about the drone and the carried velocity `v0` turned; `None` with fewer
/// than 6 sights or no finite solution.
pub(in crate::fusion::nonlinear) fn relocate(
    sights: &[TimedSight],
    ap: &ApFromDrone,
    v0: &Vector3<f64>,
    cauchy_scale: f64,
) -> Option<Relocated> {
    if sights.len() < 6 {
        return None;
    }
    let stride = sights.len().div_ceil(SEED_SIGHTS);
    let mut seeds: Vec<(f64, Vec8)> = Vec::new();
    let steps = (360.0 / AP_TURN_STEP_DEG).round() as usize;
    for i in 0..steps {
        let turn = UnitQuaternion::from_axis_angle(
            &Vector3::z_axis(),
            (i as f64 * AP_TURN_STEP_DEG).to_radians(),
        );
        let c = ap.drone + turn * ap.offset;
        for deg in VELOCITY_TURNS_DEG {
            let v_turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), deg.to_radians());
            let dv = v_turn * v0 - v0;
            let mut x = Vec8::zeros();
            x.fixed_rows_mut::<3>(0).copy_from(&c);
            x.fixed_rows_mut::<3>(3).copy_from(&dv);
            if let Some((x, _, f)) = solve(sights, stride, x, ap, SEED_ITERATIONS, cauchy_scale) {
                seeds.push((f, x));
            }
        }
    }
    seeds.sort_by(|a, b| a.0.total_cmp(&b.0));
    seeds
        .into_iter()
        .take(FINAL_SEEDS)
        .filter_map(|(_, x)| solve(sights, 1, x, ap, FINAL_ITERATIONS, cauchy_scale))
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .and_then(|(x, info, f)| {
            let cov = info.try_inverse()?;
            let (c, dv, da) = unpack(&x);
            let var = cov.fixed_view::<2, 2>(0, 0).symmetric_eigenvalues().max();
            Some(Relocated {
                c,
                dv,
                da,
                cost: f,
                ap_sigma_m: var.max(0.0).sqrt(),
            })
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aoa::steering::sin_aoa;
    use nalgebra::Rotation3;
    use rand_distr::{Distribution, StandardNormal};

    /// A circle flown with the yaw swinging, dead-reckoned from a state whose velocity is 0.8
    /// m/s off and with a 1.5° tilt error: the AP, the velocity and the tilt come back.
    #[test]
    fn the_ap_velocity_and_tilt_come_back_along_a_circle() {
        let mut rng = crate::sim::rng::stream(3, "relocate");
        let c_true = Vector3::new(6.0, 1.0, 1.8);
        let dv_true = Vector3::new(0.5, -0.6, 0.05);
        let da_true = Vector2::new(0.25, -0.1);
        let (r, w) = (2.5, 0.5);
        let mut sights = Vec::new();
        for i in 0..250 {
            let t = i as f64 * 0.02;
            let p_true = Vector3::new(r * (w * t).cos() - r, r * (w * t).sin(), 1.5);
            let yaw = 0.3 * (1.3 * t).sin();
            let world_from_array = Rotation3::from_euler_angles(0.0, 0.0, yaw);
            let d = world_from_array.inverse_transform_vector(&(c_true - p_true));
            let n: f64 = StandardNormal.sample(&mut rng);
            let theta = sin_aoa(&d).asin() + n * 1.5f64.to_radians();
            // What the dead reckoning says: the truth less the corrections.
            let p_dr =
                p_true - dv_true * t - Vector3::new(da_true.x, da_true.y, 0.0) * (0.5 * t * t);
            sights.push(TimedSight {
                sight: Sight {
                    p_a_in_w: p_dr,
                    world_from_array,
                    sin_measured: theta.sin(),
                    sigma: theta.cos().max(0.2) * 1.5f64.to_radians(),
                },
                t_s: t,
            });
        }
        // The lost window's AP, seen from the carried position (0.3 m off) with the heading
        // 40° off.
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 40f64.to_radians());
        let drone = Vector3::new(0.2, -0.2, 1.5);
        let ap = ApFromDrone {
            drone,
            offset: turn * (c_true - drone),
            sigma_m: 0.5,
        };
        let v0 = Vector3::new(0.0, r * w, 0.0) - dv_true;
        let found = relocate(&sights, &ap, &v0, 2.0).expect("a solution");
        assert!((found.c - c_true).norm() < 0.3, "AP at {:?}", found.c);
        // The corrected track, across the line of sight to the AP: within 0.2 m of the truth
        // over the 5 s. Along it, bearings see the motion only through the geometry's slow
        // change, so there the velocity and the tilt trade off against each other (the
        // window refines them over the seconds after; the barometer and the AP's range help).
        let truth = Relocated {
            c: c_true,
            dv: dv_true,
            da: da_true,
            cost: 0.0,
            ap_sigma_m: 0.0,
        };
        for i in 0..=50 {
            let t = i as f64 * 0.1;
            let p = Vector3::new(r * (w * t).cos() - r, r * (w * t).sin(), 1.5);
            let los = (c_true - p).xy().normalize();
            let across = Vector2::new(-los.y, los.x);
            let off = across.dot(&(found.dp(t) - truth.dp(t)).xy()).abs();
            assert!(off < 0.2, "track {off} m off across at {t} s");
        }
        assert!(found.ap_sigma_m < 0.5);
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let s = TimedSight {
            sight: Sight {
                p_a_in_w: Vector3::new(0.3, -0.2, 1.0),
                world_from_array: Rotation3::from_euler_angles(0.05, -0.02, 0.4),
                sin_measured: 0.2,
                sigma: 0.03,
            },
            t_s: 1.7,
        };
        let x = Vec8::from_column_slice(&[4.0, 1.0, 2.0, 0.3, -0.2, 0.05, 0.1, -0.2]);
        let (r, j) = residual(&s, &x).unwrap();
        let h = 1e-7;
        for i in 0..8 {
            let mut d = Vec8::zeros();
            d[i] = h;
            let fd = (residual(&s, &(x + d)).unwrap().0 - r) / h;
            assert!((fd - j[i]).abs() < 1e-6, "{i}: {fd} vs {}", j[i]);
        }
    }

    #[test]
    fn the_ap_prior_gradients_match_finite_differences() {
        let ap = ApFromDrone {
            drone: Vector3::new(0.5, -0.3, 1.4),
            offset: Vector3::new(6.0, 1.0, 0.4),
            sigma_m: 0.6,
        };
        let c = Vector3::new(5.0, 3.0, 2.0);
        let h = 1e-7;
        for (k, (r, j)) in ap.residuals(&c).into_iter().enumerate() {
            for i in 0..3 {
                let mut d = Vector3::zeros();
                d[i] = h;
                let fd = (ap.residuals(&(c + d))[k].0 - r) / h;
                assert!((fd - j[i]).abs() < 1e-6, "{k} {i}: {fd} vs {}", j[i]);
            }
        }
        // Its information: rank 2 (range and height), nothing on the bearing.
        let info = ap.information(&c);
        let across = Vector3::new(-3.3, 4.5, 0.0).normalize();
        assert!((info * across).norm() < 1e-12);
        assert!((info * Vector3::z()).norm() > 1.0);
    }

    #[test]
    fn too_few_sights_give_none() {
        let s = TimedSight {
            sight: Sight {
                p_a_in_w: Vector3::zeros(),
                world_from_array: Rotation3::identity(),
                sin_measured: 0.1,
                sigma: 0.03,
            },
            t_s: 0.0,
        };
        let ap = ApFromDrone {
            drone: Vector3::zeros(),
            offset: Vector3::x(),
            sigma_m: 0.5,
        };
        assert!(relocate(&[s; 5], &ap, &Vector3::zeros(), 2.0).is_none());
    }
}
