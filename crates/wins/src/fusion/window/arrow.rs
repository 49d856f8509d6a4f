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
//! so a solve costs O(n·(9³ + 9²·m)) for n frames and a border of m, linear in the window size.
//! `(L_BB L_BBᵀ)⁻¹` is the border's marginal covariance, for free.

use nalgebra::{Cholesky, Const, DMatrix, DVector, Dyn, OMatrix, SMatrix, SVector};

/// Size of one frame's state `[p, v, g]`.
pub const FRAME_DIM: usize = 9;
/// 9×9 block.
pub type Block = SMatrix<f64, FRAME_DIM, FRAME_DIM>;
/// 9-vector.
pub type Vec9 = SVector<f64, FRAME_DIM>;

/// A border block transposed: frame rows × border columns.
pub type BorderT = OMatrix<f64, Const<FRAME_DIM>, Dyn>;

/// Information matrix and vector of the window, in arrow form.
#[derive(Clone, Debug)]
pub struct ArrowSystem {
    /// `H_kk` per frame.
    pub diag: Vec<Block>,
    /// `H_{k+1,k}` per consecutive pair (length `n − 1`).
    pub lower: Vec<Block>,
    /// `H_{k,B}` per frame (9 × border columns; `H_{B,k}` transposed, the layout the
    /// factorization works in).
    pub frame_border: Vec<BorderT>,
    /// `H_BB`.
    pub corner: DMatrix<f64>,
    /// Information vector of the frames.
    pub rhs_frames: Vec<Vec9>,
    /// Information vector of the border.
    pub rhs_border: DVector<f64>,
}

/// The solution and what comes with it.
#[derive(Clone, Debug)]
pub struct ArrowSolution {
    /// Per-frame `[p, v, g]`.
    pub frames: Vec<Vec9>,
    /// The border.
    pub border: DVector<f64>,
    /// Marginal covariance of the border.
    pub border_covariance: DMatrix<f64>,
}

impl ArrowSystem {
    /// All zeros for `n` frames and a border of `m`.
    pub fn zeros(n: usize, m: usize) -> Self {
        Self {
            diag: vec![Block::zeros(); n],
            lower: vec![Block::zeros(); n.saturating_sub(1)],
            frame_border: vec![BorderT::zeros_generic(Const::<FRAME_DIM>, Dyn(m)); n],
            corner: DMatrix::zeros(m, m),
            rhs_frames: vec![Vec9::zeros(); n],
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
    pub fn solve(&self) -> Option<ArrowSolution> {
        self.clone().into_solution()
    }

    /// [`ArrowSystem::solve`] on a system that is not needed afterwards (scaled in place, no
    /// copy).
    pub fn into_solution(mut self) -> Option<ArrowSolution> {
        let inv_sqrt = |d: f64| {
            if d > 0.0 && d.is_finite() {
                1.0 / d.sqrt()
            } else {
                1.0
            }
        };
        let s_frames: Vec<Vec9> = self
            .diag
            .iter()
            .map(|d| Vec9::from_fn(|i, _| inv_sqrt(d[(i, i)])))
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
                    *d += Block::identity() * mu;
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
        Some(sol)
    }

    /// `D H D` and `D b` in place, `D` = diag(`s_frames`, `s_border`).
    fn scale(&mut self, s_frames: &[Vec9], s_border: &DVector<f64>) {
        let scale_block = |m: &mut Block, si: &Vec9, sj: &Vec9| {
            for j in 0..FRAME_DIM {
                for i in 0..FRAME_DIM {
                    m[(i, j)] *= si[i] * sj[j];
                }
            }
        };
        let m = self.border_dim();
        for (k, s) in s_frames.iter().enumerate() {
            scale_block(&mut self.diag[k], s, s);
            if let Some(next) = s_frames.get(k + 1) {
                scale_block(&mut self.lower[k], next, s);
            }
            let b = &mut self.frame_border[k];
            for c in 0..m {
                for r in 0..FRAME_DIM {
                    b[(r, c)] *= s[r] * s_border[c];
                }
            }
            self.rhs_frames[k].component_mul_assign(s);
        }
        scale_both_sides(&mut self.corner, s_border);
        self.rhs_border.component_mul_assign(s_border);
    }

    /// The block Cholesky solve without scaling.
    fn solve_unscaled(&self) -> Option<ArrowSolution> {
        let n = self.frames();
        let m = self.border_dim();
        let mut l_diag: Vec<Block> = Vec::with_capacity(n);
        let mut l_lower: Vec<Block> = Vec::with_capacity(n.saturating_sub(1));
        // `L_B,kᵀ = L_kk⁻¹ (H_B,k − L_B,k−1 L_k,k−1ᵀ)ᵀ`, kept transposed (9 × m).
        let mut l_border_t: Vec<BorderT> = Vec::with_capacity(n);
        // Forward substitution runs alongside: y_k = L_kk⁻¹ (b_k − L_k,k−1 y_k−1).
        let mut y_frames: Vec<Vec9> = Vec::with_capacity(n);
        let mut schur = self.corner.clone();
        let mut y_border_acc = self.rhs_border.clone();
        for k in 0..n {
            let mut a = self.diag[k];
            let mut bt = self.frame_border[k].clone();
            let mut rhs = self.rhs_frames[k];
            if k > 0 {
                let lk = &l_lower[k - 1];
                a -= lk * lk.transpose();
                for (col, prev) in bt
                    .as_mut_slice()
                    .chunks_exact_mut(FRAME_DIM)
                    .zip(l_border_t[k - 1].as_slice().chunks_exact(FRAME_DIM))
                {
                    let d = lk * Vec9::from_column_slice(prev);
                    col.iter_mut().zip(d.iter()).for_each(|(c, d)| *c -= d);
                }
                rhs -= lk * y_frames[k - 1];
            }
            let l = Cholesky::new(a)?.unpack();
            forward_substitute(&l, bt.as_mut_slice());
            forward_substitute(&l, rhs.as_mut_slice());
            if k + 1 < n {
                let mut lo_t: Block = self.lower[k].transpose();
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
        let mut frames = vec![Vec9::zeros(); n];
        for k in (0..n).rev() {
            let mut r = y_frames[k];
            if k + 1 < n {
                r -= l_lower[k].transpose() * frames[k + 1];
            }
            for (col, x) in l_border_t[k]
                .as_slice()
                .chunks_exact(FRAME_DIM)
                .zip(border.iter())
            {
                r.iter_mut().zip(col).for_each(|(r, c)| *r -= c * x);
            }
            back_substitute(&l_diag[k], &mut r);
            frames[k] = r;
        }
        Some(ArrowSolution {
            frames,
            border,
            border_covariance,
        })
    }

    /// The same system as one dense matrix and vector (for tests and the reference solve).
    pub fn to_dense(&self) -> (DMatrix<f64>, DVector<f64>) {
        let n = self.frames();
        let m = self.border_dim();
        let dim = n * FRAME_DIM + m;
        let mut h = DMatrix::zeros(dim, dim);
        let mut b = DVector::zeros(dim);
        let bo = n * FRAME_DIM;
        for k in 0..n {
            let o = k * FRAME_DIM;
            h.view_mut((o, o), (FRAME_DIM, FRAME_DIM))
                .copy_from(&self.diag[k]);
            b.rows_mut(o, FRAME_DIM).copy_from(&self.rhs_frames[k]);
            if k + 1 < n {
                h.view_mut((o + FRAME_DIM, o), (FRAME_DIM, FRAME_DIM))
                    .copy_from(&self.lower[k]);
                h.view_mut((o, o + FRAME_DIM), (FRAME_DIM, FRAME_DIM))
                    .copy_from(&self.lower[k].transpose());
            }
            if m > 0 {
                h.view_mut((bo, o), (m, FRAME_DIM))
                    .copy_from(&self.frame_border[k].transpose());
                h.view_mut((o, bo), (FRAME_DIM, m))
                    .copy_from(&self.frame_border[k]);
            }
        }
        if m > 0 {
            h.view_mut((bo, bo), (m, m)).copy_from(&self.corner);
            b.rows_mut(bo, m).copy_from(&self.rhs_border);
        }
        (h, b)
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
/// given as consecutive 9-element columns (column-major storage).
pub(super) fn forward_substitute(l: &Block, columns: &mut [f64]) {
    let inv_diag = Vec9::from_fn(|i, _| 1.0 / l[(i, i)]);
    for col in columns.chunks_exact_mut(FRAME_DIM) {
        for i in 0..FRAME_DIM {
            let mut v = col[i];
            for j in 0..i {
                v -= l[(i, j)] * col[j];
            }
            col[i] = v * inv_diag[i];
        }
    }
}

/// `x ← L⁻ᵀ x` for a lower-triangular `l` with a positive diagonal (a Cholesky factor).
fn back_substitute(l: &Block, x: &mut Vec9) {
    for i in (0..FRAME_DIM).rev() {
        let mut v = x[i];
        for j in i + 1..FRAME_DIM {
            v -= l[(j, i)] * x[j];
        }
        x[i] = v / l[(i, i)];
    }
}

/// `S ← S − Bᵀ B` on the lower triangle of `S` only (`B` is 9 × m; the caller mirrors it).
/// Columns as `[f64; 9]` so the dot products unroll.
fn subtract_gram_lower(s: &mut DMatrix<f64>, b: &BorderT) {
    let m = s.nrows();
    let (cols, _) = b.as_slice().as_chunks::<FRAME_DIM>();
    let s = s.as_mut_slice();
    for (j, cj) in cols.iter().enumerate() {
        let s_col = &mut s[j * m..(j + 1) * m];
        for (i, ci) in cols.iter().enumerate().skip(j) {
            let mut dot = 0.0;
            for r in 0..FRAME_DIM {
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

    /// A random positive definite arrow system.
    fn random(n: usize, m: usize, seed: u64) -> ArrowSystem {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut s = ArrowSystem::zeros(n, m);
        // Sum of random rank-limited factors with the arrow's sparsity.
        for k in 0..n {
            let j = DMatrix::from_fn(12, 2 * FRAME_DIM + m, |_, _| rng.random::<f64>() - 0.5);
            let jt_j = j.transpose() * &j;
            let two = if k + 1 < n { 2 } else { 1 };
            for a in 0..two {
                for c in 0..two {
                    let blk: Block = jt_j
                        .fixed_view::<FRAME_DIM, FRAME_DIM>(a * FRAME_DIM, c * FRAME_DIM)
                        .into_owned();
                    match (a, c) {
                        (0, 0) => s.diag[k] += blk,
                        (1, 1) => s.diag[k + 1] += blk,
                        (1, 0) => s.lower[k] += blk,
                        _ => {}
                    }
                }
                let bb = jt_j.view((a * FRAME_DIM, 2 * FRAME_DIM), (FRAME_DIM, m));
                s.frame_border[k + a] += bb;
            }
            s.corner += jt_j.view((2 * FRAME_DIM, 2 * FRAME_DIM), (m, m));
            s.diag[k] += Block::identity() * 0.1;
            s.rhs_frames[k] = Vec9::from_fn(|_, _| rng.random::<f64>() - 0.5);
        }
        s.corner += DMatrix::identity(m, m) * 0.1;
        s.rhs_border = DVector::from_fn(m, |_, _| rng.random::<f64>() - 0.5);
        s
    }

    #[test]
    fn arrow_cholesky_matches_a_dense_solve() {
        for (n, m, seed) in [(1, 0, 1), (2, 3, 2), (30, 6, 3), (7, 12, 4)] {
            let s = random(n, m, seed);
            let sol = s.solve().unwrap();
            let (h, b) = s.to_dense();
            let dense = h.clone().cholesky().unwrap();
            let x = dense.solve(&b);
            for k in 0..n {
                let d = (sol.frames[k] - x.rows(k * FRAME_DIM, FRAME_DIM)).norm();
                assert!(d < 1e-9 * (1.0 + x.norm()), "n {n} m {m} frame {k}: {d}");
            }
            if m > 0 {
                assert!((&sol.border - x.rows(n * FRAME_DIM, m)).norm() < 1e-9 * (1.0 + x.norm()));
                let cov = dense.inverse();
                let cb = cov.view((n * FRAME_DIM, n * FRAME_DIM), (m, m));
                assert!((&sol.border_covariance - cb).norm() < 1e-9 * (1.0 + cb.norm()));
            }
        }
    }

    #[test]
    fn indefinite_systems_are_refused() {
        let mut s = random(3, 3, 5);
        s.diag[1] = -Block::identity();
        assert!(s.solve().is_none());
    }
}
