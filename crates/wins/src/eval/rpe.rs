//! Relative pose error as evo_rpe computes it with `--delta_unit f` (consecutive, non-overlapping
//! pairs of associated poses).

use nalgebra::{Isometry3, Translation3};

use super::EvalError;
use crate::dataset::truth::Pose;
use crate::time::Timestamp;

/// The relative pose error of one pair of associated poses `(i, i + Δ)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativePoseError {
    /// Time of the estimated pose `i + Δ`.
    pub t: Timestamp,
    /// `‖trans(E_i)‖`, m.
    pub translation_m: f64,
    /// Angle of `rot(E_i)`, deg.
    pub rotation_deg: f64,
}

/// Relative pose errors `E_i = (Q_i⁻¹ Q_{i+Δ})⁻¹ (P_i⁻¹ P_{i+Δ})` (`Q` truth, `P` estimate)
/// over the associated pairs `i = 0, Δ, 2Δ, …` (evo_rpe's consecutive pairs; `pairs` as in
/// [`super::Association::pairs`]). Invariant to any rigid transform of either world frame.
///
/// Error: `delta` is 0 or not smaller than the number of pairs.
pub fn relative_pose_errors(
    est: &[Pose],
    truth: &[Pose],
    pairs: &[(usize, usize)],
    delta: usize,
) -> Result<Vec<RelativePoseError>, EvalError> {
    if delta == 0 || pairs.len() <= delta {
        return Err(EvalError::RpeTooShort {
            poses: pairs.len(),
            delta,
        });
    }
    let iso = |p: &Pose| Isometry3::from_parts(Translation3::from(p.p_b_in_w), p.world_from_body);
    let starts: Vec<usize> = (0..pairs.len()).step_by(delta).collect();
    Ok(starts
        .windows(2)
        .map(|w| {
            let ((ei, ti), (ej, tj)) = (pairs[w[0]], pairs[w[1]]);
            let q_rel = iso(&truth[ti]).inverse() * iso(&truth[tj]);
            let p_rel = iso(&est[ei]).inverse() * iso(&est[ej]);
            let e = q_rel.inverse() * p_rel;
            RelativePoseError {
                t: est[ej].t,
                translation_m: e.translation.vector.norm(),
                rotation_deg: e.rotation.angle().to_degrees(),
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::test_pose as pose;
    use nalgebra::Vector3;

    #[test]
    fn rpe_of_a_known_drift() {
        // Truth moves 1 m along its heading each frame while turning 10°/frame; the estimate
        // also drifts 2 cm sideways (body y) and 0.5° of yaw per frame: E = (0, 0.02, 0), 0.5°.
        let (n, turn, drift_deg) = (20, 10f64.to_radians(), 0.5);
        let mut truth = vec![pose(0, Vector3::zeros(), 0.0)];
        let mut est = truth.clone();
        for k in 1..n {
            let step = |prev: &Pose, side: f64, extra_deg: f64| {
                let q = prev.world_from_body;
                let p = prev.p_b_in_w + q * Vector3::new(1.0, side, 0.0);
                let yaw = q.euler_angles().2 + turn + extra_deg.to_radians();
                pose(10 * k, p, yaw)
            };
            truth.push(step(&truth[truth.len() - 1], 0.0, 0.0));
            est.push(step(&est[est.len() - 1], 0.02, drift_deg));
        }
        let pairs: Vec<_> = (0..n as usize).map(|i| (i, i)).collect();
        let e = relative_pose_errors(&est, &truth, &pairs, 1).expect("rpe");
        assert_eq!(e.len(), n as usize - 1);
        for x in &e {
            let (t, r) = (x.translation_m, x.rotation_deg);
            assert!(
                (t - 0.02).abs() < 1e-12 && (r - drift_deg).abs() < 1e-9,
                "{t} {r}"
            );
        }
        // Δ = 3 steps 0, 3, 6, …: 6 pairs; the sideways drift of one step is seen rotated.
        let e3 = relative_pose_errors(&est, &truth, &pairs, 3).expect("rpe");
        assert_eq!(e3.len(), 6);
        for x in &e3 {
            assert!((x.rotation_deg - 3.0 * drift_deg).abs() < 1e-9);
        }
        assert!(matches!(
            relative_pose_errors(&est, &truth, &pairs[..3], 3),
            Err(EvalError::RpeTooShort { poses: 3, delta: 3 })
        ));
    }
}
