//! The range anchor: what a window lost to a hole knew of an AP's range, as a factor on the
//! next window's first keyframe and that AP ([`super::anchor`]).
//!
//! The bridge ([`super::bridge`]) puts the new window's first keyframe, at `p₀` with velocity
//! `v₀`, at `p_b + (v_b + v₀) T/2 + (a_b − a₀) T²/10 + (j_b + j₀) T³/120` after the lost
//! window's last state `p_b` (its motion `v_b, a_b, j_b`; `T` the hole), each motion in its own
//! window's frame. The two frames differ by an unknown turn about the vertical and a shift, but
//! horizontal distances do not: with the lost window's AP at `c_b`,
//!
//! ```text
//! D = c_b − p_b − v_b T/2 − a_b T²/10 − j_b T³/120          (lost window, fixed)
//! L = c − p₀ + v₀ T/2 − a₀ T²/10 + j₀ T³/120                (new window)
//! r = (‖L_xy‖ − ‖D_xy‖) / σ
//! ```
//!
//! with `a₀, j₀` fixed at the anchor's creation (the new window's first motion then; their
//! errors are in the bridge's σ). `∂r/∂c = u/σ`, `∂r/∂δp₀ = −u/σ`, `∂r/∂δv₀ = (T/2) u/σ` with
//! `u = (L_x, L_y, 0)/‖L_xy‖` (position and velocity errors are additive in `w`). The anchor
//! gives a new window the AP's range, the one thing its first seconds of bearings lack, and no
//! heading: the turn between the windows is found afterwards ([`super::holes`]).

use nalgebra::{Vector3, Vector6};

use super::state::{NavState, POS, Row15, STATE_DIM, VEL};
use super::window::{FitStats, Keyframe, NonlinearWindow};
use crate::fusion::window::arrow::ArrowSystem;
use crate::time::Timestamp;

/// A range anchor (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeAnchor {
    /// The keyframe it ties (a window's first).
    pub t: Timestamp,
    /// The AP.
    pub l: usize,
    /// `T/2`, s.
    pub half_span_s: f64,
    /// `−a₀ T²/10 + j₀ T³/120`, m (new window's frame).
    pub offset_m: Vector3<f64>,
    /// `‖D_xy‖`, m.
    pub range_m: f64,
    /// 1σ, m.
    pub sigma_m: f64,
}

impl RangeAnchor {
    /// `L` of the module doc at keyframe `x` and AP `c`.
    fn lever(&self, x: &NavState, c: &Vector3<f64>) -> Vector3<f64> {
        c - x.p_b_in_w + x.v_b_in_w * self.half_span_s + self.offset_m
    }

    /// The whitened residual `r` at keyframe `x` and AP `c`.
    pub fn residual(&self, x: &NavState, c: &Vector3<f64>) -> f64 {
        (self.lever(x, c).xy().norm() - self.range_m) / self.sigma_m
    }

    /// `(∂r/∂δx, ∂r/∂c)` at `x` and `c`: zero where `L_xy` vanishes (no direction).
    pub fn jacobian(&self, x: &NavState, c: &Vector3<f64>) -> (Row15, Vector3<f64>) {
        let l = self.lever(x, c);
        let n = l.xy().norm();
        let mut jx = Row15::zeros();
        if n.is_nan() || n <= 1e-9 {
            return (jx, Vector3::zeros());
        }
        let u = Vector3::new(l.x / n, l.y / n, 0.0) / self.sigma_m;
        let mut pv = Vector6::zeros();
        pv.fixed_rows_mut::<3>(0).copy_from(&(-u));
        pv.fixed_rows_mut::<3>(3).copy_from(&(u * self.half_span_s));
        for i in 0..3 {
            jx[POS + i] = pv[i];
            jx[VEL + i] = pv[3 + i];
        }
        (jx, u)
    }
}

impl NonlinearWindow {
    /// Adds range anchor `a` (module doc), on the keyframe at `a.t` while it is the window's
    /// first (its marginalization folds the anchor into the prior). `false` when AP `a.l` is not
    /// placed or no keyframe is at `a.t`.
    pub(super) fn add_range_anchor(&mut self, a: RangeAnchor) -> bool {
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
    pub(super) fn add_anchors(
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
                Some(l) if self.fej => l,
                _ => *c,
            };
            let r = a.residual(&kf.x, c);
            let (jx, jc) = a.jacobian(lin, &c_lin);
            *cost += r * r;
            stats.anchors += 1;
            stats.anchor_chi2 += r * r;
            sys.diag[0] += jx.transpose() * jx;
            sys.rhs_frames[0] -= jx.transpose() * r;
            let o = self.ap_offset(a.l);
            let mut fb = sys.frame_border[0].columns_mut(o, 3);
            fb += jx.transpose() * jc.transpose();
            let mut corner = sys.corner.view_mut((o, o), (3, 3));
            corner += jc * jc.transpose();
            let mut rb = sys.rhs_border.rows_mut(o, 3);
            rb -= jc * r;
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitQuaternion;

    use super::*;
    use crate::fusion::nonlinear::state::Vec15;

    fn state() -> NavState {
        NavState {
            t: Timestamp(0),
            world_from_body: UnitQuaternion::from_euler_angles(0.1, -0.2, 0.7),
            p_b_in_w: Vector3::new(0.3, -0.4, 1.2),
            v_b_in_w: Vector3::new(1.1, 0.4, -0.1),
            gyro_bias_rad_s: Vector3::zeros(),
            accel_bias_m_s2: Vector3::zeros(),
        }
    }

    fn anchor() -> RangeAnchor {
        RangeAnchor {
            t: Timestamp(0),
            l: 0,
            half_span_s: 2.5,
            offset_m: Vector3::new(0.2, -0.3, 0.1),
            range_m: 4.0,
            sigma_m: 0.4,
        }
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let (a, x, c) = (anchor(), state(), Vector3::new(3.0, 2.0, 2.5));
        let (jx, jc) = a.jacobian(&x, &c);
        let h = 1e-6;
        for i in 0..15 {
            let mut d = Vec15::zeros();
            d[i] = h;
            let fd =
                (a.residual(&x.boxplus(&d), &c) - a.residual(&x.boxplus(&(-d)), &c)) / (2.0 * h);
            assert!((fd - jx[i]).abs() < 1e-6, "state {i}: {fd} vs {}", jx[i]);
        }
        for i in 0..3 {
            let mut d = Vector3::zeros();
            d[i] = h;
            let fd = (a.residual(&x, &(c + d)) - a.residual(&x, &(c - d))) / (2.0 * h);
            assert!((fd - jc[i]).abs() < 1e-6, "ap {i}: {fd} vs {}", jc[i]);
        }
    }

    #[test]
    fn the_residual_ignores_a_turn_of_the_ap_about_the_lever_and_weighs_the_range() {
        let (a, x) = (anchor(), state());
        // An AP at range 4 m from the lever's origin, in two directions: both fit.
        let origin = x.p_b_in_w - x.v_b_in_w * a.half_span_s - a.offset_m;
        for angle in [0.0_f64, 2.0] {
            let c = origin + Vector3::new(4.0 * angle.cos(), 4.0 * angle.sin(), 0.7);
            assert!(a.residual(&x, &c).abs() < 1e-12);
        }
        // 0.4 m farther: one σ.
        let c = origin + Vector3::new(4.4, 0.0, 0.0);
        assert!((a.residual(&x, &c) - 1.0).abs() < 1e-12);
    }

    fn window(ap: Option<Vector3<f64>>) -> NonlinearWindow {
        let noise = crate::rig::ImuNoise {
            gyro_noise_density_rad_s_sqrt_hz: 1e-4,
            gyro_bias_random_walk_rad_s2_sqrt_hz: 1e-5,
            gyro_turn_on_bias_rad_s: 1e-3,
            accel_noise_density_m_s2_sqrt_hz: 1e-3,
            accel_bias_random_walk_m_s3_sqrt_hz: 1e-4,
            accel_turn_on_bias_m_s2: 1e-2,
        };
        NonlinearWindow::new(
            crate::fusion::nonlinear::NonlinearConfig::default(),
            9.81,
            noise,
            nalgebra::Isometry3::identity(),
            state(),
            Vec::new(),
            &crate::fusion::nonlinear::state::Mat15::identity(),
            vec![ap],
            None,
            None,
        )
    }

    /// In a window, an anchored AP settles at the anchor's range from the lever's origin (its
    /// σ far below the other information on it), and its fit counts the anchor; an anchor on
    /// an AP not placed, or on a keyframe not the window's first, is refused.
    #[test]
    fn an_anchored_window_takes_the_range() {
        let c0 = Vector3::new(6.0, 1.0, 2.0);
        let mut w = window(Some(c0));
        let a = RangeAnchor {
            sigma_m: 0.01,
            ..anchor()
        };
        assert!(!w.add_range_anchor(RangeAnchor {
            t: Timestamp(1),
            ..a
        }));
        assert!(w.add_range_anchor(a));
        assert!(w.hold_ap(0, c0, &(nalgebra::Matrix3::identity() * 1e-2)));
        let before = a.residual(&w.keyframes().next().copied().unwrap(), &c0);
        assert!(before.abs() > 100.0, "{before}");
        w.optimize(10).expect("solved");
        let x = *w.keyframes().next().unwrap();
        let r = a.residual(&x, &w.ap(0).unwrap());
        assert!(r.abs() < 0.05, "{r}");
        let fit = w.fit();
        assert_eq!(fit.anchors, 1);
        assert!((fit.anchor_chi2 - r * r).abs() < 1e-12);
        assert!(!window(None).add_range_anchor(a));
    }

    /// When its keyframe leaves the window, the anchor goes into the prior: the next solve
    /// still holds the range against a hold that pulls the AP 1 m along it, and the anchor is
    /// gone from the factors.
    #[test]
    fn a_marginalized_anchor_stays_in_the_prior() {
        use crate::imu::{ImuBiases, ImuSample, Preintegrator};
        let c0 = Vector3::new(6.0, 1.0, 2.0);
        let mut w = window(Some(c0));
        let x0 = *w.keyframes().next().unwrap();
        let a = RangeAnchor {
            range_m: (c0 - x0.p_b_in_w + x0.v_b_in_w * 2.5 + anchor().offset_m)
                .xy()
                .norm(),
            sigma_m: 0.01,
            ..anchor()
        };
        assert!(w.add_range_anchor(a));
        assert!(w.hold_ap(0, c0, &(nalgebra::Matrix3::identity() * 1e-2)));
        // A second keyframe 0.1 s on, the IMU measuring the state's own motion (none but
        // gravity against its attitude).
        let mut pre = Preintegrator::new(w.imu_noise.clone(), ImuBiases::zero());
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
        assert!(w.hold_ap(0, farther, &(nalgebra::Matrix3::identity() * 1e2)));
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
