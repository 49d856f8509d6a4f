//! Marginalizing the oldest frame (DESIGN.md §5): the Schur complement of ONLY the factors that
//! touch it (the prior, its IMU factor to the next frame, its AoA factors), as VINS-Mono does.
//! Every other factor stays in the window and is counted once.

use std::ops::AddAssign;

use nalgebra::{DMatrix, DVector};

use super::SlidingWindow;
use super::arrow::FRAME_DIM;

impl SlidingWindow {
    /// Replaces the prior by the one on `[x_1, border]` and drops frame 0.
    pub(super) fn marginalize_oldest(&mut self) {
        let m = 3 + 3 * self.num_aps;
        let dim = 2 * FRAME_DIM + m;
        let bo = 2 * FRAME_DIM;
        let mut h = DMatrix::<f64>::zeros(dim, dim);
        let mut b = DVector::<f64>::zeros(dim);
        // Prior on [x0, border(0..pb)].
        let pb = self.prior_h.nrows() - FRAME_DIM;
        h.view_mut((0, 0), (FRAME_DIM, FRAME_DIM))
            .add_assign(&self.prior_h.view((0, 0), (FRAME_DIM, FRAME_DIM)));
        h.view_mut((bo, 0), (pb, FRAME_DIM))
            .add_assign(&self.prior_h.view((FRAME_DIM, 0), (pb, FRAME_DIM)));
        h.view_mut((0, bo), (FRAME_DIM, pb))
            .add_assign(&self.prior_h.view((0, FRAME_DIM), (FRAME_DIM, pb)));
        h.view_mut((bo, bo), (pb, pb))
            .add_assign(&self.prior_h.view((FRAME_DIM, FRAME_DIM), (pb, pb)));
        b.rows_mut(0, FRAME_DIM)
            .add_assign(&self.prior_b.rows(0, FRAME_DIM));
        b.rows_mut(bo, pb)
            .add_assign(&self.prior_b.rows(FRAME_DIM, pb));
        if self.frames.len() > 1
            && let Some(info) = self.imu_factor(0)
        {
            let f = FRAME_DIM;
            h.fixed_view_mut::<9, 9>(0, 0).add_assign(&info.h_kk);
            h.fixed_view_mut::<9, 9>(f, f).add_assign(&info.h_ll);
            h.fixed_view_mut::<9, 9>(f, 0).add_assign(&info.h_lk);
            h.fixed_view_mut::<9, 9>(0, f)
                .add_assign(&info.h_lk.transpose());
            h.fixed_view_mut::<9, 3>(0, bo).add_assign(&info.h_kb);
            h.fixed_view_mut::<3, 9>(bo, 0)
                .add_assign(&info.h_kb.transpose());
            h.fixed_view_mut::<9, 3>(f, bo).add_assign(&info.h_lb);
            h.fixed_view_mut::<3, 9>(bo, f)
                .add_assign(&info.h_lb.transpose());
            h.fixed_view_mut::<3, 3>(bo, bo).add_assign(&info.h_bb);
            b.fixed_rows_mut::<9>(0).add_assign(&info.b_k);
            b.fixed_rows_mut::<9>(f).add_assign(&info.b_l);
            b.fixed_rows_mut::<3>(bo).add_assign(&info.b_b);
        }
        let aoa: Vec<_> = self.aoa_factors(0).collect();
        for (l, info) in aoa {
            let o = bo + 3 + 3 * l;
            h.fixed_view_mut::<3, 3>(0, 0).add_assign(&info.n);
            h.fixed_view_mut::<3, 3>(o, o).add_assign(&info.n);
            h.fixed_view_mut::<3, 3>(o, 0).add_assign(&(-info.n));
            h.fixed_view_mut::<3, 3>(0, o).add_assign(&(-info.n));
            b.fixed_rows_mut::<3>(0).add_assign(&(-info.b_c));
            b.fixed_rows_mut::<3>(o).add_assign(&info.b_c);
        }
        // Schur complement of x0.
        let h00 = h.view((0, 0), (FRAME_DIM, FRAME_DIM)).into_owned();
        let h0r = h
            .view((0, FRAME_DIM), (FRAME_DIM, dim - FRAME_DIM))
            .into_owned();
        let hrr = h.view((FRAME_DIM, FRAME_DIM), (dim - FRAME_DIM, dim - FRAME_DIM));
        let b0 = b.rows(0, FRAME_DIM).into_owned();
        let br = b.rows(FRAME_DIM, dim - FRAME_DIM);
        let inv00 = match h00.clone().cholesky() {
            Some(c) => c.inverse(),
            // Cannot happen with the gauge and weak priors; a pseudo-inverse keeps it finite.
            None => h00
                .pseudo_inverse(1e-12)
                .unwrap_or_else(|_| DMatrix::zeros(9, 9)),
        };
        let k = h0r.transpose() * &inv00;
        let mut new_h = hrr - &k * &h0r;
        new_h = (&new_h + new_h.transpose()) * 0.5;
        self.prior_b = br - &k * b0;
        self.prior_h = new_h;
        self.frames.pop_front();
        self.marginalized += 1;
    }
}
