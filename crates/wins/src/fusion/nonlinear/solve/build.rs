//! The window's normal equations: every factor it holds (IMU between keyframes, AoA cones and
//! barometer altitudes at their instants, range anchors, zero-velocity holds, the prior),
//! linearized and added through the one factor interface ([`crate::fusion::arrow::Linearized`]);
//! and which keyframes are held at zero velocity.

use super::fit::FitStats;
use super::{Keyframe, NonlinearWindow};
use crate::fusion::arrow::{ArrowSystem, BorderBlock, Linearized, Weight};
use crate::fusion::nonlinear::factors::baro::{baro_jacobian, baro_residual};
use crate::fusion::nonlinear::factors::cone::cauchy;
use crate::fusion::nonlinear::factors::cone::{cone_jacobian, cone_residual, sin_sigma};
use crate::fusion::nonlinear::factors::imu::{imu_jacobians, imu_residual};
use crate::fusion::nonlinear::factors::zero_velocity::{
    zero_velocity_jacobian, zero_velocity_residual,
};
use crate::fusion::nonlinear::state::{NavState, STATE_DIM};
use nalgebra::Vector1;

impl NonlinearWindow {
    /// The normal equations at the current estimate (Jacobians at the linearization points) over
    /// every keyframe, the cost `2 × (½ Σ ρ)` and the residual statistics.
    pub(in crate::fusion::nonlinear) fn build(
        &self,
        with_prior: bool,
    ) -> (ArrowSystem<STATE_DIM>, f64, FitStats) {
        let n = self.keyframes.len();
        let m = self.border_dim();
        let mut sys = ArrowSystem::<STATE_DIM>::zeros(n, m);
        let mut cost = 0.0;
        let mut stats = FitStats::default();
        let g = self.model.gravity_m_s2;
        let shares = self.bearing_shares();
        for (k, kf) in self.keyframes.iter().enumerate() {
            let lin_k = kf.lin_or_current(self.model.fej);
            if let (Some((pre, info)), Some(prev)) = (&kf.from_prev, k.checked_sub(1)) {
                let p = &self.keyframes[prev];
                let r = imu_residual(pre, g, &p.x, &kf.x);
                let (ji, jj) = imu_jacobians(pre, g, &p.lin_or_current(self.model.fej), &lin_k);
                sys.add(&Linearized::between(
                    (prev, ji),
                    (k, jj),
                    r,
                    Weight::Matrix(*info),
                ));
                let c = (r.transpose() * info * r)[0];
                cost += c;
                stats.imu_chi2 += c;
                stats.imu_dof += STATE_DIM;
            }
            self.add_measurements(k, kf, &lin_k, &shares, &mut sys, &mut cost, &mut stats);
            if k == 0 {
                self.add_anchors(kf, &lin_k, &mut sys, &mut cost, &mut stats);
            }
            if kf.still {
                self.add_zero_velocity(k, kf, &mut sys, &mut cost, &mut stats);
            }
        }
        if with_prior {
            cost += self.add_prior(&mut sys);
        }
        (sys, cost, stats)
    }

    /// The AoA and barometer factors of keyframe `k`; each bearing of AP `l` with `shares[l]`
    /// of an independent one's information and degrees of freedom ([`super::shares`]).
    #[allow(clippy::too_many_arguments)]
    fn add_measurements(
        &self,
        k: usize,
        kf: &Keyframe,
        lin_k: &NavState,
        shares: &[f64],
        sys: &mut ArrowSystem<STATE_DIM>,
        cost: &mut f64,
        stats: &mut FitStats,
    ) {
        let g = self.model.gravity_m_s2;
        for f in &kf.frames {
            for b in &f.bearings {
                let Some(c) = self.aps.get(b.ap).filter(|_| self.placed[b.ap]) else {
                    continue;
                };
                let c_lin = match self.ap_lin[b.ap] {
                    Some(l) if self.model.fej => l,
                    _ => *c,
                };
                let s_meas = b.aoa_rad.sin();
                let Some(j) = cone_jacobian(
                    lin_k,
                    &f.partial,
                    g,
                    &self.model.body_from_array,
                    &c_lin,
                    s_meas,
                ) else {
                    continue;
                };
                // The residual at the current estimate: the Jacobian's own unless a frozen point
                // differs from it.
                let r = if *lin_k == kf.x && c_lin == *c {
                    j.residual
                } else {
                    match cone_residual(
                        &kf.x,
                        &f.partial,
                        g,
                        &self.model.body_from_array,
                        c,
                        s_meas,
                    ) {
                        Some(r) => r,
                        None => continue,
                    }
                } + self.bias.map_or(0.0, |b| b.0);
                let sigma = sin_sigma(b.aoa_rad, b.sigma_rad);
                let e2 = (r / sigma).powi(2);
                let (rho, w) = cauchy(e2, self.model.config.cauchy_scale);
                let share = shares.get(b.ap).copied().unwrap_or(1.0);
                *cost += share * rho;
                stats.bearings += 1;
                stats.bearing_dof += share;
                stats.bearing_chi2 += share * e2;
                stats.bearing_robust += share * rho;
                stats.bearing_outliers += usize::from(e2 > 9.0);
                let info = share * w / (sigma * sigma);
                let mut factor =
                    Linearized::on_frame(k, j.d_state, Vector1::new(r), Weight::Scalar(info))
                        .with_border(BorderBlock::three(self.ap_offset(b.ap), j.d_ap));
                if self.bias.is_some() {
                    // ∂r/∂β = 1.
                    factor =
                        factor.with_border(BorderBlock::one(self.scalars() - 1, Vector1::new(1.0)));
                }
                sys.add(&factor);
            }
            if let (Some(h), Some((o, o_lin))) = (f.altitude_m, self.baro) {
                let r = baro_residual(&kf.x, &f.partial, g, o, h);
                let o_lin = match o_lin {
                    Some(l) if self.model.fej => l,
                    _ => o,
                };
                let (jx, jo) = baro_jacobian(lin_k, &f.partial, g, o_lin, h);
                let info = self.model.config.baro_sigma_m.powi(-2);
                let e2 = r * r * info;
                *cost += e2;
                stats.baro += 1;
                stats.baro_chi2 += e2;
                sys.add(
                    &Linearized::on_frame(k, jx, Vector1::new(r), Weight::Scalar(info))
                        .with_border(BorderBlock::one(0, Vector1::new(jo))),
                );
            }
        }
    }
}

impl NonlinearWindow {
    /// Holds the newest keyframe at zero velocity from now on (it was taken while still).
    pub fn hold_newest_still(&mut self) {
        if let Some(k) = self.keyframes.back_mut() {
            k.still = true;
        }
    }

    /// Keyframes held at zero velocity.
    pub fn still_keyframes(&self) -> usize {
        self.keyframes.iter().filter(|k| k.still).count()
    }

    /// Adds keyframe `k`'s zero-velocity factor to `sys` (the Jacobian is constant, so first
    /// estimates change nothing).
    pub(in crate::fusion::nonlinear) fn add_zero_velocity(
        &self,
        k: usize,
        kf: &Keyframe,
        sys: &mut ArrowSystem<STATE_DIM>,
        cost: &mut f64,
        stats: &mut FitStats,
    ) {
        let r = zero_velocity_residual(&kf.x);
        let info = self.model.config.zero_velocity_sigma_m_s.powi(-2);
        let j = zero_velocity_jacobian();
        let e2 = r.norm_squared() * info;
        *cost += e2;
        stats.zero_velocity += 3;
        stats.zero_velocity_chi2 += e2;
        sys.add(&Linearized::on_frame(k, j, r, Weight::Scalar(info)));
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::super::aps::tests::window;
    use super::*;
    use crate::fusion::nonlinear::state::VEL;
    use crate::time::Timestamp;

    /// A window at rest whose IMU reads gravity plus an accelerometer bias of 0.5 m/s² along x,
    /// with `n` keyframes 0.1 s apart after the first (each held still when `held`).
    fn biased_rest(n: i64, held: bool) -> NonlinearWindow {
        use crate::imu::{ImuBiases, ImuSample, Preintegrator};
        let mut w = window(Vec::new());
        let x0 = *w.keyframes().next().unwrap();
        let g = w.model.gravity_m_s2;
        let sample = |ms: i64| ImuSample {
            t: Timestamp(ms * 1_000_000),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::new(0.5, 0.0, g),
        };
        let mut pre = Preintegrator::new(w.model.imu_noise.clone(), ImuBiases::zero());
        for k in 1..=n {
            for ms in ((k - 1) * 100..k * 100).step_by(10) {
                pre.push(&sample(ms)).unwrap();
            }
            let t = Timestamp(k * 100_000_000);
            let interval = pre.cut(t, &sample(k * 100)).unwrap();
            assert!(
                w.push_keyframe(NavState { t, ..x0 }, interval, Vec::new())
                    .is_some()
            );
            if held {
                w.hold_newest_still();
            }
        }
        // The tilt that explains the drift is slow to reach from a level start.
        w.optimize(50).unwrap();
        w
    }

    /// Held still, the window's velocities stay at zero against the IMU's drift (it is taken
    /// for a tilt or a bias, which a rest cannot tell apart); without the holds they follow it.
    #[test]
    fn a_still_window_holds_its_velocity_against_the_drift() {
        let w = biased_rest(4, true);
        assert_eq!(w.still_keyframes(), 4);
        assert_eq!(w.fit().zero_velocity, 12);
        for x in w.keyframes().skip(1) {
            assert!(x.v_b_in_w.norm() < 1e-3, "{:?}", x.v_b_in_w);
        }
        let drifting = biased_rest(4, false);
        assert_eq!(drifting.fit().zero_velocity, 0);
        let v = drifting.keyframes().last().unwrap().v_b_in_w;
        assert!(v.x > 0.05, "{v:?}");
    }

    /// When a held keyframe leaves the window its hold goes into the prior on the next one's
    /// velocity, once (the marginalization's copy of the next keyframe carries none).
    #[test]
    fn a_marginalized_hold_stays_in_the_prior() {
        let velocity_information = |held: bool| {
            let mut w = biased_rest(3, held);
            w.marginalize_oldest();
            w.marginalize_oldest();
            assert_eq!(w.fit().zero_velocity, if held { 6 } else { 0 });
            w.prior.h.fixed_view::<3, 3>(VEL, VEL).diagonal().min()
        };
        let info = 0.02_f64.powi(-2);
        let held = velocity_information(true);
        assert!(held > 0.9 * info && held < 1.1 * info, "{held}");
        let free = velocity_information(false);
        assert!(free < 10.0, "{free}");
    }
}
