//! The one factor interface: a factor linearized at its points, and the one function that adds
//! any such factor to the normal equations ([`ArrowSystem::add`]).
//!
//! A factor with residual `r` (R rows) touching frames `k` (Jacobian `J_k`, R × D) and border
//! blocks `c` (Jacobian `J_c`, R × 1…3) under a weight `W` (after its robust loss) adds
//! `J_aᵀ W J_b` to the information matrix for every pair of blocks it touches and `−J_aᵀ W r` to
//! the information vector. Adding a factor to an estimator means writing its residual and
//! Jacobians and returning a [`Linearized`]: the solver is not touched.

use nalgebra::{SMatrix, SVector};

use super::{ArrowSystem, At};

/// The weight of a factor's residual: its information (after the robust loss).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weight<const R: usize> {
    /// The same information on every row (a scalar measurement, or isotropic rows).
    Scalar(f64),
    /// A full information matrix (R × R).
    Matrix(SMatrix<f64, R, R>),
}

/// A factor's Jacobian with respect to border columns `offset .. offset + cols` (`cols` ≤ 3; the
/// columns past `cols` are ignored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BorderBlock<const R: usize> {
    /// The first border column.
    pub offset: usize,
    /// How many columns (1 to 3).
    pub cols: usize,
    /// `∂r/∂(those columns)`, R × 3 (only the first `cols` columns count).
    pub jacobian: SMatrix<f64, R, 3>,
}

impl<const R: usize> BorderBlock<R> {
    /// A block of three columns (an AP's position).
    pub fn three(offset: usize, jacobian: SMatrix<f64, R, 3>) -> Self {
        Self {
            offset,
            cols: 3,
            jacobian,
        }
    }

    /// A block of one column (a scalar of the border: the barometer offset, the bearings'
    /// common offset).
    pub fn one(offset: usize, jacobian: SVector<f64, R>) -> Self {
        let mut j = SMatrix::<f64, R, 3>::zeros();
        j.set_column(0, &jacobian);
        Self {
            offset,
            cols: 1,
            jacobian: j,
        }
    }
}

/// A factor linearized: the states it touches with its Jacobian blocks, its residual at the
/// current estimate, and its weight (module doc). At most two frames and two border blocks.
#[derive(Clone, Debug, PartialEq)]
pub struct Linearized<const R: usize, const D: usize> {
    /// `(k, ∂r/∂δx_k)` per frame touched.
    frames: [Option<(usize, SMatrix<f64, R, D>)>; 2],
    /// The border blocks touched.
    border: [Option<BorderBlock<R>>; 2],
    /// `r`.
    pub residual: SVector<f64, R>,
    /// `W`.
    pub weight: Weight<R>,
}

impl<const R: usize, const D: usize> Linearized<R, D> {
    /// A factor on frame `k` alone.
    pub fn on_frame(
        k: usize,
        jacobian: SMatrix<f64, R, D>,
        residual: SVector<f64, R>,
        weight: Weight<R>,
    ) -> Self {
        Self {
            frames: [Some((k, jacobian)), None],
            border: [None, None],
            residual,
            weight,
        }
    }

    /// A factor between frames `k` and `l` (neighbours).
    pub fn between(
        (k, j_k): (usize, SMatrix<f64, R, D>),
        (l, j_l): (usize, SMatrix<f64, R, D>),
        residual: SVector<f64, R>,
        weight: Weight<R>,
    ) -> Self {
        Self {
            frames: [Some((k, j_k)), Some((l, j_l))],
            border: [None, None],
            residual,
            weight,
        }
    }

    /// The same factor touching a border block too (at most two; a third is ignored).
    pub fn with_border(mut self, block: BorderBlock<R>) -> Self {
        if let Some(free) = self.border.iter_mut().find(|b| b.is_none()) {
            *free = Some(block);
        }
        self
    }

    /// The frames touched, with their Jacobians.
    pub fn frames(&self) -> impl Iterator<Item = &(usize, SMatrix<f64, R, D>)> {
        self.frames.iter().flatten()
    }

    /// The border blocks touched.
    pub fn border(&self) -> impl Iterator<Item = &BorderBlock<R>> {
        self.border.iter().flatten()
    }
}

impl<const D: usize> ArrowSystem<D> {
    /// Adds any linearized factor (module doc): `J_aᵀ W J_b` for every pair of blocks it
    /// touches, `−J_aᵀ W r` to the information vector.
    pub fn add<const R: usize>(&mut self, f: &Linearized<R, D>) {
        match &f.weight {
            Weight::Scalar(w) => self.add_scalar_weighted(f, *w),
            Weight::Matrix(w) => self.add_matrix_weighted(f, w),
        }
    }

    fn add_scalar_weighted<const R: usize>(&mut self, f: &Linearized<R, D>, w: f64) {
        let wr = f.residual * w;
        for (a, (k, j_k)) in f.frames().enumerate() {
            self.diag[*k] += j_k.transpose() * j_k * w;
            self.rhs_frames[*k] -= j_k.transpose() * wr;
            for (l, j_l) in f.frames().take(a) {
                self.add_information(
                    At::Frame(*k, 0),
                    At::Frame(*l, 0),
                    &(j_k.transpose() * j_l * w),
                );
            }
            for c in f.border() {
                let block = j_k.transpose() * c.jacobian * w;
                let mut fb = self.frame_border[*k].columns_mut(c.offset, c.cols);
                fb += block.columns(0, c.cols);
            }
        }
        for (a, c) in f.border().enumerate() {
            let block = c.jacobian.transpose() * c.jacobian * w;
            let mut corner = self.corner.view_mut((c.offset, c.offset), (c.cols, c.cols));
            corner += block.view((0, 0), (c.cols, c.cols));
            let mut rb = self.rhs_border.rows_mut(c.offset, c.cols);
            rb -= (c.jacobian.transpose() * wr).rows(0, c.cols);
            for d in f.border().take(a) {
                let block = c.jacobian.transpose() * d.jacobian * w;
                self.add_information(
                    At::Border(c.offset),
                    At::Border(d.offset),
                    &block.view((0, 0), (c.cols, d.cols)),
                );
            }
        }
    }

    fn add_matrix_weighted<const R: usize>(
        &mut self,
        f: &Linearized<R, D>,
        w: &SMatrix<f64, R, R>,
    ) {
        // `J_kᵀ W` per frame slot (the slots fill from the first).
        let jt_w = f.frames.map(|fr| fr.map(|(_, j)| j.transpose() * w));
        for (a, (k, j_k)) in f.frames().enumerate() {
            let Some(jt_w_k) = &jt_w[a] else {
                continue;
            };
            self.diag[*k] += jt_w_k * j_k;
            self.rhs_frames[*k] -= jt_w_k * f.residual;
            // The block below the diagonal, `(J_lᵀ W) J_k` for `l = k + 1`.
            for (b, (l, _)) in f.frames().enumerate() {
                if let (true, Some(jt_w_l)) = (*l == k + 1, &jt_w[b]) {
                    self.lower[*k] += jt_w_l * j_k;
                }
            }
            for c in f.border() {
                let block = jt_w_k * c.jacobian;
                let mut fb = self.frame_border[*k].columns_mut(c.offset, c.cols);
                fb += block.columns(0, c.cols);
            }
        }
        for (a, c) in f.border().enumerate() {
            let ct_w = c.jacobian.transpose() * w;
            let mut corner = self.corner.view_mut((c.offset, c.offset), (c.cols, c.cols));
            corner += (ct_w * c.jacobian).view((0, 0), (c.cols, c.cols));
            let mut rb = self.rhs_border.rows_mut(c.offset, c.cols);
            rb -= (ct_w * f.residual).rows(0, c.cols);
            for d in f.border().take(a) {
                let block = ct_w * d.jacobian;
                self.add_information(
                    At::Border(c.offset),
                    At::Border(d.offset),
                    &block.view((0, 0), (c.cols, d.cols)),
                );
            }
        }
    }
}
