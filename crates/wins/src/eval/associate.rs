//! Time association of estimated and truth poses: nearest timestamp within a tolerance, with no
//! interpolation, as evo's `sync.associate_trajectories` does (`--t_max_diff`).

use std::io;

use super::align::align_poses;
use super::{Alignment, EvalError, EvalOptions};
use crate::dataset::truth::Pose;
use crate::time::Timestamp;

/// Which pose of the estimate goes with which pose of the truth.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Association {
    /// Matched `(estimate index, truth index)` pairs, increasing in both indices.
    pub pairs: Vec<(usize, usize)>,
    /// Estimated poses that belong to no pair (no truth pose within the tolerance).
    pub unmatched_est: usize,
}

/// Pairs each pose of the shorter trajectory with the pose of the longer one nearest in time, when
/// they are at most `max_time_diff_ns` apart (a tie goes to the earlier pose).
///
/// As in evo, the trajectory with fewer poses drives (the estimate when both have as many), so a
/// pose of the longer one can be matched more than once and none of the shorter one is lost to a
/// double match. Usually the estimate is the shorter (truth at IMU rate), and every estimated
/// pose is either matched or counted in [`Association::unmatched_est`].
///
/// Errors: an empty or time-unsorted trajectory, or no pair at all.
pub fn associate(
    est: &[Pose],
    truth: &[Pose],
    max_time_diff_ns: i64,
) -> Result<Association, EvalError> {
    let est_t: Vec<Timestamp> = est.iter().map(|p| p.t).collect();
    let truth_t: Vec<Timestamp> = truth.iter().map(|p| p.t).collect();
    check_sorted(&est_t, "estimate")?;
    check_sorted(&truth_t, "truth")?;
    let truth_drives = truth.len() < est.len();
    let pairs: Vec<(usize, usize)> = if truth_drives {
        nearest_matches(&truth_t, &est_t, max_time_diff_ns)
            .into_iter()
            .map(|(j, i)| (i, j))
            .collect()
    } else {
        nearest_matches(&est_t, &truth_t, max_time_diff_ns)
    };
    if pairs.is_empty() {
        return Err(EvalError::NoMatches {
            est_poses: est.len(),
            truth_poses: truth.len(),
            max_time_diff_s: max_time_diff_ns as f64 * 1e-9,
        });
    }
    let mut matched_est: Vec<usize> = pairs.iter().map(|&(i, _)| i).collect();
    matched_est.dedup();
    Ok(Association {
        unmatched_est: est.len() - matched_est.len(),
        pairs,
    })
}

fn check_sorted(t: &[Timestamp], trajectory: &'static str) -> Result<(), EvalError> {
    if t.is_empty() {
        return Err(EvalError::EmptyTrajectory { trajectory });
    }
    match t.windows(2).position(|w| w[1] < w[0]) {
        Some(k) => Err(EvalError::Unsorted {
            trajectory,
            index: k + 1,
        }),
        None => Ok(()),
    }
}

/// For each `a[i]`, the index of the nearest `b[j]` within `max_ns` (evo's binary-search branch
/// of `matching_time_indices`: the later neighbour wins only when strictly nearer). Both sorted.
fn nearest_matches(a: &[Timestamp], b: &[Timestamp], max_ns: i64) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(a.len());
    for (i, &t) in a.iter().enumerate() {
        // First index with b[k] > t.
        let upper = b.partition_point(|&x| x <= t);
        let diff_upper = b.get(upper).map(|x| x.0 - t.0);
        let diff_lower = upper.checked_sub(1).map(|k| t.0 - b[k].0);
        let best = match (diff_lower, diff_upper) {
            (Some(lo), Some(up)) if up < lo => Some((upper, up)),
            (Some(lo), _) => Some((upper - 1, lo)),
            (None, Some(up)) => Some((upper, up)),
            (None, None) => None,
        };
        if let Some((j, diff)) = best
            && diff <= max_ns
        {
            out.push((i, j));
        }
    }
    out
}

/// The association of `est` with `truth` and the alignment of the pairs' positions, after
/// the options and both trajectories are checked.
pub(super) fn associate_and_align(
    est: &[Pose],
    truth: &[Pose],
    options: &EvalOptions,
) -> Result<(Association, Alignment), EvalError> {
    options.validate()?;
    check_finite(est, "estimate")?;
    check_finite(truth, "truth")?;
    let association = associate(est, truth, options.max_time_diff_ns())?;
    let (est_p, truth_p): (Vec<_>, Vec<_>) = association
        .pairs
        .iter()
        .map(|&(i, j)| (&est[i], &truth[j]))
        .unzip();
    let alignment = align_poses(&est_p, &truth_p, options.align)?;
    Ok((association, alignment))
}

fn check_finite(poses: &[Pose], trajectory: &'static str) -> Result<(), EvalError> {
    let bad = |p: &Pose| {
        !(p.p_b_in_w.iter().all(|x| x.is_finite())
            && p.world_from_body.coords.iter().all(|x| x.is_finite()))
    };
    match poses.iter().position(bad) {
        Some(index) => Err(EvalError::NonFinite { trajectory, index }),
        None => Ok(()),
    }
}

/// For each item of `a` (in time order), the item of `b` (in time order) nearest in time when at
/// most `max_ns` away, to `f`: [`super::associate`]'s rule (the later neighbour only when
/// strictly nearer), reading `b` once alongside `a`: the association of the evaluation in passes.
pub(super) fn nearest<A, B>(
    a: impl Iterator<Item = io::Result<(Timestamp, A)>>,
    b: impl Iterator<Item = io::Result<(Timestamp, B)>>,
    max_ns: i64,
    mut f: impl FnMut(&A, &B),
) -> io::Result<()> {
    let mut b = b.peekable();
    let mut lower: Option<(Timestamp, B)> = None;
    for item in a {
        let (t, x) = item?;
        while let Some(next) = b.next_if(|r| matches!(r, Ok((tb, _)) if *tb <= t)) {
            lower = Some(next?);
        }
        let upper = match b.peek() {
            Some(Ok(u)) => Some(u),
            Some(Err(_)) => return b.next().map_or(Ok(()), |r| r.map(|_| ())),
            None => None,
        };
        let diff_lower = lower.as_ref().map(|(tb, _)| t.0 - tb.0);
        let diff_upper = upper.map(|(tb, _)| tb.0 - t.0);
        let best = match (diff_lower, diff_upper) {
            (Some(lo), Some(up)) if up < lo => upper.map(|(_, y)| (y, up)),
            (Some(lo), _) => lower.as_ref().map(|(_, y)| (y, lo)),
            (None, Some(up)) => upper.map(|(_, y)| (y, up)),
            (None, None) => None,
        };
        if let Some((y, diff)) = best
            && diff <= max_ns
        {
            f(&x, y);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    const MS: i64 = 1_000_000;

    fn poses(times_ms: &[i64]) -> Vec<Pose> {
        times_ms
            .iter()
            .map(|&t| Pose {
                t: Timestamp(t * MS),
                p_b_in_w: Vector3::zeros(),
                world_from_body: UnitQuaternion::identity(),
            })
            .collect()
    }

    #[test]
    fn nearest_within_10_ms_and_unmatched_counted() {
        // Truth at 200 Hz over 1 s; estimates at 20 Hz with jitter, a gap and poses outside.
        let truth = poses(&(0..=200).map(|k| 5 * k).collect::<Vec<_>>());
        let est = poses(&[-50, -11, -10, 0, 52, 104, 498, 1003, 1010, 1011, 2000]);
        let a = associate(&est, &truth, 10 * MS).expect("matched");
        assert_eq!(
            a.pairs,
            vec![
                (2, 0),   // −10 → 0 ms (exactly at the tolerance)
                (3, 0),   // 0 → 0
                (4, 10),  // 52 → 50 (nearer than 55)
                (5, 21),  // 104 → 105
                (6, 100), // 498 → 500
                (7, 200), // 1003 → 1000
                (8, 200), // 1010 → 1000 (at the tolerance)
            ]
        );
        assert_eq!(a.unmatched_est, 4);
    }

    #[test]
    fn ties_go_to_the_earlier_pose_as_in_evo() {
        let truth = poses(&[0, 10, 20]);
        let a = associate(&poses(&[5, 15]), &truth, 10 * MS).expect("matched");
        assert_eq!(a.pairs, vec![(0, 0), (1, 1)]);
    }

    #[test]
    fn a_denser_estimate_is_matched_from_the_truth_side() {
        // evo drives with the shorter trajectory: here the truth.
        let truth = poses(&[0, 100, 200]);
        let est = poses(&(0..=40).map(|k| 5 * k).collect::<Vec<_>>());
        let a = associate(&est, &truth, 10 * MS).expect("matched");
        assert_eq!(a.pairs, vec![(0, 0), (20, 1), (40, 2)]);
        assert_eq!(a.unmatched_est, 38);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let truth = poses(&[0, 10, 20]);
        assert!(matches!(
            associate(&poses(&[500]), &truth, 10 * MS),
            Err(EvalError::NoMatches { .. })
        ));
        assert!(matches!(
            associate(&poses(&[]), &truth, 10 * MS),
            Err(EvalError::EmptyTrajectory {
                trajectory: "estimate"
            })
        ));
        assert!(matches!(
            associate(&poses(&[0, 20, 10]), &truth, 10 * MS),
            Err(EvalError::Unsorted {
                trajectory: "estimate",
                index: 2
            })
        ));
    }
}
