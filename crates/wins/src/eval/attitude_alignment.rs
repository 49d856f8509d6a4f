//! The alignment's rotation from the attitudes, for pairs whose positions cannot fix it: a drone
//! that takes off straight up and hovers flies a vertical line, about which any yaw fits the
//! positions equally. The attitudes still carry the rotation between the two worlds: for each
//! pair `R_t · R_eᵀ` (`truth_world_from_est_world`), averaged over the pairs. With
//! [`AlignMode::PosYaw`] only its yaw is kept (`ψ = arg Σ exp(i·ψᵢ)`, `ψᵢ` the yaw of each
//! pair's rotation); with [`AlignMode::Se3`] the whole rotation (the normalized sum of the pairs'
//! quaternions, each on the first one's side: the chordal mean, Hartley et al., IJCV 2013,
//! §5.3). The translation then takes the estimate's mean position onto the truth's. Pairs that
//! disagree fix nothing: two rotations [`MAX_SPREAD_RAD`] apart have a mean resultant length of
//! `cos(spread/2)` as yaw phasors and `cos(spread/4)` as quaternions, and a mean shorter than
//! that is refused.

use nalgebra::{Isometry3, Quaternion, UnitQuaternion, Vector3};

use super::EvalError;
use super::align::{AlignMode, Alignment};
use crate::dataset::truth::Pose;

/// Widest spread of the pairs' rotations that still has a mean, rad: a third of a turn (half of
/// them a half turn from the other half has none).
pub const MAX_SPREAD_RAD: f64 = 2.0 * std::f64::consts::FRAC_PI_3;

/// The running sums of the pairs' relative rotations.
#[derive(Clone, Debug, Default)]
pub(crate) struct AttitudeMean {
    pairs: usize,
    yaw_cos: f64,
    yaw_sin: f64,
    quaternion: Option<(Quaternion<f64>, Quaternion<f64>)>,
}

impl AttitudeMean {
    /// One pair, `est` going onto `truth`.
    pub(crate) fn push(&mut self, est: &Pose, truth: &Pose) {
        let relative = truth.world_from_body * est.world_from_body.inverse();
        let r = relative.to_rotation_matrix();
        let yaw = r[(1, 0)].atan2(r[(0, 0)]);
        self.pairs += 1;
        self.yaw_cos += yaw.cos();
        self.yaw_sin += yaw.sin();
        let q = *relative.quaternion();
        match &mut self.quaternion {
            None => self.quaternion = Some((q, q)),
            Some((first, sum)) => *sum += if q.dot(first) < 0.0 { -q } else { q },
        }
    }

    /// The alignment of `mode` whose rotation is the pairs' mean and whose translation takes
    /// `mean_est` onto `mean_truth`. Errors: no pair, or rotations that disagree
    /// ([`MAX_SPREAD_RAD`]), as [`EvalError::Degenerate`] with the positions' `singular_values`.
    pub(crate) fn alignment(
        &self,
        mode: AlignMode,
        mean_est: &Vector3<f64>,
        mean_truth: &Vector3<f64>,
        singular_values: [f64; 3],
    ) -> Result<Alignment, EvalError> {
        let degenerate = EvalError::Degenerate { singular_values };
        let rotation = match mode {
            AlignMode::PosYaw => {
                if self.pairs == 0
                    || self.yaw_cos.hypot(self.yaw_sin)
                        < (MAX_SPREAD_RAD / 2.0).cos() * self.pairs as f64
                {
                    return Err(degenerate);
                }
                UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    self.yaw_sin.atan2(self.yaw_cos),
                )
            }
            AlignMode::Se3 => {
                let Some((_, sum)) = self.quaternion else {
                    return Err(degenerate);
                };
                if sum.norm() < (MAX_SPREAD_RAD / 4.0).cos() * self.pairs as f64 {
                    return Err(degenerate);
                }
                UnitQuaternion::from_quaternion(sum)
            }
        };
        let t = mean_truth - rotation * mean_est;
        let mut alignment = Alignment::from_isometry(&Isometry3::from_parts(t.into(), rotation));
        alignment.rotation_from_attitudes = true;
        Ok(alignment)
    }
}
