//! The window's normal equations: every factor it holds (IMU between keyframes, AoA cones and
//! barometer altitudes at their instants, range anchors, zero-velocity holds, the prior),
//! linearized and added through the one factor interface ([`crate::fusion::arrow::Linearized`]).

use super::fit::{FitStats, cauchy};
use super::{Keyframe, NonlinearWindow};
use crate::fusion::arrow::{ArrowSystem, BorderBlock, Linearized, Weight};
use crate::fusion::nonlinear::factors::baro::{baro_jacobian, baro_residual};
use crate::fusion::nonlinear::factors::cone::{cone_jacobian, cone_residual, sin_sigma};
use crate::fusion::nonlinear::factors::imu::{imu_jacobians, imu_residual};
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
            self.add_measurements(k, kf, &lin_k, &mut sys, &mut cost, &mut stats);
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

    /// The AoA and barometer factors of keyframe `k`.
    fn add_measurements(
        &self,
        k: usize,
        kf: &Keyframe,
        lin_k: &NavState,
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
                *cost += rho;
                stats.bearings += 1;
                stats.bearing_chi2 += e2;
                stats.bearing_robust += rho;
                stats.bearing_outliers += usize::from(e2 > 9.0);
                let info = w / (sigma * sigma);
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
