//! The alignment's rotation from the attitudes, for pairs whose positions cannot fix it: a drone
//! that takes off straight up and hovers flies a vertical line, about which any yaw fits the
//! positions equally. The attitudes still carry the rotation between the two worlds: for each
//! pair `R_t · R_eᵀ` (`truth_world_from_est_world`), averaged over the pairs. For an alignment
//! of a heading only its yaw is kept (`ψ = arg Σ exp(i·ψᵢ)`, `ψᵢ` the yaw of each pair's
//! rotation); for SE(3) the whole rotation (the normalized sum of the pairs' quaternions, each on
//! the first one's side: the chordal mean, Hartley et al., IJCV 2013, §5.3); `super::align` then
//! adds the translation that takes the estimate's mean position onto the truth's. Pairs that
//! disagree fix nothing: two rotations [`MAX_SPREAD_RAD`] apart have a mean resultant length of
//! `cos(spread/2)` as yaw phasors and `cos(spread/4)` as quaternions, and a shorter mean is
//! refused.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::dataset::truth::Pose;

/// Widest spread of the pairs' rotations that still has a mean, rad: a third of a turn (half of
/// them a half turn from the other half has none).
pub(crate) const MAX_SPREAD_RAD: f64 = 2.0 * std::f64::consts::FRAC_PI_3;

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

    /// The pairs' mean rotation `truth_world_from_est_world`, its yaw alone when `yaw_only`;
    /// `None` with no pair, or with rotations that disagree ([`MAX_SPREAD_RAD`]).
    pub(crate) fn rotation(&self, yaw_only: bool) -> Option<UnitQuaternion<f64>> {
        let n = self.pairs as f64;
        if yaw_only {
            let length = self.yaw_cos.hypot(self.yaw_sin);
            (self.pairs > 0 && length >= (MAX_SPREAD_RAD / 2.0).cos() * n).then(|| {
                UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    self.yaw_sin.atan2(self.yaw_cos),
                )
            })
        } else {
            let (_, sum) = self.quaternion?;
            (sum.norm() >= (MAX_SPREAD_RAD / 4.0).cos() * n)
                .then(|| UnitQuaternion::from_quaternion(sum))
        }
    }
}
