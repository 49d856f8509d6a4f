//! Assembling the window's normal equations from its prior and factors, once for the solve and
//! once (restricted to the oldest frame's factors) for marginalization.

use std::cell::Ref;
use std::ops::AddAssign;

use nalgebra::Vector3;

use super::factors::{
    AoaFactorInput, AoaInfo, AoaPoint, AoaSigmas, BIAS_DIM, ImuFactorInput, ImuInfo, aoa_info,
    imu_info,
};
use super::{Frame, SlidingWindow, nominal_gravity};
use crate::fusion::arrow::{ArrowSystem, FRAME_DIM};

/// Where an IMU factor was linearized: the previous solution's `v_k+1`, `g_k+1`, `p_k+1 − p_k`
/// and gyro bias (they enter the noise mapping and the gyro-bias columns).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ImuLinearization {
    v_next: Vector3<f64>,
    g_next: Vector3<f64>,
    step_in_b0: Vector3<f64>,
    gyro_bias_rad_s: Vector3<f64>,
    gyro_active: bool,
}

impl ImuLinearization {
    /// Whether a factor linearized at `self` may stand for one at `other` (fluid
    /// re-linearization, as iSAM2 does): the moves below change its rows by far less than their
    /// noise over one 20 ms interval.
    fn close_to(&self, other: &Self) -> bool {
        self.gyro_active == other.gyro_active
            && (self.v_next - other.v_next).amax() < 2e-2
            && (self.g_next - other.g_next).amax() < 2e-2
            && (self.step_in_b0 - other.step_in_b0).amax() < 5e-4
            && (self.gyro_bias_rad_s - other.gyro_bias_rad_s).amax() < 2e-4
    }
}

/// Border offset of the gyro bias.
const GYRO: usize = 3;

/// Border offset of AP `l`.
pub(super) fn ap_offset(l: usize) -> usize {
    BIAS_DIM + 3 * l
}

impl SlidingWindow {
    /// Whether the gyro bias is being estimated now (after convergence, when enabled).
    pub(super) fn gyro_active(&self) -> bool {
        self.config.estimate_gyro_bias
            && self.config.adaptive_weights
            && self.converged_at.is_some()
    }

    /// Where frame `f`'s rows to AP `l` are linearized (module doc of [`super`]): the algebraic
    /// row with the initial range until converged, then the angle at the current solution.
    fn aoa_point(&self, f: &Frame, l: usize) -> AoaPoint {
        let c = &self.config;
        if self.converged_at.is_none() || !c.adaptive_weights {
            return AoaPoint::Range(c.initial_range_m);
        }
        let ap = self.border.fixed_rows::<3>(ap_offset(l));
        let p = f.x.fixed_rows::<3>(0);
        let x = ap - p - f.b0_from_bk * c.body_from_array.translation.vector;
        let r = x.norm();
        if !r.is_finite() {
            AoaPoint::Range(c.initial_range_m)
        } else if c.angle_rows && r >= c.range_limits_m.0 {
            AoaPoint::At(x)
        } else {
            AoaPoint::Range(r.clamp(c.range_limits_m.0, c.range_limits_m.1))
        }
    }

    /// Frame `k`'s IMU factor to frame `k + 1`, from the frame's cache when its linearization
    /// point has hardly moved (borrowed, not copied: it is several kB).
    pub(super) fn imu_factor(&self, k: usize) -> Option<Ref<'_, ImuInfo>> {
        let (a, b) = (&self.frames[k], &self.frames[k + 1]);
        let pre = b.from_prev.as_ref()?;
        let adaptive = self.solved_once && self.config.adaptive_weights;
        let (v_next, g_next, step_in_b0) = if adaptive {
            (
                b.x.fixed_rows::<3>(3).into_owned(),
                b.x.fixed_rows::<3>(6).into_owned(),
                b.x.fixed_rows::<3>(0) - a.x.fixed_rows::<3>(0),
            )
        } else {
            (Vector3::zeros(), nominal_gravity(pre), Vector3::zeros())
        };
        let g_next = if g_next.norm() < 1.0 {
            nominal_gravity(pre)
        } else {
            g_next
        };
        let point = ImuLinearization {
            v_next,
            g_next,
            step_in_b0,
            gyro_bias_rad_s: self.gyro_bias_rad_s,
            gyro_active: self.gyro_active(),
        };
        let fresh = b
            .imu_cache
            .borrow()
            .as_ref()
            .is_some_and(|(at, _)| at.close_to(&point));
        if !fresh {
            let info = imu_info(&ImuFactorInput {
                pre,
                b0_from_bk: &a.b0_from_bk,
                gyro_bias_rad_s: self.gyro_bias_rad_s,
                psi_k: point.gyro_active.then_some((a.psi, a.gyro_lin)),
                v_next,
                g_next,
                step_in_b0,
                attitude_sigma_rad: self.config.attitude_sigma_rad,
            })?;
            *b.imu_cache.borrow_mut() = Some((point, info));
        }
        Ref::filter_map(b.imu_cache.borrow(), |c| c.as_ref().map(|(_, info)| info)).ok()
    }

    /// The AoA rows' σ besides the bearings' own, and their model.
    pub(super) fn aoa_sigmas(&self) -> AoaSigmas {
        let c = &self.config;
        AoaSigmas {
            attitude_rad: c.attitude_sigma_rad,
            elevation_rad: c.elevation_sigma_rad,
            cone: c.cone_rows,
        }
    }

    fn aoa_factors(&self, k: usize) -> impl Iterator<Item = (usize, AoaInfo)> + '_ {
        let f = &self.frames[k];
        let c = &self.config;
        let up = f.up(c.adaptive_weights);
        let gyro = self.gyro_active().then_some((&f.psi, &f.gyro_lin));
        f.bearings
            .iter()
            .filter(|b| b.is_valid())
            .filter_map(move |b| {
                let info = aoa_info(&AoaFactorInput {
                    bearing: b,
                    b0_from_bj: &f.b0_from_bk,
                    up_in_bj: &up,
                    body_from_array: &c.body_from_array,
                    point: self.aoa_point(f, b.ap),
                    gyro,
                    sigmas: self.aoa_sigmas(),
                })?;
                Some((b.ap, info))
            })
    }

    /// The normal equations over the first `n` frames: the prior, and the factors of every frame
    /// (`only_first`: of frame 0 alone, its IMU factor to frame 1 included).
    pub(super) fn assemble(&self, n: usize, only_first: bool) -> ArrowSystem {
        let m = BIAS_DIM + 3 * self.num_aps;
        let mut sys = ArrowSystem::zeros(n, m);
        if n == 0 {
            return sys;
        }
        let pb = self.prior_h.nrows() - FRAME_DIM;
        sys.diag[0] += self.prior_h.fixed_view::<FRAME_DIM, FRAME_DIM>(0, 0);
        sys.frame_border[0]
            .view_mut((0, 0), (FRAME_DIM, pb))
            .add_assign(&self.prior_h.view((0, FRAME_DIM), (FRAME_DIM, pb)));
        sys.corner
            .view_mut((0, 0), (pb, pb))
            .add_assign(&self.prior_h.view((FRAME_DIM, FRAME_DIM), (pb, pb)));
        sys.rhs_frames[0] += self.prior_b.fixed_rows::<FRAME_DIM>(0);
        sys.rhs_border
            .rows_mut(0, pb)
            .add_assign(&self.prior_b.rows(FRAME_DIM, pb));
        let last = if only_first { 1 } else { n };
        for k in 0..last {
            if k + 1 < n
                && let Some(info) = self.imu_factor(k)
            {
                add_imu(&mut sys, k, &info);
            }
            for (l, info) in self.aoa_factors(k) {
                add_aoa(&mut sys, k, ap_offset(l), &info);
            }
        }
        sys
    }
}

fn add_imu(sys: &mut ArrowSystem, k: usize, info: &ImuInfo) {
    sys.diag[k] += info.h_kk;
    sys.diag[k + 1] += info.h_ll;
    sys.lower[k] += info.h_lk;
    sys.frame_border[k]
        .fixed_view_mut::<FRAME_DIM, BIAS_DIM>(0, 0)
        .add_assign(&info.h_kb);
    sys.frame_border[k + 1]
        .fixed_view_mut::<FRAME_DIM, BIAS_DIM>(0, 0)
        .add_assign(&info.h_lb);
    sys.corner
        .view_mut((0, 0), (BIAS_DIM, BIAS_DIM))
        .add_assign(&info.h_bb);
    sys.rhs_frames[k] += info.b_k;
    sys.rhs_frames[k + 1] += info.b_l;
    sys.rhs_border.rows_mut(0, BIAS_DIM).add_assign(&info.b_b);
}

fn add_aoa(sys: &mut ArrowSystem, k: usize, o: usize, info: &AoaInfo) {
    sys.diag[k].fixed_view_mut::<3, 3>(0, 0).add_assign(&info.n);
    sys.corner.fixed_view_mut::<3, 3>(o, o).add_assign(&info.n);
    sys.frame_border[k]
        .fixed_view_mut::<3, 3>(0, o)
        .add_assign(&(-info.n.transpose()));
    sys.rhs_frames[k]
        .fixed_rows_mut::<3>(0)
        .add_assign(&(-info.b_c));
    sys.rhs_border.fixed_rows_mut::<3>(o).add_assign(&info.b_c);
    // The gyro-bias coupling (zero unless the bias is estimated).
    sys.frame_border[k]
        .fixed_view_mut::<3, 3>(0, GYRO)
        .add_assign(&(-info.n_cg));
    sys.corner
        .fixed_view_mut::<3, 3>(o, GYRO)
        .add_assign(&info.n_cg);
    sys.corner
        .fixed_view_mut::<3, 3>(GYRO, o)
        .add_assign(&info.n_cg.transpose());
    sys.corner
        .fixed_view_mut::<3, 3>(GYRO, GYRO)
        .add_assign(&info.n_gg);
    sys.rhs_border
        .fixed_rows_mut::<3>(GYRO)
        .add_assign(&info.b_g);
}
