//! The window's solve (Gauss–Newton with a line search and a trust region, damped only after a
//! rejected step) and the marginalization of the oldest keyframe.

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector, Vector3};

use crate::fusion::arrow::ArrowSystem;
use crate::fusion::nonlinear::solve::{Keyframe, LAMBDA_FIRST, NonlinearWindow};
use crate::fusion::nonlinear::state::{NavState, STATE_DIM};

/// Why a solve failed (the estimate is left as it was).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SolveError {
    /// The normal equations stayed indefinite under every damping tried.
    #[error("the normal equations are not positive definite")]
    NotPositiveDefinite,
    /// A state became non-finite.
    #[error("the estimate is not finite")]
    NotFinite,
}

/// Fractions of a step tried before the damping is raised.
const STEP_FRACTIONS: [f64; 4] = [1.0, 0.5, 0.25, 0.125];
/// The largest change of one iteration per error-state block `[δθ, δp, δv, δb_g, δb_a]` (rad,
/// m, m/s, rad/s, m/s²); the border (AP coordinates, the barometer offset) takes the position's.
const MAX_STEP: [f64; 5] = [0.2, 2.0, 2.0, 0.02, 0.5];
/// The damping never falls below this (relative to the diagonal: Gauss–Newton in effect).
const LAMBDA_MIN: f64 = 1e-9;
/// An iteration whose increment is below this (relative to the state's scale) ends the solve.
const STEP_TOLERANCE: f64 = 1e-7;

/// What a solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    /// Accepted iterations.
    pub iterations: usize,
    /// Cost before and after (`Σ ρ` + prior, twice the LM objective).
    pub cost_before: f64,
    /// See `cost_before`.
    pub cost_after: f64,
}

struct Snapshot {
    x: Vec<NavState>,
    aps: Vec<Vector3<f64>>,
    baro: Option<f64>,
    bias: Option<f64>,
}

impl NonlinearWindow {
    fn snapshot(&self) -> Snapshot {
        Snapshot {
            x: self.keyframes.iter().map(|k| k.x).collect(),
            aps: self.aps.clone(),
            baro: self.baro.map(|b| b.0),
            bias: self.bias.map(|b| b.0),
        }
    }

    fn restore(&mut self, s: &Snapshot) {
        for (k, x) in self.keyframes.iter_mut().zip(&s.x) {
            k.x = *x;
        }
        self.aps.clone_from(&s.aps);
        if let (Some(b), Some(o)) = (&mut self.baro, s.baro) {
            b.0 = o;
        }
        if let (Some(b), Some(o)) = (&mut self.bias, s.bias) {
            b.0 = o;
        }
    }

    fn is_finite(&self) -> bool {
        self.keyframes.iter().all(|k| k.x.is_finite())
            && self.aps.iter().all(|c| c.iter().all(|v| v.is_finite()))
            && self.baro.is_none_or(|b| b.0.is_finite())
            && self.bias.is_none_or(|b| b.0.is_finite())
    }

    /// Up to `iterations` solver steps (a step that raises the cost at every fraction tried is
    /// undone and the damping raised); the newest keyframe's and the border's covariances come
    /// from an undamped factorization at the final estimate.
    pub fn optimize(&mut self, iterations: usize) -> Result<SolveReport, SolveError> {
        let (mut sys, mut cost, _) = self.build(true);
        let mut report = SolveReport {
            cost_before: cost,
            cost_after: cost,
            iterations: 0,
        };
        let mut lambda = self.lambda;
        let mut tries = 0;
        while report.iterations < iterations && tries < 3 * iterations + 5 {
            tries += 1;
            let Some(sol) = damped(&sys, lambda).into_solution() else {
                lambda = (lambda * 10.0).max(LAMBDA_FIRST);
                if lambda > 1e6 {
                    return Err(SolveError::NotPositiveDefinite);
                }
                continue;
            };
            let before = self.snapshot();
            // A trust region: an undamped step along a direction the data barely see can be
            // huge at no cost; no iteration moves a state further than [`MAX_STEP`].
            let reach = sol
                .frames
                .iter()
                .flat_map(|d| d.iter().enumerate().map(|(i, v)| v.abs() / MAX_STEP[i / 3]))
                .chain(sol.border.iter().map(|v| v.abs() / MAX_STEP[1]))
                .fold(0.0, f64::max);
            let cap = if reach > 1.0 { reach.recip() } else { 1.0 };
            // Along the step, shortened while the cost rises (the direction keeps the
            // Gauss–Newton shape, which damping would not).
            let mut accepted = None;
            for alpha in STEP_FRACTIONS.map(|a| a * cap) {
                if alpha == 1.0 {
                    self.apply(&sol.frames, &sol.border);
                } else {
                    let frames: Vec<_> = sol.frames.iter().map(|d| d * alpha).collect();
                    self.apply(&frames, &(&sol.border * alpha));
                }
                let (new_sys, new_cost, _) = self.build(true);
                // Not above the cost, give or take rounding (the prior's gradient term can make
                // the cost negative: a relative tolerance on `cost` alone would then refuse an
                // equal one).
                if self.is_finite() && new_cost.is_finite() && new_cost <= cost + 1e-12 * cost.abs()
                {
                    accepted = Some((new_sys, new_cost, alpha));
                    break;
                }
                self.restore(&before);
            }
            let Some((new_sys, new_cost, alpha)) = accepted else {
                lambda = (lambda * 10.0).max(LAMBDA_FIRST);
                if lambda > 1e6 {
                    break;
                }
                continue;
            };
            sys = new_sys;
            cost = new_cost;
            report.iterations += 1;
            lambda /= 10.0;
            if lambda < LAMBDA_MIN {
                lambda = LAMBDA_MIN;
            }
            let step = sol.frames.iter().map(|d| d.amax()).fold(0.0, f64::max) * alpha;
            if step < STEP_TOLERANCE && sol.border.amax() * alpha < STEP_TOLERANCE {
                break;
            }
        }
        // The covariances at the final estimate (the loop's factorizations are damped, and at
        // the estimate before each step).
        if let Some(sol) = damped(&sys, 0.0).into_solution() {
            self.covariance.newest = sol.last_frame_covariance;
            self.covariance.border = sol.border_covariance;
            self.covariance.newest_border = sol.last_frame_border_covariance;
        }
        // The next solve starts where this one ended, but never more damped than a new window: a
        // solve that found no lower cost (at its minimum) leaves the damping past 1e6, which
        // would freeze the next solve's new information.
        self.lambda = lambda.min(LAMBDA_FIRST);
        if !self.is_finite() {
            return Err(SolveError::NotFinite);
        }
        report.cost_after = cost;
        Ok(report)
    }

    /// `δ = x ⊟ x_lin` over `[first keyframe, border]` (border entries without a frozen point:
    /// 0).
    pub(in crate::fusion::nonlinear) fn prior_delta(&self) -> DVector<f64> {
        let mut e = DVector::zeros(STATE_DIM + self.border_dim());
        if let Some(k0) = self.keyframes.front() {
            let lin = k0.lin.unwrap_or(k0.x);
            e.rows_mut(0, STATE_DIM).copy_from(&k0.x.boxminus(&lin));
        }
        if let Some((o, Some(l))) = self.baro {
            e[STATE_DIM] = o - l;
        }
        if let Some((b, Some(l))) = self.bias {
            e[STATE_DIM + self.scalars() - 1] = b - l;
        }
        for (l, (c, lin)) in self.aps.iter().zip(&self.ap_lin).enumerate() {
            if let Some(lin) = lin {
                let o = STATE_DIM + self.ap_offset(l);
                e.rows_mut(o, 3).copy_from(&(c - lin));
            }
        }
        e
    }

    /// Adds the prior to `sys`; returns its cost `δᵀHδ + 2gᵀδ`.
    pub(in crate::fusion::nonlinear) fn add_prior(&self, sys: &mut ArrowSystem<STATE_DIM>) -> f64 {
        let dim = self.prior.h.nrows();
        let full = STATE_DIM + self.border_dim();
        let mut e = self.prior_delta();
        e = e.rows(0, dim.min(full)).into_owned();
        let he = &self.prior.h * &e;
        let grad = &he + &self.prior.g;
        if sys.frames() == 0 {
            return 0.0;
        }
        sys.add_prior(&self.prior.h, &-grad);
        e.dot(&he) + 2.0 * e.dot(&self.prior.g)
    }

    /// Marginalizes the oldest keyframe into the prior on `[next keyframe, border]` (module doc
    /// of [`crate::fusion::nonlinear::solve`]): the Schur complement of only the factors that touch it, with the
    /// states it leaves in the prior frozen at their current estimate for every later Jacobian.
    pub fn marginalize_oldest(&mut self) {
        if self.keyframes.len() < 2 {
            return;
        }
        // Freeze the linearization points of what enters the prior.
        if let Some(k1) = self.keyframes.get_mut(1) {
            k1.lin.get_or_insert(k1.x);
        }
        let mut has_altitude = false;
        let mut has_bearing = false;
        if let Some(k0) = self.keyframes.front() {
            for f in &k0.frames {
                has_altitude |= f.altitude_m.is_some();
                has_bearing |= !f.bearings.is_empty();
                for b in &f.bearings {
                    if let (Some(c), Some(lin), Some(true)) = (
                        self.aps.get(b.ap),
                        self.ap_lin.get_mut(b.ap),
                        self.placed.get(b.ap),
                    ) {
                        lin.get_or_insert(*c);
                    }
                }
            }
        }
        // An anchor on it goes into the prior with its AP.
        let t0 = self.keyframes.front().map(|k| k.x.t);
        for a in self.anchors.iter().filter(|a| Some(a.t) == t0) {
            if let (Some(c), Some(lin)) = (self.aps.get(a.l), self.ap_lin.get_mut(a.l)) {
                lin.get_or_insert(*c);
            }
        }
        if let Some(b) = &mut self.baro
            && (has_altitude || self.prior.h.nrows() > STATE_DIM)
        {
            b.1.get_or_insert(b.0);
        }
        if let Some(b) = &mut self.bias
            && (has_bearing || self.prior.h.nrows() > STATE_DIM)
        {
            b.1.get_or_insert(b.0);
        }
        // The local problem: the oldest keyframe, the next one without its own measurements.
        let mut rest: VecDeque<Keyframe> = std::mem::take(&mut self.keyframes);
        let (Some(k0), Some(k1)) = (rest.pop_front(), rest.front().cloned()) else {
            return;
        };
        let dt_s = k1.x.t.secs_since(k0.x.t);
        self.keyframes = VecDeque::from([
            k0,
            Keyframe {
                frames: Vec::new(),
                still: false,
                ..k1
            },
        ]);
        let (sys, _, _) = self.build(true);
        self.keyframes = rest;
        self.anchors.retain(|a| Some(a.t) != t0);
        let (h, rhs) = sys.to_dense();
        let dim = h.nrows();
        let s = STATE_DIM;
        let r = dim - s;
        let h00 = h.view((0, 0), (s, s)).into_owned();
        let h0r = h.view((0, s), (s, r)).into_owned();
        let inv00 = match h00.clone().cholesky() {
            Some(c) => c.inverse(),
            None => h00
                .pseudo_inverse(1e-12)
                .unwrap_or_else(|_| DMatrix::zeros(s, s)),
        };
        let k = h0r.transpose() * &inv00;
        let mut new_h = h.view((s, s), (r, r)).into_owned() - &k * &h0r;
        new_h = (&new_h + new_h.transpose()) * 0.5;
        // rhs = −gradient at the current estimate; move it to the frozen points.
        let new_rhs = rhs.rows(s, r).into_owned() - &k * rhs.rows(0, s);
        let e = self.prior_delta();
        let e = e.rows(0, r.min(e.nrows())).into_owned();
        self.prior.g = -new_rhs - &new_h * e;
        self.prior.h = new_h;
        self.counts.marginalized += 1;
        self.inflate_baro_offset(dt_s);
    }

    /// The barometer offset wanders (a random walk): its prior variance grows by `q Δt`
    /// (Woodbury on the information form, mean kept).
    fn inflate_baro_offset(&mut self, dt_s: f64) {
        let q = self.model.config.baro_offset_walk_m_sqrt_s.powi(2) * dt_s.max(0.0);
        let i = STATE_DIM;
        if self.baro.is_none() || q <= 0.0 || self.prior.h.nrows() <= i {
            return;
        }
        let hu = self.prior.h.column(i).into_owned();
        let d = 1.0 / q + hu[i];
        if d <= 0.0 {
            return;
        }
        let ug = self.prior.g[i];
        self.prior.h -= &hu * hu.transpose() / d;
        self.prior.g -= &hu * (ug / d);
    }
}

/// `sys` with `λ · diag` added (at least a tiny absolute floor, for directions nothing
/// constrains).
fn damped(sys: &ArrowSystem<STATE_DIM>, lambda: f64) -> ArrowSystem<STATE_DIM> {
    sys.damped(lambda, 1e-12)
}
