//! Marginalizing the oldest frame (docs/DESIGN.md §5): the Schur complement of ONLY the factors that
//! touch it (the prior, its IMU factor to the next frame, its AoA factors), as VINS-Mono does.
//! Every other factor stays in the window and is counted once.

use nalgebra::DMatrix;

use super::SlidingWindow;
use crate::fusion::arrow::FRAME_DIM;

impl SlidingWindow {
    /// Replaces the prior by the one on `[x_1, border]` and drops frame 0.
    pub(super) fn marginalize_oldest(&mut self) {
        let (h, b) = self.assemble(2.min(self.frames.len()), true).to_dense();
        let dim = h.nrows();
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
        self.prior.b = br - &k * b0;
        self.prior.h = new_h;
        self.frames.pop_front();
        self.marginalized += 1;
    }
}
