//! Assembling the window's normal equations from its prior and factors, once for the solve and
//! once (restricted to the oldest frame's factors) for marginalization.

use std::cell::Ref;

use nalgebra::Vector3;

use super::factors::{
    AoaFactorInput, AoaInfo, AoaPoint, AoaSigmas, BIAS_DIM, ImuFactorInput, ImuInfo, aoa_info,
    imu_info,
};
use super::{Frame, SlidingWindow, nominal_gravity};
use crate::fusion::arrow::{ArrowSystem, At};

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
            && self.health.converged_at.is_some()
    }

    /// Where frame `f`'s rows to AP `l` are linearized (module doc of [`super`]): the algebraic
    /// row with the initial range until converged, then the angle at the current solution.
    fn aoa_point(&self, f: &Frame, l: usize) -> AoaPoint {
        let c = &self.config;
        if self.health.converged_at.is_none() || !c.adaptive_weights {
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
        sys.add_prior(&self.prior.h, &self.prior.b);
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

/// The IMU factor between frames `k` and `k + 1`, in information form.
fn add_imu(sys: &mut ArrowSystem, k: usize, info: &ImuInfo) {
    let (f_k, f_l, bias) = (At::Frame(k, 0), At::Frame(k + 1, 0), At::Border(0));
    sys.add_information(f_k, f_k, &info.h_kk);
    sys.add_information(f_l, f_l, &info.h_ll);
    sys.add_information(f_l, f_k, &info.h_lk);
    sys.add_information(f_k, bias, &info.h_kb);
    sys.add_information(f_l, bias, &info.h_lb);
    sys.add_information(bias, bias, &info.h_bb);
    sys.add_rhs(f_k, &info.b_k);
    sys.add_rhs(f_l, &info.b_l);
    sys.add_rhs(bias, &info.b_b);
}

/// An AoA factor of frame `k` on the AP at border offset `o`, in information form: its
/// position rows `[p_k, c]`, and the gyro-bias coupling (zero unless the bias is estimated).
fn add_aoa(sys: &mut ArrowSystem, k: usize, o: usize, info: &AoaInfo) {
    let (p_k, c, gyro) = (At::Frame(k, 0), At::Border(o), At::Border(GYRO));
    sys.add_information(p_k, p_k, &info.n);
    sys.add_information(c, c, &info.n);
    sys.add_information(p_k, c, &(-info.n.transpose()));
    sys.add_rhs(p_k, &(-info.b_c));
    sys.add_rhs(c, &info.b_c);
    sys.add_information(p_k, gyro, &(-info.n_cg));
    sys.add_information(c, gyro, &info.n_cg);
    sys.add_information(gyro, gyro, &info.n_gg);
    sys.add_rhs(gyro, &info.b_g);
}
