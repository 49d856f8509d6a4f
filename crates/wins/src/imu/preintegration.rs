//! IMU preintegration between consecutive PAoA frames (paper `eqn:alpha`, `eqn:beta`,
//! `eqn:rotation`; Forster et al. RSS 2015, Lupton & Sukkarieh TRO 2012).
//!
//! For frames `k` at `t_k` and `k+1` at `t_{k+1}`, with `R_t = R_{b_k}^{b_t}` the rotation from the
//! body at `t` into `b_k`, `ω̂ = ω − b_g` and `f̂ = f − b_a` (specific force):
//!
//! ```text
//! ΔR = R_{b_{k+1}}^{b_k} = ∫ R_t [ω̂_t]× dt        (eqn:rotation, as the ODE Ṙ = R [ω̂]×)
//! β  = ∫ R_t f̂_t dt                              (eqn:beta)
//! α  = ∬ R_t f̂_t dt²                             (eqn:alpha)
//! ```
//!
//! so that, with the paper's upward gravity `g^{b_k}` (+9.8 along body z at rest, level) and
//! `Δt = t_{k+1} − t_k`: `α = R_{b_k}^{b_0}ᵀ(p_{k+1} − p_k) − v_k Δt + g^{b_k} Δt²/2` and
//! `β = ΔR v_{k+1} − v_k + g^{b_k} Δt` (`eqn:imumodel`).
//!
//! **Integration**: the signal is linear between samples; each sub-interval `[t_0, t_1]` (between
//! samples, or ending at a cut) uses the mean rate `ω̄` and force `f̄` of its endpoints, the
//! rotation exactly (`ΔR ← ΔR Exp(ω̄ h)`) and the force rotated by the mid-interval rotation
//! `R_mid = ΔR Exp(ω̄ h / 2)`.
//!
//! **Errors** (true = estimate + δ; rotation on the right, `ΔR_true = ΔR̂ Exp(δθ)`): the state
//! `δx = [δα, δβ, δθ]` obeys `δx' = F δx + G [δf̄; δω̄]` with, per sub-interval,
//!
//! ```text
//! E = Exp(ω̄h), E½ = Exp(ω̄h/2), A = R_mid [f̄]×
//! F = | I  hI  −h²/2 A E½ᵀ |     G = | h²/2 R_mid  −h²/2 A J_r(ω̄h/2) h/2 |
//!     | 0   I  −h A E½ᵀ    |         | h R_mid     −h A J_r(ω̄h/2) h/2    |
//!     | 0   0   Eᵀ         |         | 0           J_r(ω̄h) h             |
//! ```
//!
//! **Noise**: each sample carries white noise of variance `σ_c²/T_s` (`T_s` the sample period;
//! docs/DESIGN.md §2). A sub-interval's input noise is the mean of its two endpoints' noises, so
//! consecutive sub-intervals share a sample; the covariance carries that correlation exactly
//! (cross term `C = Cov(δx, η_end)`). A sample interpolated at a cut is treated as having fresh
//! noise of the full variance (slightly conservative), and intervals are independent of each
//! other. Bias random walk is not part of the interval covariance (the estimator has no bias
//! states; biases enter through the Jacobians below).
//!
//! **Gaps**: samples further apart than a set limit are integrated the same way, with the
//! covariance of the motion the IMU did not see added ([`super::gap`]).
//!
//! **Bias Jacobians**: `J = ∂[α, β, θ]/∂[b_a, b_g]`, propagated as `J' = F J − G`, so that a later
//! stage corrects a bias estimate without re-integrating: [`Preintegrated::corrected`].

use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};

use super::{ImuBiases, ImuGap, ImuSample};
use crate::rig::ImuNoise;
use crate::so3::{exp, right_jacobian};
use crate::time::Timestamp;

/// 9×9 covariance of `[δα, δβ, δθ]`.
pub type Covariance9 = SMatrix<f64, 9, 9>;
/// 9×6 Jacobian of `[α, β, θ]` with respect to `[b_a, b_g]`.
pub type BiasJacobian = SMatrix<f64, 9, 6>;

/// Why a sample or a cut was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PreintegrationError {
    /// A sample with a NaN or infinite component.
    #[error("IMU sample at {t_ns} ns has a non-finite value")]
    NonFinite {
        /// Its time, ns.
        t_ns: i64,
    },
    /// A sample older than the previous one.
    #[error("IMU sample at {t_ns} ns is older than the previous one at {last_ns} ns")]
    OutOfOrder {
        /// Its time, ns.
        t_ns: i64,
        /// The previous sample's time, ns.
        last_ns: i64,
    },
    /// A cut outside `[last sample, next sample]`.
    #[error("cannot cut at {t_ns} ns: the samples around it are at {last_ns} and {next_ns} ns")]
    CutOutsideSamples {
        /// The cut, ns.
        t_ns: i64,
        /// The last integrated sample, ns.
        last_ns: i64,
        /// The sample after the cut, ns.
        next_ns: i64,
    },
    /// A cut before any sample arrived.
    #[error("cannot cut at {t_ns} ns: no IMU sample yet")]
    NoSamples {
        /// The cut, ns.
        t_ns: i64,
    },
    /// [`Preintegrated::append`] of an interval that does not start where this one ends.
    #[error(
        "cannot append an interval starting at {next_start_ns} ns to one ending at {end_ns} ns"
    )]
    NotContiguous {
        /// End of the interval appended to, ns.
        end_ns: i64,
        /// Start of the appended interval, ns.
        next_start_ns: i64,
    },
}

/// The preintegrated IMU measurement between two frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Preintegrated {
    /// Start of the interval (frame `k`).
    pub start: Timestamp,
    /// End of the interval (frame `k+1`).
    pub end: Timestamp,
    /// α (`eqn:alpha`), in `b_k`, m.
    pub alpha: Vector3<f64>,
    /// β (`eqn:beta`), in `b_k`, m/s.
    pub beta: Vector3<f64>,
    /// ΔR = `R_{b_{k+1}}^{b_k}` (`eqn:rotation`): maps `b_{k+1}` vectors into `b_k`.
    pub bk_from_bk1: UnitQuaternion<f64>,
    /// Covariance of `[δα, δβ, δθ]` (rotation error on the right).
    pub covariance: Covariance9,
    /// `∂[α, β, θ]/∂[b_a, b_g]` at [`Preintegrated::bias`].
    pub jacobian_bias: BiasJacobian,
    /// The bias estimate the measurements were corrected with.
    pub bias: ImuBiases,
}

impl Preintegrated {
    /// An empty interval starting (and ending) at `t`.
    pub fn empty(t: Timestamp, bias: ImuBiases) -> Self {
        Self {
            start: t,
            end: t,
            alpha: Vector3::zeros(),
            beta: Vector3::zeros(),
            bk_from_bk1: UnitQuaternion::identity(),
            covariance: Covariance9::zeros(),
            jacobian_bias: BiasJacobian::zeros(),
            bias,
        }
    }

    /// Interval length, s.
    pub fn dt_s(&self) -> f64 {
        self.end.secs_since(self.start)
    }

    /// α, β, ΔR for another bias estimate, to first order through [`Self::jacobian_bias`]
    /// (Forster et al. 2015, eq. 44): `ΔR(b) = ΔR̂ Exp(J_θg δb_g)`.
    pub fn corrected(&self, bias: &ImuBiases) -> (Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>) {
        let mut db = SVector::<f64, 6>::zeros();
        db.fixed_rows_mut::<3>(0)
            .copy_from(&(bias.accel_m_s2 - self.bias.accel_m_s2));
        db.fixed_rows_mut::<3>(3)
            .copy_from(&(bias.gyro_rad_s - self.bias.gyro_rad_s));
        let d = self.jacobian_bias * db;
        let alpha = self.alpha + d.fixed_rows::<3>(0);
        let beta = self.beta + d.fixed_rows::<3>(3);
        let rot = self.bk_from_bk1 * exp(&d.fixed_rows::<3>(6).into_owned());
        (alpha, beta, rot)
    }

    /// Extends this interval `[t_0, t_1]` by `next` over `[t_1, t_2]`, so that it covers
    /// `[t_0, t_2]` (1 = `self`, 2 = `next`, `Δt_2 = next.dt_s()`):
    ///
    /// ```text
    /// α_13 = α_1 + β_1 Δt_2 + ΔR_1 α_2      β_13 = β_1 + ΔR_1 β_2      ΔR_13 = ΔR_1 ΔR_2
    /// ```
    ///
    /// Errors (right perturbation, `[δα, δβ, δθ]`) compose as `δx_13 = A δx_1 + B δx_2` with
    ///
    /// ```text
    /// A = | I  Δt_2 I  −ΔR_1 [α_2]× |     B = | ΔR_1  0     0 |
    ///     | 0  I       −ΔR_1 [β_2]× |         | 0     ΔR_1  0 |
    ///     | 0  0        ΔR_2ᵀ       |         | 0     0     I |
    /// ```
    ///
    /// so `Σ_13 = A Σ_1 Aᵀ + B Σ_2 Bᵀ` (the two intervals' noises independent) and
    /// `J_13 = A J_1 + B J_2`. If `next` was integrated with another bias estimate, its α, β, ΔR
    /// are first moved to `self.bias` with [`Self::corrected`] (its covariance and bias Jacobian
    /// are kept as they are: first order). `self` is left unchanged on error.
    ///
    /// Within one [`Preintegrator`] interval the sample at a cut would feed both sides' endpoint
    /// noise; appended intervals treat those as independent, so `Σ_13` is slightly smaller (by
    /// about `1/(2N)` of the total per cut, `N` samples) than integrating `[t_0, t_2]` in one go.
    pub fn append(&mut self, next: &Preintegrated) -> Result<(), PreintegrationError> {
        if next.start != self.end {
            return Err(PreintegrationError::NotContiguous {
                end_ns: self.end.0,
                next_start_ns: next.start.0,
            });
        }
        let (alpha2, beta2, rot2) = if next.bias == self.bias {
            (next.alpha, next.beta, next.bk_from_bk1)
        } else {
            next.corrected(&self.bias)
        };
        let dt2 = next.dt_s();
        let r1 = self.bk_from_bk1.to_rotation_matrix().into_inner();
        let r2 = rot2.to_rotation_matrix().into_inner();

        let mut a = Covariance9::identity();
        a.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(Matrix3::identity() * dt2));
        a.fixed_view_mut::<3, 3>(0, 6)
            .copy_from(&(-r1 * alpha2.cross_matrix()));
        a.fixed_view_mut::<3, 3>(3, 6)
            .copy_from(&(-r1 * beta2.cross_matrix()));
        a.fixed_view_mut::<3, 3>(6, 6).copy_from(&r2.transpose());
        let mut b = Covariance9::identity();
        b.fixed_view_mut::<3, 3>(0, 0).copy_from(&r1);
        b.fixed_view_mut::<3, 3>(3, 3).copy_from(&r1);

        self.alpha += self.beta * dt2 + r1 * alpha2;
        self.beta += r1 * beta2;
        self.bk_from_bk1 = UnitQuaternion::new_normalize(*(self.bk_from_bk1 * rot2).quaternion());
        let cov = a * self.covariance * a.transpose() + b * next.covariance * b.transpose();
        self.covariance = (cov + cov.transpose()) * 0.5;
        self.jacobian_bias = a * self.jacobian_bias + b * next.jacobian_bias;
        self.end = next.end;
        Ok(())
    }
}

/// Integrates a stream of IMU samples and cuts it into [`Preintegrated`] intervals at frame
/// times.
///
/// Push samples in time order with [`Self::push`]; to end an interval at a frame time `t` that
/// lies between the last pushed sample and the next one, call [`Self::cut`] with that next
/// sample *before* pushing it (the signal is interpolated at `t`).
#[derive(Clone, Debug)]
pub struct Preintegrator {
    noise: ImuNoise,
    bias: ImuBiases,
    last: Option<ImuSample>,
    /// Spacing of the last two pushed samples, s (the sample period for the noise variance).
    period_s: Option<f64>,
    /// How a gap between samples is integrated (`None`: as any other spacing).
    gap: Option<ImuGap>,
    running: Preintegrated,
    /// `Cov(δx, η)` with the noise of the last endpoint.
    cross: BiasJacobian,
}

impl Preintegrator {
    /// An integrator with the given noise densities and bias estimate.
    pub fn new(noise: ImuNoise, bias: ImuBiases) -> Self {
        Self {
            noise,
            bias,
            last: None,
            period_s: None,
            gap: None,
            running: Preintegrated::empty(Timestamp(0), bias),
            cross: BiasJacobian::zeros(),
        }
    }

    /// The same integrator, with samples further apart than `gap.max_s` integrated as a gap:
    /// their interval's covariance grows by [`ImuGap::covariance`].
    pub fn with_gap(mut self, gap: ImuGap) -> Self {
        self.gap = Some(gap);
        self
    }

    /// When `s` comes after a gap ([`Self::with_gap`]) since the last sample: the gap's start,
    /// the last sample's time.
    pub fn gap_before(&self, s: &ImuSample) -> Option<Timestamp> {
        let gap = self.gap?;
        let last = self.last?;
        gap.is_gap(s.t.secs_since(last.t)).then_some(last.t)
    }

    /// Sets the white-noise densities, used from the next sample on (the covariance already
    /// integrated keeps the densities it was integrated with); the random walks are not used here.
    pub fn set_noise(&mut self, noise: ImuNoise) {
        self.noise = noise;
    }

    /// The bias estimate used from the next interval on.
    pub fn bias(&self) -> ImuBiases {
        self.bias
    }

    /// Sets the bias estimate; takes effect at the next cut (the running interval keeps its
    /// linearization point, use [`Preintegrated::corrected`]).
    pub fn set_bias(&mut self, bias: ImuBiases) {
        self.bias = bias;
    }

    /// The last pushed sample.
    pub fn last_sample(&self) -> Option<&ImuSample> {
        self.last.as_ref()
    }

    /// The interval integrated since the last cut (for propagating a pose at IMU rate).
    pub fn running(&self) -> &Preintegrated {
        &self.running
    }

    /// Whether [`Self::push`] would take `s`: finite values, not older than the last sample.
    pub fn check(&self, s: &ImuSample) -> Result<(), PreintegrationError> {
        check_finite(s)?;
        match self.last {
            Some(last) if s.t < last.t => Err(PreintegrationError::OutOfOrder {
                t_ns: s.t.0,
                last_ns: last.t.0,
            }),
            _ => Ok(()),
        }
    }

    /// Integrates up to sample `s`.
    pub fn push(&mut self, s: &ImuSample) -> Result<(), PreintegrationError> {
        self.check(s)?;
        let Some(last) = self.last else {
            self.last = Some(*s);
            self.running = Preintegrated::empty(s.t, self.bias);
            self.cross = BiasJacobian::zeros();
            return Ok(());
        };
        if s.t > last.t {
            self.period_s = Some(s.t.secs_since(last.t));
            let in_gap = self.gap_before(s).is_some();
            self.step(&last, s, in_gap);
        }
        self.last = Some(*s);
        Ok(())
    }

    /// Ends the running interval at `t` (with `last ≤ t ≤ next.t`), returns it, and starts the
    /// next one at `t`. `next` is the first sample after `t`; it is not integrated past `t`
    /// (push it afterwards).
    pub fn cut(
        &mut self,
        t: Timestamp,
        next: &ImuSample,
    ) -> Result<Preintegrated, PreintegrationError> {
        check_finite(next)?;
        let Some(last) = self.last else {
            return Err(PreintegrationError::NoSamples { t_ns: t.0 });
        };
        if t < last.t || t > next.t {
            return Err(PreintegrationError::CutOutsideSamples {
                t_ns: t.0,
                last_ns: last.t.0,
                next_ns: next.t.0,
            });
        }
        let at_cut = interpolate(&last, next, t);
        if next.t > last.t {
            self.period_s = Some(next.t.secs_since(last.t));
        }
        if t > last.t {
            let in_gap = self.gap_before(next).is_some();
            self.step(&last, &at_cut, in_gap);
        }
        let done = std::mem::replace(&mut self.running, Preintegrated::empty(t, self.bias));
        self.cross = BiasJacobian::zeros();
        self.last = Some(at_cut);
        Ok(done)
    }

    /// One sub-interval from `a` to `b` (see the module doc for F and G); `in_gap`: part of a
    /// gap between samples, whose covariance is added ([`ImuGap`]).
    fn step(&mut self, a: &ImuSample, b: &ImuSample, in_gap: bool) {
        let h = b.t.secs_since(a.t);
        let q = self.sample_noise_variances();
        let pre = &mut self.running;
        let w = (a.gyro_rad_s + b.gyro_rad_s) * 0.5 - pre.bias.gyro_rad_s;
        let f = (a.accel_m_s2 + b.accel_m_s2) * 0.5 - pre.bias.accel_m_s2;
        let phi = w * h;
        let e = exp(&phi).to_rotation_matrix().into_inner();
        let e_half = exp(&(phi * 0.5)).to_rotation_matrix().into_inner();
        let r_i = pre.bk_from_bk1.to_rotation_matrix().into_inner();
        let r_mid = r_i * e_half;
        let a_mat = r_mid * f.cross_matrix();

        let mut fm = Covariance9::identity();
        fm.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(Matrix3::identity() * h));
        fm.fixed_view_mut::<3, 3>(0, 6)
            .copy_from(&(-0.5 * h * h * a_mat * e_half.transpose()));
        fm.fixed_view_mut::<3, 3>(3, 6)
            .copy_from(&(-h * a_mat * e_half.transpose()));
        fm.fixed_view_mut::<3, 3>(6, 6).copy_from(&e.transpose());
        let mut gm = BiasJacobian::zeros();
        let jr_half = right_jacobian(&(phi * 0.5)) * (0.5 * h);
        gm.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(0.5 * h * h * r_mid));
        gm.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-0.5 * h * h * a_mat * jr_half));
        gm.fixed_view_mut::<3, 3>(3, 0).copy_from(&(h * r_mid));
        gm.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(-h * a_mat * jr_half));
        gm.fixed_view_mut::<3, 3>(6, 3)
            .copy_from(&(right_jacobian(&phi) * h));

        // Mean.
        let df = r_mid * f * h;
        pre.alpha += pre.beta * h + df * (0.5 * h);
        pre.beta += df;
        pre.bk_from_bk1 =
            UnitQuaternion::new_normalize(*(pre.bk_from_bk1 * exp(&phi)).quaternion());
        pre.end = b.t;

        // Covariance with endpoint-shared noise: δx' = F δx + G (η_a + η_b)/2.
        let gq = gm * SMatrix::<f64, 6, 6>::from_diagonal(&q);
        let fc_gt = fm * self.cross * gm.transpose();
        pre.covariance = fm * pre.covariance * fm.transpose()
            + gq * gm.transpose() * 0.5
            + (fc_gt + fc_gt.transpose()) * 0.5;
        self.cross = gq * 0.5;
        if let Some(gap) = self.gap.filter(|_| in_gap) {
            pre.covariance += gap.covariance(h);
        }

        // Bias Jacobians: the bias enters like the input error with the opposite sign.
        pre.jacobian_bias = fm * pre.jacobian_bias - gm;
    }

    /// Per-sample white-noise variances `[σ_a²/T_s ×3, σ_g²/T_s ×3]`.
    fn sample_noise_variances(&self) -> SVector<f64, 6> {
        let ts = self.period_s.unwrap_or(0.005).max(1e-6);
        let va = self.noise.accel_noise_density_m_s2_sqrt_hz.powi(2) / ts;
        let vg = self.noise.gyro_noise_density_rad_s_sqrt_hz.powi(2) / ts;
        SVector::<f64, 6>::from_column_slice(&[va, va, va, vg, vg, vg])
    }
}

fn check_finite(s: &ImuSample) -> Result<(), PreintegrationError> {
    if s.gyro_rad_s
        .iter()
        .chain(s.accel_m_s2.iter())
        .all(|x| x.is_finite())
    {
        Ok(())
    } else {
        Err(PreintegrationError::NonFinite { t_ns: s.t.0 })
    }
}

/// The linearly interpolated sample at `t` (`a.t ≤ t ≤ b.t`).
fn interpolate(a: &ImuSample, b: &ImuSample, t: Timestamp) -> ImuSample {
    let span = (b.t.0 - a.t.0) as f64;
    let w = if span > 0.0 {
        (t.0 - a.t.0) as f64 / span
    } else {
        1.0
    };
    ImuSample {
        t,
        gyro_rad_s: a.gyro_rad_s.lerp(&b.gyro_rad_s, w),
        accel_m_s2: a.accel_m_s2.lerp(&b.accel_m_s2, w),
    }
}

#[cfg(test)]
mod tests;
