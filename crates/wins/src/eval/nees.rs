//! Consistency of a reported position covariance: the normalized estimation error squared
//! (NEES, Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and
//! Navigation*, §5.4.2).
//!
//! For an associated pose with aligned error `e = R·p_est + t − p_truth` and reported position
//! covariance `Σ` (in the estimate's world), the covariance in the truth's world is `R Σ Rᵀ` and
//! the NEES is `ε = eᵀ (R Σ Rᵀ)⁻¹ e`. With an honest covariance and Gaussian errors `ε` is
//! χ²(3): mean 3, below [`NEES_95_3DOF`] 95 % of the time. Larger means the estimator claims
//! more than it knows (what a flight controller fusing the pose must not be told).
//!
//! Over `N` independent runs, the mean of the per-run means lies, for an honest covariance,
//! within [`mean_nees_band`] (the χ²(3N)/N band of the Monte-Carlo average at one time, which a
//! time average can only narrow: the band is a conservative check).
//!
//! The alignment that makes `e` absorbs what no AoA-inertial estimate can know (the world's
//! origin and the yaw about gravity), which the estimator fixes by a prior on its first frame
//! instead: `e` is measured against the best-fitting gauge, so `ε` leans low, never high.

use nalgebra::{Matrix3, Vector3};

use super::associate::associate_and_align;
use super::{EvalError, EvalOptions};
use crate::chi2::chi2_upper;
use crate::dataset::truth::Pose;
use crate::time::Timestamp;

/// χ²(3) exceeded with probability 5 %.
pub const NEES_95_3DOF: f64 = 7.814_727_903_251_178;

/// The position NEES of one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeesSummary {
    /// Mean of `ε` over the poses with an invertible covariance.
    pub mean: f64,
    /// Share of those poses with `ε ≤` [`NEES_95_3DOF`] (0.95 when honest).
    pub within_95: f64,
    /// Poses counted.
    pub poses: usize,
}

/// The 95 % band of the mean over `runs` runs of a 3-dof NEES: `[χ²₃ₙ(2.5 %), χ²₃ₙ(97.5 %)]/n`.
pub fn mean_nees_band(runs: usize) -> (f64, f64) {
    let n = runs.max(1) as f64;
    let dof = 3.0 * n;
    (chi2_upper(dof, 0.975) / n, chi2_upper(dof, 0.025) / n)
}

/// `ε` of each pose of `est` associated with `truth` (as [`super::evaluate`] associates and
/// aligns them) whose position covariance in `cov` (one per estimated pose, m²) is given and
/// positive definite; `None` when no pose has one.
pub fn position_nees(
    est: &[Pose],
    cov: &[Option<Matrix3<f64>>],
    truth: &[Pose],
    options: &EvalOptions,
) -> Result<Option<NeesSummary>, EvalError> {
    let (association, alignment) = associate_and_align(est, truth, options)?;
    let iso = alignment.isometry();
    let r = iso.rotation.to_rotation_matrix().into_inner();
    let values: Vec<f64> = association
        .pairs
        .iter()
        .filter_map(|&(i, j)| {
            let c = cov.get(i).copied().flatten()?;
            let e = iso.transform_point(&est[i].p_b_in_w.into()).coords - truth[j].p_b_in_w;
            nees(&e, &c, &r)
        })
        .collect();
    Ok(summarize(&values))
}

/// One row of a `covariance.csv`: the pose's time and its position covariance, m² (`None`:
/// none reported).
pub type CovarianceRow = (Timestamp, Option<Matrix3<f64>>);

/// The position covariance of each row of a run's `covariance.csv` (`t_s` and the upper
/// triangle of the 6 × 6 covariance over x, y, z, rx, ry, rz, as `wins run` writes it: the
/// position block is `c_x_x` … `c_z_z`), `None` for a row whose cells are empty (a pose sent
/// without one). Errors: a missing column, or a cell that is not a number.
pub fn read_position_covariance(
    input: impl std::io::Read,
) -> Result<Vec<CovarianceRow>, EvalError> {
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(input));
    let bad = |row: usize, reason: String| EvalError::CovarianceCsv { row, reason };
    let header = lines
        .next()
        .transpose()
        .map_err(|e| bad(0, e.to_string()))?
        .ok_or_else(|| bad(0, "no header".into()))?;
    let columns: Vec<&str> = header.trim().split(',').collect();
    let at = |name: &str| {
        columns
            .iter()
            .position(|c| *c == name)
            .ok_or_else(|| bad(0, format!("no column {name}")))
    };
    let t = at("t_s")?;
    let names = ["c_x_x", "c_x_y", "c_x_z", "c_y_y", "c_y_z", "c_z_z"];
    let cells: Vec<usize> = names.iter().map(|n| at(n)).collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    for (k, line) in lines.enumerate() {
        let row = k + 1;
        let line = line.map_err(|e| bad(row, e.to_string()))?;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.trim().split(',').collect();
        let field = |i: usize| fields.get(i).copied().unwrap_or("").trim();
        let time = field(t)
            .parse::<f64>()
            .ok()
            .map(|s| Timestamp((s * 1e9).round() as i64))
            .filter(|t| t.is_in_range())
            .ok_or_else(|| bad(row, format!("time {:?} is not seconds", field(t))))?;
        if cells.iter().all(|&i| field(i).is_empty()) {
            out.push((time, None));
            continue;
        }
        let mut v = [0.0; 6];
        for (x, &i) in v.iter_mut().zip(&cells) {
            *x = field(i)
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(row, format!("{:?} is not a number", field(i))))?;
        }
        let [xx, xy, xz, yy, yz, zz] = v;
        out.push((time, Some(Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz))));
    }
    Ok(out)
}

/// The covariance of each pose of `est` from `rows` ([`read_position_covariance`]): the row at
/// the pose's time (within a microsecond, the files' rounding), `None` when there is none.
pub fn covariance_of_each_pose(est: &[Pose], rows: &[CovarianceRow]) -> Vec<Option<Matrix3<f64>>> {
    est.iter()
        .map(|p| {
            let i = rows.partition_point(|(t, _)| t.0 < p.t.0 - 1_000);
            rows.get(i)
                .filter(|(t, _)| (t.0 - p.t.0).abs() <= 1_000)
                .and_then(|(_, c)| *c)
        })
        .collect()
}

/// `eᵀ (R Σ Rᵀ)⁻¹ e` for the alignment's rotation `r`, `None` when `Σ` is not positive definite.
pub(crate) fn nees(e: &Vector3<f64>, cov: &Matrix3<f64>, r: &Matrix3<f64>) -> Option<f64> {
    let c = r * cov * r.transpose();
    let l = c.cholesky()?;
    let v = l.solve(e);
    let value = e.dot(&v);
    value.is_finite().then_some(value)
}

pub(crate) fn summarize(values: &[f64]) -> Option<NeesSummary> {
    if values.is_empty() {
        return None;
    }
    let n = values.len() as f64;
    Some(NeesSummary {
        mean: values.iter().sum::<f64>() / n,
        within_95: values.iter().filter(|&&v| v <= NEES_95_3DOF).count() as f64 / n,
        poses: values.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::test_pose;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A 40 s circle at 50 Hz, and the estimate off it by errors drawn from `Σ = diag(σ²)`
    /// scaled by `true_scale²`, with `Σ` reported.
    fn case(true_scale: f64) -> NeesSummary {
        let sigma = Vector3::new(0.10, 0.05, 0.02);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let normal = Normal::new(0.0, 1.0).expect("unit normal");
        let truth: Vec<Pose> = (0..2000)
            .map(|k| {
                let a = 0.3 * k as f64 * 0.02;
                test_pose(k * 20, Vector3::new(2.0 * a.cos(), 2.0 * a.sin(), 1.5), a)
            })
            .collect();
        let est: Vec<Pose> = truth
            .iter()
            .map(|p| {
                let n = Vector3::from_fn(|i, _| sigma[i] * true_scale * normal.sample(&mut rng));
                Pose {
                    p_b_in_w: p.p_b_in_w + n,
                    ..*p
                }
            })
            .collect();
        let cov = vec![Some(Matrix3::from_diagonal(&sigma.component_mul(&sigma))); est.len()];
        position_nees(&est, &cov, &truth, &EvalOptions::default())
            .expect("scored")
            .expect("covariances")
    }

    #[test]
    fn an_honest_covariance_gives_three_and_an_overconfident_one_more() {
        let honest = case(1.0);
        assert!((honest.mean - 3.0).abs() < 0.25, "{honest:?}");
        assert!((honest.within_95 - 0.95).abs() < 0.02, "{honest:?}");
        let over = case(2.0);
        assert!((over.mean - 12.0).abs() < 1.0, "{over:?}");
        assert!(over.within_95 < 0.6, "{over:?}");
        assert_eq!(honest.poses, 2000);
    }

    #[test]
    fn missing_or_singular_covariances_are_left_out() {
        let truth: Vec<Pose> = (0..100)
            .map(|k| {
                test_pose(
                    k * 20,
                    Vector3::new(k as f64 * 0.01, (k % 7) as f64, 1.0),
                    0.0,
                )
            })
            .collect();
        let mut cov = vec![None; truth.len()];
        let none = position_nees(&truth, &cov, &truth, &EvalOptions::default()).expect("scored");
        assert!(none.is_none());
        cov[3] = Some(Matrix3::zeros());
        cov[5] = Some(Matrix3::identity());
        let one = position_nees(&truth, &cov, &truth, &EvalOptions::default())
            .expect("scored")
            .expect("one pose");
        assert_eq!(one.poses, 1);
        assert!(one.mean < 1e-12);
    }

    #[test]
    fn the_band_of_twenty_runs_is_the_chi2_of_sixty_over_twenty() {
        // χ²(60): 40.48 and 83.30 (tables).
        let (lo, hi) = mean_nees_band(20);
        assert!((lo - 40.48 / 20.0).abs() < 0.02, "{lo}");
        assert!((hi - 83.30 / 20.0).abs() < 0.02, "{hi}");
        assert!(mean_nees_band(1).0 < 0.3 && mean_nees_band(1).1 > 9.0);
    }
}
