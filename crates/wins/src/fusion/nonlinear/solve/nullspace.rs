//! The window's true nullspace (translation and yaw about the vertical), against which its
//! information is tested (first-estimate Jacobians keep it; [`crate::fusion::nonlinear::solve`]).

use nalgebra::{DMatrix, Vector3};

use crate::fusion::nonlinear::solve::NonlinearWindow;
use crate::fusion::nonlinear::state::{POS, STATE_DIM, THETA, VEL, Vec15};

impl NonlinearWindow {
    /// The 4 directions no data can see, at the linearization points: translation along x, y,
    /// z (the barometer offset moving against z) and yaw about the vertical (`δθ_k = R_kᵀ e_z`,
    /// `δp = e_z × p`, `δv = e_z × v`, `δc = e_z × c`), as columns over (frames, border).
    pub fn nullspace(&self) -> DMatrix<f64> {
        let n = self.keyframes.len();
        let nb = usize::from(self.baro.is_some());
        let dim = n * STATE_DIM + self.border_dim();
        let mut nsp = DMatrix::zeros(dim, 4);
        let ez = Vector3::z();
        for (k, kf) in self.keyframes.iter().enumerate() {
            let x = kf.lin_or_current(self.model.fej);
            let o = k * STATE_DIM;
            for a in 0..3 {
                nsp[(o + POS + a, a)] = 1.0;
            }
            let yaw = {
                let mut y = Vec15::zeros();
                y.fixed_rows_mut::<3>(THETA)
                    .copy_from(&(x.world_from_body.inverse() * ez));
                y.fixed_rows_mut::<3>(POS).copy_from(&ez.cross(&x.p_b_in_w));
                y.fixed_rows_mut::<3>(VEL).copy_from(&ez.cross(&x.v_b_in_w));
                y
            };
            nsp.view_mut((o, 3), (STATE_DIM, 1)).copy_from(&yaw);
        }
        let bo = n * STATE_DIM;
        if nb == 1 {
            nsp[(bo, 2)] = -1.0;
        }
        for (l, c) in self.aps.iter().enumerate() {
            let c = match self.ap_lin[l] {
                Some(lin) if self.model.fej => lin,
                _ => *c,
            };
            let o = bo + self.ap_offset(l);
            for a in 0..3 {
                nsp[(o + a, a)] = 1.0;
            }
            nsp.view_mut((o, 3), (3, 1)).copy_from(&ez.cross(&c));
        }
        nsp
    }
}
