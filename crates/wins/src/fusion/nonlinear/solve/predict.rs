//! The window's own prediction of a bearing, with the σ its joint covariance gives it: what the
//! pipeline's state gate compares a packet's angle with (`PipelineConfig::gate_sigmas`).
//!
//! At the newest keyframe `x_n`, toward AP `l` at `c_l`, the cone model of
//! [`crate::fusion::nonlinear::factors::cone`] predicts `s = sin θ (+ β)`; to first order its
//! variance is
//!
//! ```text
//! σ_s² = J Σ Jᵀ,   J = [∂s/∂δx_n, ∂s/∂c_l, ∂s/∂β = 1],
//! Σ = [[Σ_nn, Σ_nB], [Σ_Bn, Σ_BB]] restricted to x_n, c_l and β
//! ```
//!
//! with the cross-covariance `Σ_nB` of the keyframe and the border kept: the AP and the pose are
//! both uncertain in the same world frame, and only their relative uncertainty moves the angle.

use nalgebra::DVector;

use super::NonlinearWindow;
use crate::fusion::nonlinear::factors::cone::cone_jacobian;
use crate::imu::Preintegrated;

impl NonlinearWindow {
    /// The sine of the cone angle toward AP `l` the window predicts at its newest keyframe (with
    /// the bearings' common offset β when estimated), and its σ (module doc). `None` when the
    /// AP is not placed, there is no keyframe, or the last solve's covariance does not cover
    /// the AP yet.
    pub fn predicted_sin(&self, l: usize) -> Option<(f64, f64)> {
        let kf = self.keyframes.back()?;
        let c = self.ap(l)?;
        let partial = Preintegrated::empty(kf.x.t, kf.x.biases());
        let j = cone_jacobian(
            &kf.x,
            &partial,
            self.model.gravity_m_s2,
            &self.model.body_from_array,
            &c,
            0.0,
        )?;
        let m = self.border_dim();
        let cov = &self.covariance;
        if cov.border.nrows() != m || cov.newest_border.ncols() != m {
            return None;
        }
        // J over [x_n, border]: the AP's three columns and β's one.
        let mut j_border = DVector::zeros(m);
        let o = self.ap_offset(l);
        for i in 0..3 {
            j_border[o + i] = j.d_ap[i];
        }
        let beta = self.bias.map(|(b, _)| {
            j_border[self.scalars() - 1] = 1.0;
            b
        });
        let variance = (j.d_state * cov.newest * j.d_state.transpose())[0]
            + 2.0 * (j.d_state * &cov.newest_border * &j_border)[0]
            + (j_border.transpose() * &cov.border * &j_border)[0];
        Some((j.residual + beta.unwrap_or(0.0), variance.max(0.0).sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, Matrix3, Vector3};

    use crate::fusion::arrow::BorderTOf;
    use crate::fusion::nonlinear::factors::cone::cone_residual;
    use crate::fusion::nonlinear::solve::aps::tests::window;
    use crate::fusion::nonlinear::state::{POS, STATE_DIM, Vec15};
    use crate::imu::Preintegrated;

    /// The predicted σ is the joint covariance carried through central differences of the cone
    /// residual (over the keyframe's error state and the AP), cross terms included: a prior
    /// that ties the AP to the pose (both move together) leaves the angle certain.
    #[test]
    fn the_predicted_sigma_is_the_joint_covariance_through_the_cone_model() {
        let c = Vector3::new(4.0, 3.0, 2.5);
        let mut w = window(vec![Some(c)]);
        let m = w.border_dim();
        let o = w.ap_offset(0);
        let (s, sigma) = w.predicted_sin(0).expect("predicted");
        let kf = w.keyframes.back().expect("keyframe").x;
        let partial = Preintegrated::empty(kf.t, kf.biases());
        let model = w.model.clone();
        let r = |dx: &Vec15, dc: &Vector3<f64>| {
            cone_residual(
                &kf.boxplus(dx),
                &partial,
                model.gravity_m_s2,
                &model.body_from_array,
                &(c + dc),
                0.0,
            )
            .expect("in range")
        };
        assert!((s - r(&Vec15::zeros(), &Vector3::zeros())).abs() < 1e-12);
        // Central differences over [δx (15), δc (3)].
        let h = 1e-6;
        let mut jac = DMatrix::zeros(1, STATE_DIM + 3);
        for i in 0..STATE_DIM + 3 {
            let (mut dx, mut dc) = (Vec15::zeros(), Vector3::zeros());
            if i < STATE_DIM {
                dx[i] = h;
            } else {
                dc[i - STATE_DIM] = h;
            }
            jac[i] = (r(&dx, &dc) - r(&-dx, &-dc)) / (2.0 * h);
        }
        let joint = |w: &super::NonlinearWindow| {
            let mut p = DMatrix::zeros(STATE_DIM + 3, STATE_DIM + 3);
            let cov = &w.covariance;
            p.view_mut((0, 0), (STATE_DIM, STATE_DIM))
                .copy_from(&cov.newest);
            p.view_mut((STATE_DIM, STATE_DIM), (3, 3))
                .copy_from(&cov.border.view((o, o), (3, 3)));
            let cross = cov.newest_border.view((0, o), (STATE_DIM, 3)).into_owned();
            p.view_mut((0, STATE_DIM), (STATE_DIM, 3)).copy_from(&cross);
            p.view_mut((STATE_DIM, 0), (3, STATE_DIM))
                .copy_from(&cross.transpose());
            p
        };
        let expected = (&jac * joint(&w) * jac.transpose())[0].sqrt();
        assert!(
            (sigma - expected).abs() < 1e-6 * expected,
            "{sigma} {expected}"
        );
        assert!(
            sigma > 0.01,
            "a unit prior leaves the angle uncertain: {sigma}"
        );

        // The AP moving with the body's position (a prior tying the two): their relative
        // position, hence the angle, is far better known than either.
        w.covariance.newest = nalgebra::SMatrix::<f64, 15, 15>::identity() * 1e-8;
        let mut tied = DMatrix::zeros(m, m);
        tied.view_mut((o, o), (3, 3))
            .copy_from(&Matrix3::identity());
        w.covariance.border = tied;
        w.covariance
            .newest
            .view_mut((POS, POS), (3, 3))
            .fill_with_identity();
        let mut cross = BorderTOf::<STATE_DIM>::zeros(m);
        cross.view_mut((POS, o), (3, 3)).fill_with_identity();
        w.covariance.newest_border = cross;
        let (_, tied_sigma) = w.predicted_sin(0).expect("predicted");
        let expected = (&jac * joint(&w) * jac.transpose())[0].max(0.0).sqrt();
        assert!(
            (tied_sigma - expected).abs() < 1e-6,
            "{tied_sigma} {expected}"
        );
        assert!(tied_sigma < 1e-3, "{tied_sigma}");
    }
}
