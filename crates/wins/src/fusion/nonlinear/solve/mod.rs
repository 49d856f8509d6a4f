//! The nonlinear sliding window: keyframes, APs, the barometer offset and the marginalization
//! prior, solved (`solve`) on the block-arrow normal equations
//! ([`crate::fusion::arrow`] with 15-state frames).
//!
//! **Border**: `[o (when there is a barometer), β (when estimated), c_0, c_1, …]`, so an AP seen
//! later appends. `β` is a common offset of every bearing's `sin θ`: what an error `Δφ` in the
//! receive chains' uniform phase step does to a linear array (`Δ sin θ = Δφ·λ/(2πd)`, the same for
//! every path and AP; [`crate::pipeline::chains`]). The cone residual becomes
//! `s − (sin θ_measured − β)`, `∂r/∂β = 1`.
//!
//! **First-estimate Jacobians** (Huang, Mourikis, Roumeliotis 2008; OpenVINS): once a state
//! takes part in the marginalization prior (the second keyframe when the oldest leaves, every AP
//! and the barometer offset the leaving keyframe saw), its linearization point is frozen: every
//! factor's Jacobian with respect to it is evaluated there, while residuals use the current
//! estimate. Every factor then sees each state at one point, so the window's information has the
//! nullspace of the true system (translation and yaw about the vertical, 4 directions) and the
//! prior gains no information it does not have ([`NonlinearWindow::nullspace`], tested).
//!
//! The prior is `½ δᵀ H δ + gᵀ δ` with `δ = x ⊟ x_lin` over `[first keyframe, border]`.

pub(in crate::fusion::nonlinear) mod aps;
mod build;
pub mod fit;
pub(in crate::fusion::nonlinear) mod nullspace;
pub mod optimize;
mod predict;
pub mod shares;

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector, Isometry3, Vector3};

use crate::fusion::arrow::BorderTOf;
use crate::fusion::bearing::Bearing;
use crate::fusion::nonlinear::config::NonlinearConfig;
use crate::fusion::nonlinear::factors::imu::imu_information;
use crate::fusion::nonlinear::factors::range_anchor::RangeAnchor;
pub use crate::fusion::nonlinear::solve::fit::FitStats;
use crate::fusion::nonlinear::state::{Mat15, NavState, STATE_DIM, Vec15};
use crate::imu::Preintegrated;
use crate::rig::ImuNoise;

/// Prior information on each coordinate of an AP not yet placed, 1/m² (σ = 1000 m).
pub const PLACEHOLDER_INFORMATION: f64 = 1e-6;

/// LM damping of a new window, and the least after a rejected step, relative to the diagonal.
/// Each accepted step divides it by 10, down to a floor where it is Gauss–Newton in effect, and
/// the next solve starts where the last ended, never above this: the IMU factors make the
/// window stiff (their information is many orders above the bearings'), and a damping relative
/// to the diagonal that stayed on would freeze exactly the motions only the bearings see, the
/// trajectory's shifts the IMU cannot.
pub(super) const LAMBDA_FIRST: f64 = 1e-4;

/// Measurements at one instant inside a keyframe's interval.
#[derive(Clone, Debug)]
pub struct SubFrame {
    /// IMU from the keyframe to this instant (empty at the keyframe itself).
    pub partial: Preintegrated,
    /// Bearings measured then.
    pub bearings: Vec<Bearing>,
    /// Barometer altitude then, m.
    pub altitude_m: Option<f64>,
}

#[derive(Clone, Debug)]
pub(super) struct Keyframe {
    pub(super) x: NavState,
    /// The frozen linearization point (first-estimate Jacobians), once in the prior.
    pub(super) lin: Option<NavState>,
    /// IMU interval from the previous keyframe and its information.
    pub(super) from_prev: Option<(Preintegrated, Mat15)>,
    pub(super) frames: Vec<SubFrame>,
    /// Held at zero velocity ([`crate::fusion::nonlinear::factors::zero_velocity`]).
    pub(super) still: bool,
}

impl Keyframe {
    pub(super) fn lin_or_current(&self, fej: bool) -> NavState {
        match self.lin {
            Some(l) if fej => l,
            _ => self.x,
        }
    }
}

/// What the window's factors are computed with: settings, gravity, the IMU's noise, the
/// array's mounting, and whether Jacobians are taken at the first estimates.
#[derive(Clone, Debug)]
pub(in crate::fusion::nonlinear) struct Model {
    pub(in crate::fusion::nonlinear) config: NonlinearConfig,
    pub(in crate::fusion::nonlinear) gravity_m_s2: f64,
    pub(in crate::fusion::nonlinear) imu_noise: ImuNoise,
    pub(in crate::fusion::nonlinear) body_from_array: Isometry3<f64>,
    /// First-estimate Jacobians on (off only to show what they prevent).
    pub(in crate::fusion::nonlinear) fej: bool,
}

/// The marginalization prior `½ δᵀ H δ + gᵀ δ` over `[first keyframe, border]` (module doc).
#[derive(Clone, Debug)]
pub(in crate::fusion::nonlinear) struct Prior {
    pub(in crate::fusion::nonlinear) h: DMatrix<f64>,
    pub(in crate::fusion::nonlinear) g: DVector<f64>,
}

/// The covariances of the last solve.
#[derive(Clone, Debug)]
pub(in crate::fusion::nonlinear) struct Covariances {
    /// Of the newest keyframe's error state.
    pub(in crate::fusion::nonlinear) newest: Mat15,
    /// Of the border.
    pub(in crate::fusion::nonlinear) border: DMatrix<f64>,
    /// Between the newest keyframe (rows) and the border (columns).
    pub(in crate::fusion::nonlinear) newest_border: BorderTOf<STATE_DIM>,
}

/// What the window has done with its inputs.
#[derive(Clone, Copy, Debug, Default)]
pub(in crate::fusion::nonlinear) struct Counts {
    /// Keyframes marginalized.
    pub(in crate::fusion::nonlinear) marginalized: usize,
    /// Bearings to an AP without a state.
    pub(in crate::fusion::nonlinear) skipped_bearings: u64,
}

/// The window (module doc).
#[derive(Clone, Debug)]
pub struct NonlinearWindow {
    pub(in crate::fusion::nonlinear) model: Model,
    pub(in crate::fusion::nonlinear) keyframes: VecDeque<Keyframe>,
    pub(in crate::fusion::nonlinear) aps: Vec<Vector3<f64>>,
    pub(in crate::fusion::nonlinear) ap_lin: Vec<Option<Vector3<f64>>>,
    /// Whether AP `l` is placed; an AP not yet placed holds a placeholder (its bearings are
    /// skipped and a vanishing prior keeps the system regular): `aps`.
    pub(in crate::fusion::nonlinear) placed: Vec<bool>,
    /// Barometer offset and its frozen point, when the window has a barometer.
    pub(in crate::fusion::nonlinear) baro: Option<(f64, Option<f64>)>,
    /// The bearings' common `sin θ` offset β and its frozen point, when estimated.
    pub(in crate::fusion::nonlinear) bias: Option<(f64, Option<f64>)>,
    pub(in crate::fusion::nonlinear) prior: Prior,
    pub(in crate::fusion::nonlinear) covariance: Covariances,
    pub(in crate::fusion::nonlinear) counts: Counts,
    /// The Levenberg–Marquardt damping the last solve ended with (the next one starts there).
    pub(in crate::fusion::nonlinear) lambda: f64,
    /// Range anchors on the first keyframe (`factors::range_anchor`).
    pub(in crate::fusion::nonlinear) anchors: Vec<RangeAnchor>,
}

impl NonlinearWindow {
    /// A window starting at keyframe `x0` with a prior on it (`prior_h`, 15 × 15, information of
    /// `x0 ⊟ x0`; the gauge and what the start knows), APs at `aps` (`None`: not placed yet), and
    /// a barometer offset when `baro_offset_m` is given.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: NonlinearConfig,
        gravity_m_s2: f64,
        imu_noise: ImuNoise,
        body_from_array: Isometry3<f64>,
        x0: NavState,
        frames0: Vec<SubFrame>,
        prior_h: &Mat15,
        aps: Vec<Option<Vector3<f64>>>,
        baro_offset_m: Option<f64>,
        sin_bias: Option<(f64, f64)>,
    ) -> Self {
        let nb = usize::from(baro_offset_m.is_some()) + usize::from(sin_bias.is_some());
        let dim = STATE_DIM + nb + 3 * aps.len();
        let mut h = DMatrix::zeros(dim, dim);
        h.view_mut((0, 0), (STATE_DIM, STATE_DIM))
            .copy_from(prior_h);
        for (l, c) in aps.iter().enumerate() {
            if c.is_none() {
                let o = STATE_DIM + nb + 3 * l;
                h.view_mut((o, o), (3, 3))
                    .fill_diagonal(PLACEHOLDER_INFORMATION);
            }
        }
        if let Some((_, sigma)) = sin_bias {
            h[(STATE_DIM + nb - 1, STATE_DIM + nb - 1)] = sigma.max(1e-9).powi(-2);
        }
        let n_aps = aps.len();
        Self {
            model: Model {
                config,
                gravity_m_s2,
                imu_noise,
                body_from_array,
                fej: true,
            },
            keyframes: VecDeque::from([Keyframe {
                x: x0,
                lin: Some(x0),
                from_prev: None,
                frames: frames0,
                still: false,
            }]),
            ap_lin: vec![None; n_aps],
            placed: aps.iter().map(Option::is_some).collect(),
            aps: aps
                .into_iter()
                .map(|c| c.unwrap_or_else(Vector3::zeros))
                .collect(),
            baro: baro_offset_m.map(|o| (o, None)),
            // Its prior is centred on the value given: the point is fixed from the start.
            bias: sin_bias.map(|(b, _)| (b, Some(b))),
            prior: Prior {
                h,
                g: DVector::zeros(dim),
            },
            covariance: Covariances {
                newest: Mat15::identity(),
                border: DMatrix::zeros(dim - STATE_DIM, dim - STATE_DIM),
                newest_border: BorderTOf::<STATE_DIM>::zeros(dim - STATE_DIM),
            },
            counts: Counts::default(),
            lambda: LAMBDA_FIRST,
            anchors: Vec::new(),
        }
    }

    /// The same window with first-estimate Jacobians off (every Jacobian at the current
    /// estimate): only to show what they prevent.
    pub fn without_fej(mut self) -> Self {
        self.model.fej = false;
        self
    }

    /// Replaces every keyframe's state by `f(state)` and every AP by `g(AP)` (tests: a start
    /// away from the truth).
    #[doc(hidden)]
    pub fn perturb_for_test(
        &mut self,
        f: &dyn Fn(&NavState) -> NavState,
        g: &dyn Fn(Vector3<f64>) -> Vector3<f64>,
    ) {
        for k in &mut self.keyframes {
            k.x = f(&k.x);
        }
        for c in &mut self.aps {
            *c = g(*c);
        }
    }

    /// Border offset of AP `l`.
    pub(super) fn ap_offset(&self, l: usize) -> usize {
        self.scalars() + 3 * l
    }

    /// Border size (barometer offset and AP coordinates).
    pub fn border_dim(&self) -> usize {
        self.scalars() + 3 * self.aps.len()
    }

    /// Appends keyframe `x` (its initial value, usually the IMU's prediction) with the IMU
    /// interval from the newest keyframe and the measurements tied to it. `None` when the
    /// interval's covariance cannot be inverted.
    pub fn push_keyframe(
        &mut self,
        x: NavState,
        from_prev: Preintegrated,
        frames: Vec<SubFrame>,
    ) -> Option<()> {
        let info = imu_information(&from_prev, &self.model.imu_noise)?;
        self.keyframes.push_back(Keyframe {
            x,
            lin: None,
            from_prev: Some((from_prev, info)),
            frames,
            still: false,
        });
        Some(())
    }

    /// Adds measurements to the newest keyframe's interval.
    pub fn push_frame(&mut self, frame: SubFrame) {
        if let Some(k) = self.keyframes.back_mut() {
            k.frames.push(frame);
        }
    }

    /// Keyframes, oldest first.
    pub fn keyframes(&self) -> impl DoubleEndedIterator<Item = &NavState> + '_ {
        self.keyframes.iter().map(|k| &k.x)
    }

    /// The newest keyframe.
    pub fn newest(&self) -> Option<&NavState> {
        self.keyframes.back().map(|k| &k.x)
    }

    /// Number of keyframes.
    pub fn len(&self) -> usize {
        self.keyframes.len()
    }

    /// Whether there is no keyframe (never, once built).
    pub fn is_empty(&self) -> bool {
        self.keyframes.is_empty()
    }

    /// AP positions in `w`, m.
    pub fn aps(&self) -> &[Vector3<f64>] {
        &self.aps
    }

    /// The barometer offset, m.
    pub fn baro_offset_m(&self) -> Option<f64> {
        self.baro.map(|b| b.0)
    }

    /// The bearings' common `sin θ` offset β and its marginal σ (last solve), when estimated.
    pub fn sin_bias(&self) -> Option<(f64, f64)> {
        let o = self.scalars().checked_sub(1)?;
        let sigma = self
            .covariance
            .border
            .get((o, o))
            .map_or(f64::INFINITY, |v| v.max(0.0).sqrt());
        self.bias.map(|b| (b.0, sigma))
    }

    /// Scalars at the head of the border: the barometer offset and β, when present.
    pub(super) fn scalars(&self) -> usize {
        usize::from(self.baro.is_some()) + usize::from(self.bias.is_some())
    }

    /// Marginal covariance of the newest keyframe's error state (last solve).
    pub fn newest_covariance(&self) -> &Mat15 {
        &self.covariance.newest
    }

    /// Keyframes marginalized so far.
    pub fn marginalized(&self) -> usize {
        self.counts.marginalized
    }

    /// Bearings to an AP without a state (not counted in the solve).
    pub fn skipped_bearings(&self) -> u64 {
        self.counts.skipped_bearings
    }

    /// Applies an increment (frames then border).
    pub(super) fn apply(&mut self, frames: &[Vec15], border: &DVector<f64>) {
        for (kf, d) in self.keyframes.iter_mut().zip(frames) {
            kf.x = kf.x.boxplus(d);
        }
        let nb = self.scalars();
        if let Some((o, _)) = &mut self.baro {
            *o += border[0];
        }
        if let Some((b, _)) = &mut self.bias {
            *b += border[nb - 1];
        }
        for (l, c) in self.aps.iter_mut().enumerate() {
            *c += border.fixed_rows::<3>(nb + 3 * l);
        }
    }

    /// Residual statistics at the current estimate.
    pub fn fit(&self) -> FitStats {
        self.build(false).2
    }

    /// The information matrix of the window (dense, frames then border), with or without the
    /// prior, at the linearization points (for the observability test).
    pub fn information(&self, with_prior: bool) -> DMatrix<f64> {
        self.build(with_prior).0.to_dense().0
    }
}
