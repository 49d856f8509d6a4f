//! The block Cholesky solve of the arrow system (module doc of [`super`]), with Jacobi scaling.

use nalgebra::{Cholesky, Const, DMatrix, DVector, Dyn};

use super::{ArrowSolution, ArrowSystem, BlockOf, BorderTOf, VecOf};

impl<const D: usize> ArrowSystem<D> {
    /// Solves `H x = b` by the block Cholesky in the module doc, on the system scaled to a unit
    /// diagonal (Jacobi: the IMU rows weigh ~10¹⁰ and the weak priors ~10⁻⁴, so the unscaled
    /// condition number reaches 1/ε). `None` when `H` is not positive definite (it always is with
    /// the estimator's priors unless the input is degenerate).
    pub fn solve(&self) -> Option<ArrowSolution<D>> {
        self.clone().into_solution()
    }

    /// [`ArrowSystem::solve`] on a system that is not needed afterwards (scaled in place, no
    /// copy).
    pub fn into_solution(mut self) -> Option<ArrowSolution<D>> {
        let inv_sqrt = |d: f64| {
            if d > 0.0 && d.is_finite() {
                1.0 / d.sqrt()
            } else {
                1.0
            }
        };
        let s_frames: Vec<VecOf<D>> = self
            .diag
            .iter()
            .map(|d| VecOf::<D>::from_fn(|i, _| inv_sqrt(d[(i, i)])))
            .collect();
        let s_border = DVector::from_fn(self.border_dim(), |i, _| inv_sqrt(self.corner[(i, i)]));
        // D H D with D diagonal: every entry (i, j) times s_i s_j.
        self.scale(&s_frames, &s_border);
        let scaled = self;
        // Directions the data barely constrain (scale and tilt before the flight has excited them)
        // can sit below ε relative to the stiff IMU chain; then a tiny damping of the scaled
        // system keeps the solve finite and leaves those directions to the priors.
        let mut sol = scaled.solve_unscaled().or_else(|| {
            [1e-12, 1e-10, 1e-8].iter().find_map(|&mu| {
                let mut damped = scaled.clone();
                for d in &mut damped.diag {
                    *d += BlockOf::<D>::identity() * mu;
                }
                damped.corner += DMatrix::identity(damped.border_dim(), damped.border_dim()) * mu;
                damped.solve_unscaled()
            })
        })?;
        for (x, s) in sol.frames.iter_mut().zip(&s_frames) {
            *x = x.component_mul(s);
        }
        sol.border = sol.border.component_mul(&s_border);
        scale_both_sides(&mut sol.border_covariance, &s_border);
        // Σ = S Σ_scaled S: the last frame's block by its own scaling, the cross term by the last
        // frame's rows and the border's columns.
        if let Some(s_last) = s_frames.last() {
            scale_block(&mut sol.last_frame_covariance, s_last, s_last);
            scale_border_t(&mut sol.last_frame_border_covariance, s_last, &s_border);
        }
        Some(sol)
    }

    /// `D H D` and `D b` in place, `D` = diag(`s_frames`, `s_border`).
    fn scale(&mut self, s_frames: &[VecOf<D>], s_border: &DVector<f64>) {
        for (k, s) in s_frames.iter().enumerate() {
            scale_block(&mut self.diag[k], s, s);
            if let Some(next) = s_frames.get(k + 1) {
                scale_block(&mut self.lower[k], next, s);
            }
            scale_border_t(&mut self.frame_border[k], s, s_border);
            self.rhs_frames[k].component_mul_assign(s);
        }
        scale_both_sides(&mut self.corner, s_border);
        self.rhs_border.component_mul_assign(s_border);
    }

    /// The block Cholesky solve without scaling.
    fn solve_unscaled(&self) -> Option<ArrowSolution<D>> {
        let n = self.frames();
        let m = self.border_dim();
        let mut l_diag: Vec<BlockOf<D>> = Vec::with_capacity(n);
        let mut l_lower: Vec<BlockOf<D>> = Vec::with_capacity(n.saturating_sub(1));
        // `L_B,kᵀ = L_kk⁻¹ (H_B,k − L_B,k−1 L_k,k−1ᵀ)ᵀ`, kept transposed (D × m).
        let mut l_border_t: Vec<BorderTOf<D>> = Vec::with_capacity(n);
        // Forward substitution runs alongside: y_k = L_kk⁻¹ (b_k − L_k,k−1 y_k−1).
        let mut y_frames: Vec<VecOf<D>> = Vec::with_capacity(n);
        let mut schur = self.corner.clone();
        let mut y_border_acc = self.rhs_border.clone();
        for k in 0..n {
            let mut a = self.diag[k];
            let mut bt = self.frame_border[k].clone();
            let mut rhs = self.rhs_frames[k];
            if k > 0 {
                let lk = &l_lower[k - 1];
                a -= lk * lk.transpose();
                let (cols, _) = bt.as_mut_slice().as_chunks_mut::<D>();
                let (prevs, _) = l_border_t[k - 1].as_slice().as_chunks::<D>();
                for (col, prev) in cols.iter_mut().zip(prevs) {
                    let d = lk * VecOf::<D>::from(*prev);
                    col.iter_mut().zip(d.iter()).for_each(|(c, d)| *c -= d);
                }
                rhs -= lk * y_frames[k - 1];
            }
            let l = Cholesky::new(a)?.unpack();
            forward_substitute(&l, bt.as_mut_slice());
            forward_substitute(&l, rhs.as_mut_slice());
            if k + 1 < n {
                let mut lo_t: BlockOf<D> = self.lower[k].transpose();
                forward_substitute(&l, lo_t.as_mut_slice());
                l_lower.push(lo_t.transpose());
            }
            subtract_gram_lower(&mut schur, &bt);
            y_border_acc.gemv_tr(-1.0, &bt, &rhs, 1.0);
            l_border_t.push(bt);
            y_frames.push(rhs);
            l_diag.push(l);
        }
        schur.fill_upper_triangle_with_lower_triangle();
        let (border, border_covariance) = if m > 0 {
            let chol_b = Cholesky::<f64, Dyn>::new(schur)?;
            let l_bb = chol_b.l();
            let y_b = l_bb.solve_lower_triangular(&y_border_acc)?;
            let x_b = l_bb.transpose().solve_upper_triangular(&y_b)?;
            (x_b, chol_b.inverse())
        } else {
            (DVector::zeros(0), DMatrix::zeros(0, 0))
        };
        // Back substitution: L_kkᵀ x_k = y_k − L_k+1,kᵀ x_k+1 − L_B,kᵀ x_B.
        let mut frames = vec![VecOf::<D>::zeros(); n];
        for k in (0..n).rev() {
            let mut r = y_frames[k];
            if k + 1 < n {
                r -= l_lower[k].transpose() * frames[k + 1];
            }
            let (cols, _) = l_border_t[k].as_slice().as_chunks::<D>();
            for (col, x) in cols.iter().zip(border.iter()) {
                r.iter_mut().zip(col).for_each(|(r, c)| *r -= c * x);
            }
            back_substitute(&l_diag[k], r.as_mut_slice());
            frames[k] = r;
        }
        let (last_frame_covariance, last_frame_border_covariance) =
            match (l_diag.last(), l_border_t.pop()) {
                (Some(l_ff), Some(r)) => last_frame_covariances(l_ff, r, &border_covariance),
                _ => (
                    BlockOf::<D>::zeros(),
                    BorderTOf::<D>::zeros_generic(Const::<D>, Dyn(m)),
                ),
            };
        Some(ArrowSolution {
            frames,
            border,
            border_covariance,
            last_frame_covariance,
            last_frame_border_covariance,
        })
    }
}

/// The last frame's marginal covariance and its cross-covariance with the border (module doc),
/// from its Cholesky block `l_ff`, `L_Bfᵀ` (`l_bf_t`, D × m, overwritten by `R = L_ff⁻ᵀ L_Bfᵀ`)
/// and the border's covariance `Σ_BB`.
fn last_frame_covariances<const D: usize>(
    l_ff: &BlockOf<D>,
    mut l_bf_t: BorderTOf<D>,
    sigma_bb: &DMatrix<f64>,
) -> (BlockOf<D>, BorderTOf<D>) {
    // (L_ff L_ffᵀ)⁻¹ = L_ff⁻ᵀ L_ff⁻¹.
    let mut l_inv = BlockOf::<D>::identity();
    forward_substitute(l_ff, l_inv.as_mut_slice());
    let mut sigma_ff = l_inv.tr_mul(&l_inv);
    back_substitute(l_ff, l_bf_t.as_mut_slice());
    let r = l_bf_t;
    // Σ_fB = −R Σ_BB.
    let mut sigma_fb = &r * sigma_bb;
    sigma_fb.neg_mut();
    // Σ_ff += R Σ_BB Rᵀ = −Σ_fB Rᵀ, one rank-1 update per border column.
    let (fb_cols, _) = sigma_fb.as_slice().as_chunks::<D>();
    let (r_cols, _) = r.as_slice().as_chunks::<D>();
    for (x, y) in fb_cols.iter().zip(r_cols) {
        for j in 0..D {
            for i in 0..D {
                sigma_ff[(i, j)] -= x[i] * y[j];
            }
        }
    }
    // Symmetric in exact arithmetic; make it so in floating point.
    let sigma_ff = (sigma_ff + sigma_ff.transpose()) * 0.5;
    (sigma_ff, sigma_fb)
}

/// `M ← diag(si) M diag(sj)`.
pub(super) fn scale_block<const D: usize>(m: &mut BlockOf<D>, si: &VecOf<D>, sj: &VecOf<D>) {
    for j in 0..D {
        for i in 0..D {
            m[(i, j)] *= si[i] * sj[j];
        }
    }
}

/// `M ← diag(s_rows) M diag(s_cols)` for a D × m border block.
pub(super) fn scale_border_t<const D: usize>(
    b: &mut BorderTOf<D>,
    s_rows: &VecOf<D>,
    s_cols: &DVector<f64>,
) {
    for c in 0..b.ncols() {
        for r in 0..D {
            b[(r, c)] *= s_rows[r] * s_cols[c];
        }
    }
}

/// `M ← D M D` for `D` = diag(`s`).
pub(super) fn scale_both_sides(m: &mut DMatrix<f64>, s: &DVector<f64>) {
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            m[(r, c)] *= s[r] * s[c];
        }
    }
}

/// `X ← L⁻¹ X` for a lower-triangular `l` with a positive diagonal (a Cholesky factor), `X`
/// given as consecutive D-element columns (column-major storage).
pub(crate) fn forward_substitute<const D: usize>(l: &BlockOf<D>, columns: &mut [f64]) {
    let inv_diag = VecOf::<D>::from_fn(|i, _| 1.0 / l[(i, i)]);
    let (cols, _) = columns.as_chunks_mut::<D>();
    for col in cols {
        for i in 0..D {
            let mut v = col[i];
            for j in 0..i {
                v -= l[(i, j)] * col[j];
            }
            col[i] = v * inv_diag[i];
        }
    }
}

/// `X ← L⁻ᵀ X` for a lower-triangular `l` with a positive diagonal (a Cholesky factor), `X`
/// given as consecutive D-element columns (column-major storage).
fn back_substitute<const D: usize>(l: &BlockOf<D>, columns: &mut [f64]) {
    let (cols, _) = columns.as_chunks_mut::<D>();
    for x in cols {
        for i in (0..D).rev() {
            let mut v = x[i];
            for j in i + 1..D {
                v -= l[(j, i)] * x[j];
            }
            x[i] = v / l[(i, i)];
        }
    }
}

/// `S ← S − Bᵀ B` on the lower triangle of `S` only (`B` is D × m; the caller mirrors it).
/// Columns as `[f64; D]` so the dot products unroll.
fn subtract_gram_lower<const D: usize>(s: &mut DMatrix<f64>, b: &BorderTOf<D>) {
    let m = s.nrows();
    let (cols, _) = b.as_slice().as_chunks::<D>();
    let s = s.as_mut_slice();
    for (j, cj) in cols.iter().enumerate() {
        let s_col = &mut s[j * m..(j + 1) * m];
        for (i, ci) in cols.iter().enumerate().skip(j) {
            let mut dot = 0.0;
            for r in 0..D {
                dot += ci[r] * cj[r];
            }
            s_col[i] -= dot;
        }
    }
}
