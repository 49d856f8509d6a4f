//! The estimator's output: the newest keyframe carried by the IMU to a frame or to the last
//! sample, with the covariance of `[δθ, δp]`, in the output frame.

use nalgebra::{Matrix3, Matrix6};

use crate::fusion::nonlinear::estimator::NonlinearEstimator;
use crate::fusion::nonlinear::state::{NavState, POS, THETA, pose_at, pose_at_jacobians};
use crate::fusion::pose::PoseEstimate;
use crate::imu::{Preintegrated, STANDARD_GRAVITY_M_S2};
use crate::time::Timestamp;

impl NonlinearEstimator {
    /// The newest keyframe (and the frames since) as the pose at `t`, with its covariance.
    pub(super) fn pose_now(&self, t: Timestamp) -> Option<PoseEstimate> {
        let tracking = self.phase.tracking()?;
        let w = &tracking.window;
        let x = w.newest()?;
        let partial = self.since_keyframe.as_ref()?;
        if partial.end != t {
            return None;
        }
        // A keyframe not solved yet: its predicted state is the one before it carried by the
        // IMU between them, and so is its covariance, with the IMU's noise over that interval.
        if tracking.solve_due == Some(t) {
            let n = w.keyframes.len();
            if let (Some(prev), Some(Some((between, _)))) = (
                n.checked_sub(2).and_then(|i| w.keyframes.get(i)),
                w.keyframes.back().map(|k| k.from_prev.as_ref()),
            ) {
                return Some(self.output(&prev.x, between, w.newest_covariance()));
            }
        }
        Some(self.output(x, partial, w.newest_covariance()))
    }

    /// The pose at the end of `partial` after keyframe `x`, in the output frame.
    fn output(
        &self,
        x: &NavState,
        partial: &Preintegrated,
        cov_x: &crate::fusion::nonlinear::state::Mat15,
    ) -> PoseEstimate {
        let g = STANDARD_GRAVITY_M_S2;
        let p = pose_at(x, partial, g);
        let (j_rot, j_pos, _) = pose_at_jacobians(x, partial, g);
        let mut j = nalgebra::SMatrix::<f64, 6, 15>::zeros();
        j.fixed_view_mut::<3, 15>(0, 0).copy_from(&j_rot);
        j.fixed_view_mut::<3, 15>(3, 0).copy_from(&j_pos);
        let mut cov: Matrix6<f64> = j * cov_x * j.transpose();
        // The IMU's own noise over the partial interval: [δα, δβ, δθ] → (θ, p).
        let r = x.world_from_body.to_rotation_matrix().into_inner();
        let c = &partial.covariance;
        let mut add = Matrix6::zeros();
        add.fixed_view_mut::<3, 3>(THETA, THETA)
            .copy_from(&c.fixed_view::<3, 3>(6, 6));
        add.fixed_view_mut::<3, 3>(POS, POS)
            .copy_from(&(r * c.fixed_view::<3, 3>(0, 0) * r.transpose()));
        cov += add;
        // Into the output frame: positions rotate with the anchor; δθ is body-side.
        let ra: Matrix3<f64> = self.anchor.rotation.to_rotation_matrix().into_inner();
        let mut rot6 = Matrix6::identity();
        rot6.fixed_view_mut::<3, 3>(POS, POS).copy_from(&ra);
        let cov = rot6 * cov * rot6.transpose();
        PoseEstimate {
            t: partial.end,
            p_b_in_w: self.anchor.transform_point(&p.p_b_in_w.into()).coords,
            v_b_in_w: self.anchor.rotation * p.v_b_in_w,
            world_from_body: self.anchor.rotation * p.world_from_body,
            p_b_in_b0: p.p_b_in_w,
            b0_from_body: p.world_from_body,
            converged: true,
            covariance: Some(cov),
        }
    }

    /// The newest pose propagated to the last IMU sample.
    pub(super) fn propagated(&self) -> Option<PoseEstimate> {
        let w = self.phase.window()?;
        let x = w.newest()?;
        let mut partial = self.since_keyframe.clone()?;
        let run = self.inputs.pre.running();
        if run.start != partial.end {
            return None;
        }
        partial.append(run).ok()?;
        Some(self.output(x, &partial, w.newest_covariance()))
    }
}
