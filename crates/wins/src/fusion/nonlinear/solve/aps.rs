//! The window's APs: placed ones (in the border, their bearings used) and placeholders for APs
//! seen but not yet placed (the border keeps their slot so that an AP's index is its number; a
//! vanishing prior keeps the system regular; their bearings are skipped). An AP is placed at the
//! start, or later from its triangulation ([`crate::fusion::nonlinear::late_ap`]), whose information joins the
//! prior at that point. What is known of them from outside the window (a window lost to a hole:
//! where it had them, their ranges) is held here too.

use nalgebra::{DMatrix, DVector, Matrix3, Vector1, Vector3};

use crate::fusion::arrow::{ArrowSystem, BorderBlock, Linearized, Weight};
use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::factors::range_anchor::RangeAnchor;
use crate::fusion::nonlinear::solve::fit::FitStats;
use crate::fusion::nonlinear::solve::{Keyframe, NonlinearWindow, PLACEHOLDER_INFORMATION};
use crate::fusion::nonlinear::state::{NavState, STATE_DIM};
use crate::fusion::nonlinear::triangulate::{Sight, Triangulated, triangulate};

/// The largest horizontal σ (of the x–y block) of a position covariance, m.
pub fn horizontal_sigma_m(covariance: &Matrix3<f64>) -> f64 {
    covariance
        .fixed_view::<2, 2>(0, 0)
        .into_owned()
        .symmetric_eigenvalues()
        .max()
        .max(0.0)
        .sqrt()
}

/// The AP `sights` see, triangulated, when its horizontal σ is within `config`'s bounds at its
/// smallest range from the sights ([`NonlinearConfig::ap_sigma_ok`]).
pub fn triangulate_within_bounds(
    sights: &[Sight],
    config: &NonlinearConfig,
) -> Option<Triangulated> {
    let t = triangulate(sights, config.cauchy_scale)?;
    within_bounds(&t, sights, config).then_some(t)
}

/// Whether `t`'s horizontal σ is within `config`'s bounds at its smallest range from the
/// `sights` it was triangulated from ([`NonlinearConfig::ap_sigma_ok`]).
pub fn within_bounds(t: &Triangulated, sights: &[Sight], config: &NonlinearConfig) -> bool {
    let range = sights
        .iter()
        .map(|s| (t.c_in_w - s.p_a_in_w).norm())
        .fold(f64::INFINITY, f64::min);
    config.ap_sigma_ok(horizontal_sigma_m(&t.covariance), range)
}

impl NonlinearWindow {
    /// Places AP `l` at `c_in_w` with information `info` (from bearings the window does not
    /// hold) in the prior, at that point (its first estimate); APs between the last one and `l`
    /// get placeholders.
    pub fn place_ap(&mut self, l: usize, c_in_w: Vector3<f64>, info: &Matrix3<f64>) {
        while self.aps.len() <= l {
            self.push_placeholder();
        }
        let o = STATE_DIM + self.ap_offset(l);
        let n = self.prior.h.nrows();
        self.prior.h.view_mut((o, 0), (3, n)).fill(0.0);
        self.prior.h.view_mut((0, o), (n, 3)).fill(0.0);
        self.prior.h.view_mut((o, o), (3, 3)).copy_from(info);
        self.prior.g.rows_mut(o, 3).fill(0.0);
        self.aps[l] = c_in_w;
        self.ap_lin[l] = Some(c_in_w);
        self.placed[l] = true;
    }

    /// Holds placed AP `l` near `target` with information `info` (what is known of it from
    /// outside the window: where a lost window had it), added to its prior:
    /// `(c − target)ᵀ Λ (c − target)` about the AP's linearization point, frozen here at its
    /// estimate if it was not yet (as when it enters the prior at a marginalization). `false`
    /// when the AP is not placed.
    pub(in crate::fusion::nonlinear) fn hold_ap(
        &mut self,
        l: usize,
        target: Vector3<f64>,
        info: &Matrix3<f64>,
    ) -> bool {
        let (Some(true), Some(c), Some(lin)) =
            (self.placed.get(l), self.aps.get(l), self.ap_lin.get_mut(l))
        else {
            return false;
        };
        let lin = *lin.get_or_insert(*c);
        let o = STATE_DIM + self.ap_offset(l);
        let mut block = self.prior.h.view_mut((o, o), (3, 3));
        block += info;
        let mut g = self.prior.g.rows_mut(o, 3);
        g += info * (lin - target);
        true
    }

    /// Holds the barometer offset near `target_m` with information `info` (1/m²; what is known
    /// of it from outside the window: a lost window's offset, the barometer having run on),
    /// added to its prior as [`hold_ap`](Self::hold_ap) does. `false` without a barometer.
    pub(in crate::fusion::nonlinear) fn hold_baro_offset(
        &mut self,
        target_m: f64,
        info: f64,
    ) -> bool {
        let Some((o, lin)) = self.baro.as_mut() else {
            return false;
        };
        let lin = *lin.get_or_insert(*o);
        self.prior.h[(STATE_DIM, STATE_DIM)] += info;
        self.prior.g[STATE_DIM] += info * (lin - target_m);
        true
    }

    fn push_placeholder(&mut self) {
        let dim = self.prior.h.nrows();
        let full = STATE_DIM + self.border_dim() + 3;
        let mut h = DMatrix::zeros(full, full);
        h.view_mut((0, 0), (dim, dim)).copy_from(&self.prior.h);
        h.view_mut((full - 3, full - 3), (3, 3))
            .fill_diagonal(PLACEHOLDER_INFORMATION);
        let mut g = DVector::zeros(full);
        g.rows_mut(0, dim).copy_from(&self.prior.g);
        self.prior.h = h;
        self.prior.g = g;
        self.aps.push(Vector3::zeros());
        self.ap_lin.push(None);
        self.placed.push(false);
    }

    /// Whether AP `l` is placed.
    pub fn is_placed(&self, l: usize) -> bool {
        self.placed.get(l).copied().unwrap_or(false)
    }

    /// AP `l`'s position in `w`, when placed.
    pub fn ap(&self, l: usize) -> Option<Vector3<f64>> {
        self.is_placed(l).then(|| self.aps[l])
    }

    /// AP `l`'s marginal position covariance (last solve), m², when placed.
    pub fn ap_covariance(&self, l: usize) -> Option<Matrix3<f64>> {
        let o = self.ap_offset(l);
        (self.is_placed(l) && self.covariance.border.nrows() >= o + 3)
            .then(|| self.covariance.border.fixed_view::<3, 3>(o, o).into_owned())
    }

    /// AP `l`'s largest marginal σ (largest eigenvalue of its block), m.
    pub fn ap_sigma_m(&self, l: usize) -> Option<f64> {
        self.ap_covariance(l)
            .map(|p| p.symmetric_eigenvalues().max().max(0.0).sqrt())
    }

    /// AP `l`'s smallest range from the window's keyframes, m, when placed.
    pub fn ap_nearest_range_m(&self, l: usize) -> Option<f64> {
        let c = self.ap(l)?;
        Some(
            self.keyframes()
                .map(|x| (c - x.p_b_in_w).norm())
                .fold(f64::INFINITY, f64::min),
        )
    }

    /// AP `l`'s largest horizontal marginal σ (of its x–y block), m. An AP near the array's
    /// height is seen at an elevation `e ≈ 0`, where the cone angle changes only to second order
    /// with `e` (`sin θ = cos e sin φ`): its height is weakly determined, and matters as little
    /// to the bearings.
    pub fn ap_horizontal_sigma_m(&self, l: usize) -> Option<f64> {
        self.ap_covariance(l).map(|p| horizontal_sigma_m(&p))
    }
}

impl NonlinearWindow {
    /// Adds range anchor `a` ([`crate::fusion::nonlinear::factors::range_anchor`]), on the keyframe at `a.t` while it is the window's
    /// first (its marginalization folds the anchor into the prior). `false` when AP `a.l` is not
    /// placed or no keyframe is at `a.t`.
    pub(in crate::fusion::nonlinear) fn add_range_anchor(&mut self, a: RangeAnchor) -> bool {
        let ok = self.is_placed(a.l)
            && self.keyframes.front().is_some_and(|k| k.x.t == a.t)
            && a.sigma_m > 0.0
            && a.range_m.is_finite();
        if ok {
            self.anchors.push(a);
        }
        ok
    }

    /// The range anchors on keyframe `kf`, the window's first, into `sys` (first-estimate
    /// Jacobians, as the other factors).
    pub(in crate::fusion::nonlinear) fn add_anchors(
        &self,
        kf: &Keyframe,
        lin: &NavState,
        sys: &mut ArrowSystem<STATE_DIM>,
        cost: &mut f64,
        stats: &mut FitStats,
    ) {
        for a in self.anchors.iter().filter(|a| a.t == kf.x.t) {
            let (Some(c), Some(true)) = (self.aps.get(a.l), self.placed.get(a.l)) else {
                continue;
            };
            let c_lin = match self.ap_lin[a.l] {
                Some(l) if self.model.fej => l,
                _ => *c,
            };
            let r = a.residual(&kf.x, c);
            let (jx, jc) = a.jacobian(lin, &c_lin);
            *cost += r * r;
            stats.anchors += 1;
            stats.anchor_chi2 += r * r;
            sys.add(
                &Linearized::on_frame(0, jx, Vector1::new(r), Weight::Scalar(1.0))
                    .with_border(BorderBlock::three(self.ap_offset(a.l), jc.transpose())),
            );
        }
    }
}

#[cfg(test)]
pub(in crate::fusion::nonlinear) mod tests {
    use nalgebra::{Isometry3, Matrix3, Vector3};

    use crate::fusion::nonlinear::config::NonlinearConfig;
    use crate::fusion::nonlinear::factors::range_anchor::RangeAnchor;
    use crate::fusion::nonlinear::factors::range_anchor::tests::{anchor, state};
    use crate::fusion::nonlinear::solve::NonlinearWindow;
    use crate::fusion::nonlinear::state::{Mat15, NavState};
    use crate::rig::ImuNoise;
    use crate::time::Timestamp;

    /// A window at rest at (0, 0, 1.5) m, level, with the APs `aps` and a unit prior.
    pub(in crate::fusion::nonlinear) fn window(aps: Vec<Option<Vector3<f64>>>) -> NonlinearWindow {
        window_with_baro(aps, None)
    }

    fn window_with_baro(
        aps: Vec<Option<Vector3<f64>>>,
        baro_offset_m: Option<f64>,
    ) -> NonlinearWindow {
        let x0 = NavState {
            t: Timestamp(0),
            world_from_body: nalgebra::UnitQuaternion::identity(),
            p_b_in_w: Vector3::new(0.0, 0.0, 1.5),
            v_b_in_w: Vector3::zeros(),
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        };
        window_at(x0, aps, baro_offset_m)
    }

    fn window_at(
        x0: NavState,
        aps: Vec<Option<Vector3<f64>>>,
        baro_offset_m: Option<f64>,
    ) -> NonlinearWindow {
        let noise = ImuNoise {
            gyro_noise_density_rad_s_sqrt_hz: 1e-4,
            gyro_bias_random_walk_rad_s2_sqrt_hz: 1e-5,
            gyro_turn_on_bias_rad_s: 1e-3,
            accel_noise_density_m_s2_sqrt_hz: 1e-3,
            accel_bias_random_walk_m_s3_sqrt_hz: 1e-4,
            accel_turn_on_bias_m_s2: 1e-2,
        };
        NonlinearWindow::new(
            NonlinearConfig::default(),
            9.81,
            noise,
            Isometry3::identity(),
            x0,
            Vec::new(),
            &Mat15::identity(),
            aps,
            baro_offset_m,
            None,
        )
    }

    /// An AP held where a lost window had it, with nothing else on it, goes there; an AP not
    /// placed cannot be held.
    #[test]
    fn a_held_ap_goes_where_it_is_held() {
        let (start, target) = (Vector3::new(6.0, 1.0, 2.0), Vector3::new(5.6, 1.3, 1.8));
        let mut w = window(vec![Some(start), None]);
        assert!(w.hold_ap(0, target, &(Matrix3::identity() * 1e4)));
        assert!(!w.hold_ap(1, target, &Matrix3::identity()));
        assert!(!w.hold_ap(2, target, &Matrix3::identity()));
        w.optimize(5).expect("solved");
        let c = w.ap(0).expect("placed");
        assert!((c - target).norm() < 1e-6, "{c:?}");
        // Held at two points, it settles between them, by their information.
        let other = target + Vector3::new(0.3, 0.0, 0.0);
        let mut w = window(vec![Some(start)]);
        assert!(w.hold_ap(0, target, &(Matrix3::identity() * 1e4)));
        assert!(w.hold_ap(0, other, &(Matrix3::identity() * 3e4)));
        w.optimize(5).expect("solved");
        let c = w.ap(0).expect("placed");
        assert!((c - (target * 0.25 + other * 0.75)).norm() < 1e-6, "{c:?}");
    }

    /// A barometer offset held where a lost window had it goes there, and between two holds by
    /// their information; a window without a barometer has none to hold.
    #[test]
    fn a_held_barometer_offset_goes_where_it_is_held() {
        let mut w = window_with_baro(vec![Some(Vector3::new(6.0, 1.0, 2.0))], Some(0.4));
        assert!(w.hold_baro_offset(-0.2, 1e4));
        w.optimize(5).expect("solved");
        let o = w.baro_offset_m().expect("a barometer");
        assert!((o + 0.2).abs() < 1e-4, "{o}");
        let mut w = window_with_baro(vec![Some(Vector3::new(6.0, 1.0, 2.0))], Some(0.4));
        assert!(w.hold_baro_offset(-0.2, 1e4));
        assert!(w.hold_baro_offset(0.2, 3e4));
        w.optimize(5).expect("solved");
        let o = w.baro_offset_m().expect("a barometer");
        assert!((o - 0.1).abs() < 1e-4, "{o}");
        assert!(!window(Vec::new()).hold_baro_offset(0.0, 1.0));
    }

    /// A hold added after a solve that ended at its minimum (no step lowering the cost, the
    /// cost negative from a prior's gradient) is followed by the next solve: the damping that
    /// solve left is not carried into the next one.
    #[test]
    fn a_hold_after_a_converged_solve_is_followed() {
        let start = Vector3::new(6.0, 1.0, 2.0);
        let mut w = window_with_baro(vec![Some(start)], Some(0.4));
        assert!(w.hold_baro_offset(-0.2, 1e4));
        w.optimize(5).expect("solved");
        w.optimize(5).expect("solved at the minimum");
        let target = Vector3::new(5.0, 1.0, 2.0);
        assert!(w.hold_ap(0, target, &(Matrix3::identity() * 1e4)));
        w.optimize(5).expect("solved");
        let c = w.ap(0).expect("placed");
        assert!((c - target).norm() < 1e-3, "{c:?}");
    }

    /// A window at the anchors' tests' moving state, with AP 0 at `ap`.
    fn moving_window(ap: Option<Vector3<f64>>) -> NonlinearWindow {
        window_at(state(), vec![ap], None)
    }

    /// In a window, an anchored AP settles at the anchor's range from the lever's origin (its
    /// σ far below the other information on it), and its fit counts the anchor; an anchor on
    /// an AP not placed, or on a keyframe not the window's first, is refused.
    #[test]
    fn an_anchored_window_takes_the_range() {
        let c0 = Vector3::new(6.0, 1.0, 2.0);
        let mut w = moving_window(Some(c0));
        let a = RangeAnchor {
            sigma_m: 0.01,
            ..anchor()
        };
        assert!(!w.add_range_anchor(RangeAnchor {
            t: Timestamp(1),
            ..a
        }));
        assert!(w.add_range_anchor(a));
        assert!(w.hold_ap(0, c0, &(Matrix3::identity() * 1e-2)));
        let before = a.residual(&w.keyframes().next().copied().unwrap(), &c0);
        assert!(before.abs() > 100.0, "{before}");
        w.optimize(10).expect("solved");
        let x = *w.keyframes().next().unwrap();
        let r = a.residual(&x, &w.ap(0).unwrap());
        assert!(r.abs() < 0.05, "{r}");
        let fit = w.fit();
        assert_eq!(fit.anchors, 1);
        assert!((fit.anchor_chi2 - r * r).abs() < 1e-12);
        assert!(!moving_window(None).add_range_anchor(a));
    }

    /// When its keyframe leaves the window, the anchor goes into the prior: the next solve
    /// still holds the range against a hold that pulls the AP 1 m along it, and the anchor is
    /// gone from the factors.
    #[test]
    fn a_marginalized_anchor_stays_in_the_prior() {
        use crate::imu::{ImuBiases, ImuSample, Preintegrator};
        let c0 = Vector3::new(6.0, 1.0, 2.0);
        let mut w = moving_window(Some(c0));
        let x0 = *w.keyframes().next().unwrap();
        let a = RangeAnchor {
            range_m: (c0 - x0.p_b_in_w + x0.v_b_in_w * 2.5 + anchor().offset_m)
                .xy()
                .norm(),
            sigma_m: 0.01,
            ..anchor()
        };
        assert!(w.add_range_anchor(a));
        assert!(w.hold_ap(0, c0, &(Matrix3::identity() * 1e-2)));
        // A second keyframe 0.1 s on, the IMU measuring the state's own motion (none but
        // gravity against its attitude).
        let mut pre = Preintegrator::new(w.model.imu_noise.clone(), ImuBiases::zero());
        let f = x0.world_from_body.inverse() * Vector3::new(0.0, 0.0, 9.81);
        let sample = |ms: i64| ImuSample {
            t: Timestamp(ms * 1_000_000),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: f,
        };
        for ms in (0..100).step_by(10) {
            pre.push(&sample(ms)).unwrap();
        }
        let interval = pre.cut(Timestamp(100_000_000), &sample(100)).unwrap();
        let x1 = NavState {
            t: Timestamp(100_000_000),
            p_b_in_w: x0.p_b_in_w + x0.v_b_in_w * 0.1,
            ..x0
        };
        assert!(w.push_keyframe(x1, interval, Vec::new()).is_some());
        w.optimize(5).unwrap();
        w.marginalize_oldest();
        assert!(w.anchors.is_empty());
        assert_eq!(w.fit().anchors, 0);
        // Held 1 m farther along the range (σ 0.1 m): the anchor (σ 0.01 m) keeps the range.
        let farther = c0 + Vector3::new(1.0, 0.0, 0.0);
        assert!(w.hold_ap(0, farther, &(Matrix3::identity() * 1e2)));
        w.optimize(10).unwrap();
        // The first keyframe where the second now puts it (the IMU measured no acceleration):
        // the two moved with the AP, whose range from it is kept.
        let x1 = *w.keyframes().next().unwrap();
        let back = NavState {
            p_b_in_w: x1.p_b_in_w - x1.v_b_in_w * 0.1,
            ..x1
        };
        let c = w.ap(0).unwrap();
        assert!((c - farther).norm() < 0.1, "{c:?}");
        let r = a.residual(&back, &c);
        assert!(r.abs() < 1.0, "{r} σ off the anchor's range");
    }
}
