//! MUSIC over (AoA, ToF) (SpotFi §3.2), with the spectrum evaluated through the Kronecker
//! structure of the steering vector (docs/DESIGN.md §3).
//!
//! The steering vector of a window is `s(θ, τ) = a(θ) ⊗ b(τ)`: `a_m = exp(+j·2π·f_c·y_m·sin θ/c)`
//! over the window's `M_s` antennas ([`ArrayGeometry::antenna_phase_rad`], the one definition
//! shared with the simulator) and `b_w = exp(−j·2π·w·Δf·τ)` over its `W` subcarriers
//! ([`tof_phase_rad`]). With `E` the n × L signal basis (n = M_s·W), MUSIC's pseudo-spectrum is
//! `1 / ‖(I − E·Eᴴ)·s‖² = 1 / (n − Σ_l |e_lᴴ·s|²)`, and
//!
//! ```text
//!   e_lᴴ·s = Σ_m a_m · c_lm(τ),   c_lm(τ) = Σ_w conj(E[(m,w), l]) · b_w(τ)
//!   Σ_l |e_lᴴ·s|² = aᴴ·G(τ)·a,    G_ij(τ) = Σ_l conj(c_li(τ)) · c_lj(τ)      (M_s × M_s)
//! ```
//!
//! so each ToF costs `L·M_s·W` multiply-adds once, and each grid point an `M_s × M_s` form
//! (for SpotFi's `M_s = 2`: one complex product), instead of an n × n quadratic form per point
//! ([`super::reference`] does it that way, as the benchmark's baseline and the tests' oracle).
//!
//! Results are reported as the *residual* `ρ = 1 − aᴴGa / n ∈ [0, 1]`, the fraction of the
//! steering vector outside the signal subspace; the normalized pseudo-spectrum is `1/ρ`.

use nalgebra::DMatrix;
use num_complex::Complex64;

use super::smoothing::SmoothingLayout;
use super::steering::tof_phase_rad;
use super::subspace::{Subspace, signal_subspace};
use crate::csi::NUM_SUBCARRIERS;
use crate::rig::ArrayGeometry;

/// Most antennas a smoothing window may hold.
pub const MAX_WINDOW_ANTENNAS: usize = 8;

pub use self::config::{MAX_TOF_SPAN_S, MIN_AOA_STEP_DEG, MIN_TOF_STEP_S, MusicConfig};
pub use self::error::MusicError;
use crate::check::Problems;

/// A MUSIC spectrum on a grid: `residual[i_tof · aoa_rad.len() + i_aoa]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// AoA grid, rad, increasing.
    pub aoa_rad: Vec<f64>,
    /// ToF grid, s, increasing.
    pub tof_s: Vec<f64>,
    /// Residual `ρ` per grid point (see the module docs), ToF-major.
    pub residual: Vec<f64>,
}

impl Spectrum {
    /// Normalized pseudo-spectrum in dB, `−10·log10 ρ`, in the same order.
    pub fn db(&self) -> Vec<f64> {
        self.residual
            .iter()
            .map(|r| -10.0 * r.max(1e-300).log10())
            .collect()
    }
}

/// MUSIC for one channel layout (bandwidth, array, centre frequency), with its grids precomputed.
#[derive(Clone, Debug)]
pub struct Music {
    config: MusicConfig,
    layout: SmoothingLayout,
    /// Per AoA grid point, the window's antenna phasors `a_m` (Nθ × M_s).
    aoa_rad: Vec<f64>,
    aoa_table: Vec<Complex64>,
    /// Per AoA grid point, `conj(a_0)·a_1` (used when `M_s = 2`), real parts (imaginary parts in
    /// `aoa_cross_im`: split, so the spectrum's loop vectorizes).
    aoa_cross_re: Vec<f64>,
    /// See `aoa_cross_re`.
    aoa_cross_im: Vec<f64>,
    /// The ToF grid, s.
    tof_s: Vec<f64>,
    /// Per subcarrier of the window and ToF grid point, the phasor `b_w(τ)` (W × Nτ, ToF
    /// innermost), real parts (imaginary parts in `tof_table_im`), for [`Music::grams_on_grid`].
    tof_table_re: Vec<f64>,
    /// See `tof_table_re`.
    tof_table_im: Vec<f64>,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
}

/// A window of the AoA axis, rad (inclusive bounds, clamped to ±90°).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoaWindow {
    /// Lower bound, rad.
    pub min_rad: f64,
    /// Upper bound, rad.
    pub max_rad: f64,
}

impl AoaWindow {
    /// The whole half-plane, −90°…90°.
    pub const FULL: AoaWindow = AoaWindow {
        min_rad: -std::f64::consts::FRAC_PI_2,
        max_rad: std::f64::consts::FRAC_PI_2,
    };

    /// `center ± half_width`.
    pub fn around(center_rad: f64, half_width_rad: f64) -> Self {
        Self {
            min_rad: (center_rad - half_width_rad).max(-std::f64::consts::FRAC_PI_2),
            max_rad: (center_rad + half_width_rad).min(std::f64::consts::FRAC_PI_2),
        }
    }
}

impl Music {
    /// MUSIC for CSI of `geometry.num_antennas` antennas on subcarriers at `offsets_hz` from the
    /// carrier `center_freq_hz`. `subcarriers_per_window` is the `W` to use (see
    /// [`MusicConfig::subcarriers_per_window_ht20`]).
    pub fn new(
        config: &MusicConfig,
        geometry: ArrayGeometry,
        center_freq_hz: f64,
        offsets_hz: &[f64],
        subcarriers_per_window: usize,
    ) -> Result<Self, MusicError> {
        config
            .problems("music")
            .into_result()
            .map_err(MusicError::Config)?;
        geometry.validate(center_freq_hz)?;
        let layout = SmoothingLayout::new(
            offsets_hz,
            geometry.num_antennas,
            config.antennas_per_window,
            subcarriers_per_window,
        )?;
        if config.tof_max_s - config.tof_min_s >= 1.0 / layout.step_hz() {
            let mut p = Problems::new();
            p.push(
                "music",
                "tof_max_s",
                format!(
                    "the ToF span must stay below the unambiguous {:.0} ns of these subcarriers",
                    1e9 / layout.step_hz()
                ),
            );
            return Err(MusicError::Config(p));
        }
        let n_aoa = config.aoa_points();
        let aoa_rad: Vec<f64> = (0..n_aoa)
            .map(|i| (-90.0 + 180.0 * i as f64 / (n_aoa - 1) as f64).to_radians())
            .collect();
        let n_tof = config.tof_points();
        let tof_s: Vec<f64> = (0..n_tof)
            .map(|i| config.tof_min_s + i as f64 * config.tof_step_s)
            .collect();
        let mut music = Self {
            config: config.clone(),
            layout,
            aoa_rad,
            aoa_table: Vec::new(),
            aoa_cross_re: Vec::new(),
            aoa_cross_im: Vec::new(),
            tof_s,
            tof_table_re: Vec::new(),
            tof_table_im: Vec::new(),
            geometry,
            center_freq_hz,
        };
        music.aoa_table = music
            .aoa_rad
            .iter()
            .flat_map(|&t| music.aoa_phasors(t))
            .collect();
        let cross: Vec<Complex64> = music
            .aoa_table
            .chunks(music.layout.antennas_per_window())
            .map(|a| {
                if a.len() == 2 {
                    a[0].conj() * a[1]
                } else {
                    Complex64::new(0.0, 0.0)
                }
            })
            .collect();
        music.aoa_cross_re = cross.iter().map(|c| c.re).collect();
        music.aoa_cross_im = cross.iter().map(|c| c.im).collect();
        // Per ToF point its W phasors, stored subcarrier-major (ToF innermost).
        let (w_len, n_tof) = (music.layout.subcarriers_per_window(), music.tof_s.len());
        let per_tof: Vec<Complex64> = music
            .tof_s
            .iter()
            .flat_map(|&t| music.tof_phasors(t))
            .collect();
        let transposed = |part: fn(&Complex64) -> f64| {
            (0..w_len * n_tof)
                .map(|i| part(&per_tof[(i % n_tof) * w_len + i / n_tof]))
                .collect::<Vec<f64>>()
        };
        music.tof_table_re = transposed(|c| c.re);
        music.tof_table_im = transposed(|c| c.im);
        Ok(music)
    }

    /// The smoothing layout in use.
    pub fn layout(&self) -> &SmoothingLayout {
        &self.layout
    }

    /// The settings.
    pub fn config(&self) -> &MusicConfig {
        &self.config
    }

    /// The AoA grid, rad.
    pub fn aoa_grid(&self) -> &[f64] {
        &self.aoa_rad
    }

    /// The ToF grid, s.
    pub fn tof_grid(&self) -> &[f64] {
        &self.tof_s
    }

    /// Smoothed matrix and signal subspace of one sanitized, calibrated packet (`csi` row-major,
    /// antenna `m`'s subcarrier `k` at `m·K + k`).
    pub fn subspace(&self, csi: &[Complex64]) -> Result<Subspace, MusicError> {
        let mut x = DMatrix::zeros(self.layout.rows(), self.layout.cols());
        self.layout.fill(csi, &mut x)?;
        signal_subspace(&x, self.config.forward_backward, &self.config.paths)
    }

    /// `a_m(θ)` over the window's antennas (shared steering vector, carrier frequency).
    pub fn aoa_phasors(&self, aoa_rad: f64) -> Vec<Complex64> {
        let mut a = vec![Complex64::new(0.0, 0.0); self.layout.antennas_per_window()];
        self.aoa_phasors_into(aoa_rad, &mut a);
        a
    }

    /// [`Music::aoa_phasors`] into the first `M_s` entries of `out`.
    fn aoa_phasors_into(&self, aoa_rad: f64, out: &mut [Complex64]) {
        let s = aoa_rad.sin();
        for (m, o) in out.iter_mut().enumerate() {
            *o = Complex64::from_polar(
                1.0,
                self.geometry.antenna_phase_rad(m, self.center_freq_hz, s),
            );
        }
    }

    /// `b_w(τ)` over the window's subcarriers.
    pub fn tof_phasors(&self, tof_s: f64) -> Vec<Complex64> {
        let mut b = vec![Complex64::new(0.0, 0.0); self.layout.subcarriers_per_window()];
        self.tof_phasors_into(tof_s, &mut b);
        b
    }

    /// [`Music::tof_phasors`] into the first `W` entries of `out`. The phase is linear in the
    /// subcarrier's offset, so `b_w = z^w` with `z` the phasor of one step: one `sincos` per
    /// call instead of `W` (the refinement calls this hundreds of times per packet), with a
    /// rounding error of a few ε after 30 products.
    fn tof_phasors_into(&self, tof_s: f64, out: &mut [Complex64]) {
        let z = Complex64::from_polar(1.0, tof_phase_rad(self.layout.step_hz(), tof_s));
        let mut b = Complex64::new(1.0, 0.0);
        for o in out.iter_mut() {
            *o = b;
            b *= z;
        }
    }

    /// `G(τ)` at an off-grid ToF, into `g` (M_s², row-major), without allocating.
    pub(crate) fn gram_at(&self, basis: &DMatrix<Complex64>, tof_s: f64, g: &mut [Complex64]) {
        let mut b = [Complex64::new(0.0, 0.0); NUM_SUBCARRIERS];
        let b = &mut b[..self.layout.subcarriers_per_window()];
        self.tof_phasors_into(tof_s, b);
        self.gram_from(basis, b, g);
    }

    /// The residual for an off-grid AoA given `G(τ)`, without allocating.
    pub(crate) fn residual_with(&self, g: &[Complex64], aoa_rad: f64) -> f64 {
        if let [g00, g01, _, g11] = g {
            // `M_s = 2`: only `conj(a₀)·a₁` enters the form, one `sincos` instead of two.
            let s = aoa_rad.sin();
            let cross = Complex64::from_polar(
                1.0,
                self.geometry.antenna_phase_rad(1, self.center_freq_hz, s)
                    - self.geometry.antenna_phase_rad(0, self.center_freq_hz, s),
            );
            return self.residual_of(g00.re + g11.re + 2.0 * (g01 * cross).re);
        }
        let mut a = [Complex64::new(0.0, 0.0); MAX_WINDOW_ANTENNAS];
        let a = &mut a[..self.layout.antennas_per_window()];
        self.aoa_phasors_into(aoa_rad, a);
        self.residual_of(self.form(g, a))
    }

    /// `G(τ)` (M_s × M_s, row-major) from the subcarrier phasors of one ToF.
    pub(crate) fn gram_from(
        &self,
        basis: &DMatrix<Complex64>,
        b: &[Complex64],
        g: &mut [Complex64],
    ) {
        let (ms, w_len) = (
            self.layout.antennas_per_window(),
            self.layout.subcarriers_per_window(),
        );
        g.fill(Complex64::new(0.0, 0.0));
        let mut c = [Complex64::new(0.0, 0.0); MAX_WINDOW_ANTENNAS];
        for l in 0..basis.ncols() {
            let col = basis.column(l);
            for (m, cm) in c.iter_mut().enumerate().take(ms) {
                *cm = (0..w_len).map(|w| col[m * w_len + w].conj() * b[w]).sum();
            }
            for i in 0..ms {
                for j in 0..ms {
                    g[i * ms + j] += c[i].conj() * c[j];
                }
            }
        }
    }

    /// `G(τ)` at every ToF grid point (Nτ blocks of M_s², row-major), the same as
    /// [`Music::gram_from`] per point but with the ToF axis innermost (split real and imaginary
    /// parts, so the loops vectorize): `c_lm(τ) = Σ_w conj(E[m·W + w, l])·b_w(τ)`, then
    /// `G_ij(τ) = Σ_l conj(c_li(τ))·c_lj(τ)`.
    fn grams_on_grid(&self, basis: &DMatrix<Complex64>) -> Vec<Complex64> {
        let (ms, w_len, nt) = (
            self.layout.antennas_per_window(),
            self.layout.subcarriers_per_window(),
            self.tof_s.len(),
        );
        let paths = basis.ncols();
        let mut c_re = vec![0.0; paths * ms * nt];
        let mut c_im = vec![0.0; paths * ms * nt];
        for l in 0..paths {
            let col = basis.column(l);
            for m in 0..ms {
                let o = (l * ms + m) * nt;
                let (cr, ci) = (&mut c_re[o..o + nt], &mut c_im[o..o + nt]);
                for w in 0..w_len {
                    let e = col[m * w_len + w];
                    let tr = &self.tof_table_re[w * nt..(w + 1) * nt];
                    let ti = &self.tof_table_im[w * nt..(w + 1) * nt];
                    for (((cr, ci), tr), ti) in cr.iter_mut().zip(ci.iter_mut()).zip(tr).zip(ti) {
                        *cr += e.re * tr + e.im * ti;
                        *ci += e.re * ti - e.im * tr;
                    }
                }
            }
        }
        let mut g = vec![Complex64::new(0.0, 0.0); nt * ms * ms];
        for l in 0..paths {
            for i in 0..ms {
                let oi = (l * ms + i) * nt;
                for j in 0..ms {
                    let oj = (l * ms + j) * nt;
                    for it in 0..nt {
                        let (ar, ai) = (c_re[oi + it], c_im[oi + it]);
                        let (br, bi) = (c_re[oj + it], c_im[oj + it]);
                        g[it * ms * ms + i * ms + j] +=
                            Complex64::new(ar * br + ai * bi, ar * bi - ai * br);
                    }
                }
            }
        }
        g
    }

    /// `aᴴ·G·a` for the window's antenna phasors `a`.
    fn form(&self, g: &[Complex64], a: &[Complex64]) -> f64 {
        let ms = a.len();
        if ms == 2 {
            return g[0].re + g[3].re + 2.0 * (g[1] * a[0].conj() * a[1]).re;
        }
        let mut q = 0.0;
        for i in 0..ms {
            for j in 0..ms {
                q += (a[i].conj() * g[i * ms + j] * a[j]).re;
            }
        }
        q
    }

    /// The residual at an arbitrary (θ, τ), off the grid.
    pub fn residual_at(&self, subspace: &Subspace, aoa_rad: f64, tof_s: f64) -> f64 {
        let mut g = [Complex64::new(0.0, 0.0); MAX_WINDOW_ANTENNAS * MAX_WINDOW_ANTENNAS];
        let ms = self.layout.antennas_per_window();
        let g = &mut g[..ms * ms];
        self.gram_at(&subspace.basis, tof_s, g);
        self.residual_with(g, aoa_rad)
    }

    pub(crate) fn residual_of(&self, q: f64) -> f64 {
        (1.0 - q / self.layout.rows() as f64).clamp(1e-12, 1.0)
    }

    /// Grid indices of the AoA grid inside `window`.
    fn aoa_range(&self, window: AoaWindow) -> std::ops::Range<usize> {
        let lo = self
            .aoa_rad
            .partition_point(|&t| t < window.min_rad - 1e-12);
        let hi = self
            .aoa_rad
            .partition_point(|&t| t <= window.max_rad + 1e-12);
        lo..hi.max(lo)
    }

    /// The spectrum over the ToF grid and the AoA grid points inside `window`.
    pub fn spectrum(&self, subspace: &Subspace, window: AoaWindow) -> Spectrum {
        let ms = self.layout.antennas_per_window();
        let range = self.aoa_range(window);
        let n_aoa = range.len();
        let mut residual = Vec::with_capacity(n_aoa * self.tof_s.len());
        let grams = self.grams_on_grid(&subspace.basis);
        for g in grams.chunks_exact(ms * ms) {
            if ms == 2 {
                // aᴴGa = G00 + G11 + 2·Re(G01·conj(a0)·a1): one complex product per point,
                // folded into `ρ = c + c_re·x_re + c_im·x_im`.
                let scale = 1.0 / self.layout.rows() as f64;
                let c = 1.0 - (g[0].re + g[3].re) * scale;
                let (c_re, c_im) = (-2.0 * scale * g[1].re, 2.0 * scale * g[1].im);
                let (x_re, x_im) = (
                    &self.aoa_cross_re[range.clone()],
                    &self.aoa_cross_im[range.clone()],
                );
                residual.extend(
                    x_re.iter()
                        .zip(x_im)
                        .map(|(xr, xi)| (c + c_re * xr + c_im * xi).clamp(1e-12, 1.0)),
                );
            } else {
                for ia in range.clone() {
                    let q = self.form(g, &self.aoa_table[ia * ms..][..ms]);
                    residual.push(self.residual_of(q));
                }
            }
        }
        Spectrum {
            aoa_rad: self.aoa_rad[range].to_vec(),
            tof_s: self.tof_s.clone(),
            residual,
        }
    }
}

mod config;
pub(crate) mod error;
mod peaks;
