//! The normal equations of the sliding window and their Cholesky solve.
//!
//! With the frames first and the border (accelerometer bias, AP positions) last, the information
//! matrix is block tridiagonal with a dense border (an "arrow"): each IMU factor touches two
//! neighbouring frames, each AoA factor one frame and one AP, the prior the first frame and the
//! border. Its Cholesky factor keeps the shape (no fill-in outside it):
//!
//! ```text
//! L_kk   = chol(H_kk − L_k,k−1 L_k,k−1ᵀ)
//! L_k+1,k = H_k+1,k L_kk⁻ᵀ
//! L_B,k  = (H_B,k − L_B,k−1 L_k,k−1ᵀ) L_kk⁻ᵀ
//! L_BB   = chol(H_BB − Σ_k L_B,k L_B,kᵀ)
//! ```
//!
//! so a solve costs O(n·(D³ + D²·m)) for n frames of D (9 here) and a border of m, linear in the
//! window size. `Σ_BB = (L_BB L_BBᵀ)⁻¹` is the border's marginal covariance, for free, and since
//! the last frame f = n − 1 is eliminated last among the frames, its marginal covariance and its
//! cross-covariance with the border come from the trailing blocks alone:
//!
//! ```text
//! Σ_ff = L_ff⁻ᵀ (I + L_Bfᵀ Σ_BB L_Bf) L_ff⁻¹ = (L_ff L_ffᵀ)⁻¹ + R Σ_BB Rᵀ,   R = L_ff⁻ᵀ L_Bfᵀ
//! Σ_fB = −L_ff⁻ᵀ L_Bfᵀ Σ_BB = −R Σ_BB
//! ```

use nalgebra::{Cholesky, Const, DMatrix, DVector, Dyn, OMatrix, SMatrix, SVector};

/// Size of one frame's state `[p, v, g]`.
pub const FRAME_DIM: usize = 9;
/// D×D block.
pub type BlockOf<const D: usize> = SMatrix<f64, D, D>;
/// D-vector.
pub type VecOf<const D: usize> = SVector<f64, D>;
/// A border block transposed: D frame rows × border columns.
pub type BorderTOf<const D: usize> = OMatrix<f64, Const<D>, Dyn>;
/// 9×9 block.
pub type Block = BlockOf<FRAME_DIM>;
/// 9-vector.
pub type Vec9 = VecOf<FRAME_DIM>;

/// A border block transposed: frame rows × border columns.
pub type BorderT = BorderTOf<FRAME_DIM>;

/// Information matrix and vector of the window, in arrow form, with frame blocks of `D`.
#[derive(Clone, Debug)]
pub struct ArrowSystem<const D: usize = FRAME_DIM> {
    /// `H_kk` per frame.
    pub diag: Vec<BlockOf<D>>,
    /// `H_{k+1,k}` per consecutive pair (length `n − 1`).
    pub lower: Vec<BlockOf<D>>,
    /// `H_{k,B}` per frame (D × border columns; `H_{B,k}` transposed, the layout the
    /// factorization works in).
    pub frame_border: Vec<BorderTOf<D>>,
    /// `H_BB`.
    pub corner: DMatrix<f64>,
    /// Information vector of the frames.
    pub rhs_frames: Vec<VecOf<D>>,
    /// Information vector of the border.
    pub rhs_border: DVector<f64>,
}

/// The solution and what comes with it.
#[derive(Clone, Debug)]
pub struct ArrowSolution<const D: usize = FRAME_DIM> {
    /// Per-frame state (`[p, v, g]` for the window's frames).
    pub frames: Vec<VecOf<D>>,
    /// The border.
    pub border: DVector<f64>,
    /// Marginal covariance of the border.
    pub border_covariance: DMatrix<f64>,
    /// Marginal covariance of the last frame (frame `n − 1`); zeros when there are no frames.
    pub last_frame_covariance: BlockOf<D>,
    /// Cross-covariance of the last frame (rows) with the border (columns), D × m; zeros when
    /// there are no frames.
    pub last_frame_border_covariance: BorderTOf<D>,
}

impl<const D: usize> ArrowSystem<D> {
    /// All zeros for `n` frames and a border of `m`.
    pub fn zeros(n: usize, m: usize) -> Self {
        Self {
            diag: vec![BlockOf::<D>::zeros(); n],
            lower: vec![BlockOf::<D>::zeros(); n.saturating_sub(1)],
            frame_border: vec![BorderTOf::<D>::zeros_generic(Const::<D>, Dyn(m)); n],
            corner: DMatrix::zeros(m, m),
            rhs_frames: vec![VecOf::<D>::zeros(); n],
            rhs_border: DVector::zeros(m),
        }
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.diag.len()
    }

    /// Border size.
    pub fn border_dim(&self) -> usize {
        self.corner.nrows()
    }

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

    /// The same system as one dense matrix and vector (for tests and the reference solve).
    pub fn to_dense(&self) -> (DMatrix<f64>, DVector<f64>) {
        let n = self.frames();
        let m = self.border_dim();
        let dim = n * D + m;
        let mut h = DMatrix::zeros(dim, dim);
        let mut b = DVector::zeros(dim);
        let bo = n * D;
        for k in 0..n {
            let o = k * D;
            h.view_mut((o, o), (D, D)).copy_from(&self.diag[k]);
            b.rows_mut(o, D).copy_from(&self.rhs_frames[k]);
            if k + 1 < n {
                h.view_mut((o + D, o), (D, D)).copy_from(&self.lower[k]);
                h.view_mut((o, o + D), (D, D))
                    .copy_from(&self.lower[k].transpose());
            }
            if m > 0 {
                h.view_mut((bo, o), (m, D))
                    .copy_from(&self.frame_border[k].transpose());
                h.view_mut((o, bo), (D, m)).copy_from(&self.frame_border[k]);
            }
        }
        if m > 0 {
            h.view_mut((bo, bo), (m, m)).copy_from(&self.corner);
            b.rows_mut(bo, m).copy_from(&self.rhs_border);
        }
        (h, b)
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
fn scale_block<const D: usize>(m: &mut BlockOf<D>, si: &VecOf<D>, sj: &VecOf<D>) {
    for j in 0..D {
        for i in 0..D {
            m[(i, j)] *= si[i] * sj[j];
        }
    }
}

/// `M ← diag(s_rows) M diag(s_cols)` for a D × m border block.
fn scale_border_t<const D: usize>(b: &mut BorderTOf<D>, s_rows: &VecOf<D>, s_cols: &DVector<f64>) {
    for c in 0..b.ncols() {
        for r in 0..D {
            b[(r, c)] *= s_rows[r] * s_cols[c];
        }
    }
}

/// `M ← D M D` for `D` = diag(`s`).
fn scale_both_sides(m: &mut DMatrix<f64>, s: &DVector<f64>) {
    for c in 0..m.ncols() {
        for r in 0..m.nrows() {
            m[(r, c)] *= s[r] * s[c];
        }
    }
}

/// `X ← L⁻¹ X` for a lower-triangular `l` with a positive diagonal (a Cholesky factor), `X`
/// given as consecutive D-element columns (column-major storage).
pub(super) fn forward_substitute<const D: usize>(l: &BlockOf<D>, columns: &mut [f64]) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random positive definite arrow system with frame blocks of `D`.
    fn random<const D: usize>(n: usize, m: usize, seed: u64) -> ArrowSystem<D> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut s = ArrowSystem::<D>::zeros(n, m);
        // Sum of random rank-limited factors with the arrow's sparsity.
        for k in 0..n {
            let j = DMatrix::from_fn(D + 3, 2 * D + m, |_, _| rng.random::<f64>() - 0.5);
            let jt_j = j.transpose() * &j;
            let two = if k + 1 < n { 2 } else { 1 };
            for a in 0..two {
                for c in 0..two {
                    let blk: BlockOf<D> = jt_j.fixed_view::<D, D>(a * D, c * D).into_owned();
                    match (a, c) {
                        (0, 0) => s.diag[k] += blk,
                        (1, 1) => s.diag[k + 1] += blk,
                        (1, 0) => s.lower[k] += blk,
                        _ => {}
                    }
                }
                let bb = jt_j.view((a * D, 2 * D), (D, m));
                s.frame_border[k + a] += bb;
            }
            s.corner += jt_j.view((2 * D, 2 * D), (m, m));
            s.diag[k] += BlockOf::<D>::identity() * 0.1;
            s.rhs_frames[k] = VecOf::<D>::from_fn(|_, _| rng.random::<f64>() - 0.5);
        }
        s.corner += DMatrix::identity(m, m) * 0.1;
        s.rhs_border = DVector::from_fn(m, |_, _| rng.random::<f64>() - 0.5);
        s
    }

    /// Frobenius distance within `rel` of `b`'s norm.
    fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, rel: f64, what: &str) {
        assert_eq!(a.shape(), b.shape(), "{what}: shape");
        let d = (a - b).norm();
        assert!(d <= rel * b.norm(), "{what}: {d} vs {}", b.norm());
    }

    /// The arrow solve against a dense Cholesky of the same system: solution, border covariance
    /// and the last frame's covariance blocks.
    fn matches_a_dense_solve<const D: usize>(n: usize, m: usize, seed: u64) {
        let s = random::<D>(n, m, seed);
        let sol = s.solve().unwrap();
        let (h, b) = s.to_dense();
        let dense = h.clone().cholesky().unwrap();
        let x = dense.solve(&b);
        let cov = dense.inverse();
        let what = format!("D {D} n {n} m {m}");
        assert_eq!(sol.frames.len(), n);
        for k in 0..n {
            let d = (sol.frames[k] - x.rows(k * D, D)).norm();
            assert!(d < 1e-9 * (1.0 + x.norm()), "{what} frame {k}: {d}");
        }
        assert_eq!(sol.border.len(), m);
        assert_eq!(sol.border_covariance.shape(), (m, m));
        assert_eq!(sol.last_frame_border_covariance.shape(), (D, m));
        if m > 0 {
            assert!((&sol.border - x.rows(n * D, m)).norm() < 1e-9 * (1.0 + x.norm()));
            let cb = cov.view((n * D, n * D), (m, m)).into_owned();
            assert_close(&sol.border_covariance, &cb, 1e-9, &what);
        }
        if n > 0 {
            let f = (n - 1) * D;
            let cff = cov.view((f, f), (D, D)).into_owned();
            let got = DMatrix::from_column_slice(D, D, sol.last_frame_covariance.as_slice());
            assert_close(&got, &cff, 1e-9, &format!("{what} Σ_ff"));
            if m > 0 {
                let cfb = cov.view((f, n * D), (D, m)).into_owned();
                let got =
                    DMatrix::from_column_slice(D, m, sol.last_frame_border_covariance.as_slice());
                assert_close(&got, &cfb, 1e-9, &format!("{what} Σ_fB"));
            }
        } else {
            assert_eq!(sol.last_frame_covariance, BlockOf::<D>::zeros());
            assert!(sol.last_frame_border_covariance.iter().all(|&v| v == 0.0));
        }
    }

    const CASES: [(usize, usize, u64); 8] = [
        (1, 0, 1),
        (2, 3, 2),
        (30, 6, 3),
        (7, 12, 4),
        (1, 5, 6),
        (4, 0, 7),
        (0, 4, 8),
        (0, 0, 9),
    ];

    #[test]
    fn arrow_cholesky_matches_a_dense_solve() {
        for (n, m, seed) in CASES {
            matches_a_dense_solve::<FRAME_DIM>(n, m, seed);
        }
    }

    #[test]
    fn arrow_cholesky_matches_a_dense_solve_with_15_blocks() {
        for (n, m, seed) in CASES {
            matches_a_dense_solve::<15>(n, m, seed);
        }
    }

    /// Jacobi scaling is undone in the covariances: the same check on a badly scaled system.
    #[test]
    fn last_frame_covariance_survives_bad_scaling() {
        let (n, m) = (5, 6);
        let mut s = random::<FRAME_DIM>(n, m, 10);
        let scales = DVector::from_fn(n * FRAME_DIM + m, |i, _| 10f64.powi((i % 7) as i32 - 3));
        // H ← D H D, b ← D b with D far from the identity.
        for k in 0..n {
            let sk = scales.fixed_rows::<FRAME_DIM>(k * FRAME_DIM).into_owned();
            scale_block(&mut s.diag[k], &sk, &sk);
            if k + 1 < n {
                let sn = scales
                    .fixed_rows::<FRAME_DIM>((k + 1) * FRAME_DIM)
                    .into_owned();
                scale_block(&mut s.lower[k], &sn, &sk);
            }
            let sb = scales.rows(n * FRAME_DIM, m).into_owned();
            scale_border_t(&mut s.frame_border[k], &sk, &sb);
            s.rhs_frames[k].component_mul_assign(&sk);
        }
        let sb = scales.rows(n * FRAME_DIM, m).into_owned();
        scale_both_sides(&mut s.corner, &sb);
        s.rhs_border.component_mul_assign(&sb);
        let sol = s.solve().unwrap();
        let cov = s.to_dense().0.cholesky().unwrap().inverse();
        let f = (n - 1) * FRAME_DIM;
        let cff = cov.view((f, f), (FRAME_DIM, FRAME_DIM)).into_owned();
        let got =
            DMatrix::from_column_slice(FRAME_DIM, FRAME_DIM, sol.last_frame_covariance.as_slice());
        assert_close(&got, &cff, 1e-8, "Σ_ff");
        let cfb = cov.view((f, n * FRAME_DIM), (FRAME_DIM, m)).into_owned();
        let got =
            DMatrix::from_column_slice(FRAME_DIM, m, sol.last_frame_border_covariance.as_slice());
        assert_close(&got, &cfb, 1e-8, "Σ_fB");
    }

    #[test]
    fn indefinite_systems_are_refused() {
        let mut s = random::<FRAME_DIM>(3, 3, 5);
        s.diag[1] = -Block::identity();
        assert!(s.solve().is_none());
    }
}
