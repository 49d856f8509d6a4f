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

use nalgebra::{Const, DMatrix, DVector, Dim, Dyn, Matrix, OMatrix, SMatrix, SVector, Storage};

mod cholesky;
mod factor;

pub(crate) use self::cholesky::forward_substitute;
pub use self::factor::{BorderBlock, Linearized, Weight};

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
///
/// Factors enter in one of two forms: linearized (Jacobian blocks, residual, weight:
/// [`ArrowSystem::add`], every factor of the default estimator), or already in information form
/// ([`ArrowSystem::add_information`], [`ArrowSystem::add_rhs`]: a marginalization prior, the
/// paper's linear factors). Where an entry lives in the arrow is this type's business alone.
#[derive(Clone, Debug)]
pub struct ArrowSystem<const D: usize = FRAME_DIM> {
    /// `H_kk` per frame.
    diag: Vec<BlockOf<D>>,
    /// `H_{k+1,k}` per consecutive pair (length `n − 1`).
    lower: Vec<BlockOf<D>>,
    /// `H_{k,B}` per frame (D × border columns; `H_{B,k}` transposed, the layout the
    /// factorization works in).
    frame_border: Vec<BorderTOf<D>>,
    /// `H_BB`.
    corner: DMatrix<f64>,
    /// Information vector of the frames.
    rhs_frames: Vec<VecOf<D>>,
    /// Information vector of the border.
    rhs_border: DVector<f64>,
}

/// Where a block of the system is: frame `k` from its state's row `offset`, or the border from
/// its column `offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    /// Frame `k`, from its row `offset`.
    Frame(usize, usize),
    /// The border, from its column `offset`.
    Border(usize),
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

    /// Adds an information block `H_rc += block` for the rows at `row` and the columns at `col`,
    /// and its mirror `H_cr += blockᵀ` when the two are different states (the matrix is
    /// symmetric; the arrow stores one of the two where it can). Frames more than one apart have
    /// no block in an arrow: such a block is a caller's error and is not added.
    pub fn add_information<R: Dim, C: Dim, S: Storage<f64, R, C>>(
        &mut self,
        row: At,
        col: At,
        block: &Matrix<f64, R, C, S>,
    ) {
        match (row, col) {
            (At::Frame(i, oi), At::Frame(j, oj)) if i == j => {
                add_block(&mut self.diag[i], (oi, oj), block, false);
            }
            (At::Frame(i, oi), At::Frame(j, oj)) if i == j + 1 => {
                add_block(&mut self.lower[j], (oi, oj), block, false);
            }
            (At::Frame(i, oi), At::Frame(j, oj)) if j == i + 1 => {
                add_block(&mut self.lower[i], (oj, oi), block, true);
            }
            (At::Frame(k, oi), At::Border(o)) => {
                add_block(&mut self.frame_border[k], (oi, o), block, false);
            }
            (At::Border(o), At::Frame(k, oj)) => {
                add_block(&mut self.frame_border[k], (oj, o), block, true);
            }
            (At::Border(a), At::Border(b)) => {
                add_block(&mut self.corner, (a, b), block, false);
                if a != b {
                    add_block(&mut self.corner, (b, a), block, true);
                }
            }
            _ => debug_assert!(false, "no arrow block between {row:?} and {col:?}"),
        }
    }

    /// Adds `v` to the information vector at `at`.
    pub fn add_rhs<R: Dim, S: Storage<f64, R>>(&mut self, at: At, v: &Matrix<f64, R, Const<1>, S>) {
        match at {
            At::Frame(k, o) => {
                for (i, x) in v.iter().enumerate() {
                    self.rhs_frames[k][o + i] += x;
                }
            }
            At::Border(o) => {
                for (i, x) in v.iter().enumerate() {
                    self.rhs_border[o + i] += x;
                }
            }
        }
    }

    /// Adds a prior in information form over `[frame 0, the border's first columns]`: `h`
    /// (square, at least D) and `rhs` of the same size.
    pub fn add_prior(&mut self, h: &DMatrix<f64>, rhs: &DVector<f64>) {
        if self.frames() == 0 {
            return;
        }
        let mb = h.nrows() - D;
        self.diag[0] += h.fixed_view::<D, D>(0, 0);
        if mb > 0 {
            let mut fb = self.frame_border[0].columns_mut(0, mb);
            fb += h.view((0, D), (D, mb));
            let mut corner = self.corner.view_mut((0, 0), (mb, mb));
            corner += h.view((D, D), (mb, mb));
            let mut rb = self.rhs_border.rows_mut(0, mb);
            rb += rhs.rows(D, mb);
        }
        self.rhs_frames[0] += rhs.fixed_rows::<D>(0);
    }

    /// The system with `λ · diag + floor` added to the diagonal (Levenberg–Marquardt damping
    /// relative to the diagonal, with an absolute floor for directions nothing constrains).
    pub fn damped(&self, lambda: f64, floor: f64) -> Self {
        let mut d = self.clone();
        for b in &mut d.diag {
            for i in 0..D {
                b[(i, i)] += lambda * b[(i, i)] + floor;
            }
        }
        for i in 0..d.corner.nrows() {
            let v = d.corner[(i, i)];
            d.corner[(i, i)] += lambda * v + floor;
        }
        d
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

/// `target[(r0 + i, c0 + j)] += b_ij`, or with `mirror` the transpose: `target[(r0 + j, c0 + i)]`.
fn add_block<T, R: Dim, C: Dim, S: Storage<f64, R, C>>(
    target: &mut T,
    (r0, c0): (usize, usize),
    block: &Matrix<f64, R, C, S>,
    mirror: bool,
) where
    T: std::ops::IndexMut<(usize, usize), Output = f64>,
{
    let (nr, nc) = block.shape();
    for j in 0..nc {
        for i in 0..nr {
            let v = block[(i, j)];
            if mirror {
                target[(r0 + j, c0 + i)] += v;
            } else {
                target[(r0 + i, c0 + j)] += v;
            }
        }
    }
}

#[cfg(test)]
mod tests;
