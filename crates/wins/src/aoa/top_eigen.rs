//! All eigenvalues and the top few eigenvectors of a real symmetric matrix, for the signal
//! subspace ([`super::subspace`]): MUSIC needs every eigenvalue (to count the paths) but only the
//! L ≤ 5 eigenvectors of the largest ones, so forming all n eigenvectors is wasted work.
//!
//! 1. **Householder tridiagonalization** `A = Q·T·Qᵀ` (Golub & Van Loan, *Matrix Computations*,
//!    4th ed., Algorithm 8.3.1), on the lower triangle, about 4n³/3 flops; the reflectors are kept
//!    and `Q` is never formed.
//! 2. **Eigenvalues of `T`** by shifted QR steps with the Wilkinson shift (ibid., Algorithm
//!    8.3.2) in the root-free form of Pal, Walker & Kahan (squared off-diagonals, no square root
//!    per rotation), deflating negligible off-diagonals, no eigenvectors: O(n) per step,
//!    O(n²) in all. At most [`QR_STEPS_PER_VALUE`]·n steps, then an error.
//! 3. **Eigenvectors of `T`** by inverse iteration (ibid., §8.2.2): `(T − λ̂I)·y = x`
//!    solved by tridiagonal LU with partial pivoting (O(n)); pivots below `ε‖T‖` are lifted to
//!    `±ε‖T‖`, which perturbs a shift that lands exactly on an eigenvalue. Each iterate is
//!    Gram–Schmidt orthogonalized (twice) against the vectors already found, so repeated and
//!    clustered eigenvalues still give an orthonormal basis of their invariant subspace. With L ≤ 5
//!    the vectors of *every* previous eigenvalue are used, not only the close ones (a superset of the
//!    usual cluster rule, O(nL) more). Then `v = Q·y` through the reflectors, O(n²) per vector.
//!
//! The input is scaled by its largest entry first, so the tolerances are relative.

use nalgebra::DMatrix;

use super::music::error::MusicError;

mod tridiagonal;

use tridiagonal::{ShiftedLu, dot, inverse_iteration, tridiagonal_eigenvalues};

/// QR steps allowed per eigenvalue (a handful are needed; the cap only stops a hang).
const QR_STEPS_PER_VALUE: usize = 30;

/// `A = Q·T·Qᵀ` with `T` symmetric tridiagonal and `Q` a product of Householder reflectors; `A`
/// scaled by `1 / scale`.
pub(crate) struct Tridiagonal {
    n: usize,
    /// Diagonal of `T`.
    diag: Vec<f64>,
    /// Sub-diagonal of `T` (`off[i]` couples `i` and `i + 1`).
    off: Vec<f64>,
    /// Column-major n × n: column k, rows k + 1…n − 1 hold reflector `v_k`.
    reflectors: Vec<f64>,
    /// `H_k = I − β_k·v_k·v_kᵀ`; zero where column k needed no reflection.
    beta: Vec<f64>,
    /// The input's largest absolute entry (0 for the zero matrix).
    scale: f64,
}

impl Tridiagonal {
    /// Householder reduction of the symmetric `a` (only its lower triangle is read), Golub & Van
    /// Loan Algorithm 8.3.1: step k maps column k below the diagonal onto `α_k·e₁` with
    /// `v = x − α·e₁`, `α = −sign(x₀)‖x‖`, then `A₂₂ ← A₂₂ − v·wᵀ − w·vᵀ` with `p = β·A₂₂·v`,
    /// `w = p − (β/2)(pᵀv)·v`.
    pub(crate) fn new(a: &DMatrix<f64>) -> Result<Self, MusicError> {
        let (n, cols) = a.shape();
        if n == 0 || n != cols {
            return Err(MusicError::Layout(format!(
                "{n} × {cols} matrix for the eigensolver"
            )));
        }
        let mut scale = 0.0f64;
        for j in 0..n {
            for i in j..n {
                let v = a[(i, j)];
                if !v.is_finite() {
                    return Err(MusicError::NonFinite);
                }
                scale = scale.max(v.abs());
            }
        }
        let inv = if scale > 0.0 { 1.0 / scale } else { 0.0 };
        let mut w: Vec<f64> = a.as_slice().iter().map(|v| v * inv).collect();
        let mut off = vec![0.0; n - 1];
        let mut beta = vec![0.0; n];
        let (mut p, mut v) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..n.saturating_sub(2) {
            let col = k * n;
            let x0 = w[col + k + 1];
            let below = &w[col + k + 2..col + n];
            let tail = dot(below, below);
            if tail == 0.0 {
                off[k] = x0;
                continue;
            }
            let norm = (x0 * x0 + tail).sqrt();
            let alpha = if x0 >= 0.0 { -norm } else { norm };
            let v0 = x0 - alpha;
            w[col + k + 1] = v0;
            off[k] = alpha;
            // vᵀv = 2‖x‖(‖x‖ + |x₀|) = 2‖x‖·|v₀|.
            let b = 1.0 / (norm * v0.abs());
            beta[k] = b;
            v[k + 1..].copy_from_slice(&w[col + k + 1..col + n]);
            // p = β·A₂₂·v from the lower triangle.
            p[k + 1..].fill(0.0);
            for j in k + 1..n {
                let (column, vj) = (&w[j * n + j + 1..(j + 1) * n], v[j]);
                for (pi, a) in p[j + 1..].iter_mut().zip(column) {
                    *pi += a * vj;
                }
                p[j] += w[j * n + j] * vj + dot(column, &v[j + 1..]);
            }
            let half_k = 0.5 * b * b * dot(&p[k + 1..], &v[k + 1..]);
            for (pi, vi) in p[k + 1..].iter_mut().zip(&v[k + 1..]) {
                *pi = b * *pi - half_k * vi;
            }
            for j in k + 1..n {
                let (vj, pj) = (v[j], p[j]);
                let column = &mut w[j * n + j..(j + 1) * n];
                for ((a, vi), pi) in column.iter_mut().zip(&v[j..]).zip(&p[j..]) {
                    *a -= vi * pj + pi * vj;
                }
            }
        }
        if n >= 2 {
            off[n - 2] = w[(n - 2) * n + n - 1];
        }
        let diag = (0..n).map(|i| w[i * n + i]).collect();
        Ok(Self {
            n,
            diag,
            off,
            reflectors: w,
            beta,
            scale,
        })
    }

    /// `‖T‖₁` of the scaled matrix.
    fn norm(&self) -> f64 {
        (0..self.n)
            .map(|i| {
                let left = if i > 0 { self.off[i - 1].abs() } else { 0.0 };
                let right = self.off.get(i).map_or(0.0, |e| e.abs());
                left + self.diag[i].abs() + right
            })
            .fold(0.0, f64::max)
    }

    /// All eigenvalues of `A`, largest first (step 2 of the module docs).
    pub(crate) fn eigenvalues(&self) -> Result<Vec<f64>, MusicError> {
        let mut values =
            tridiagonal_eigenvalues(&self.diag, &self.off, QR_STEPS_PER_VALUE * self.n)?;
        values.iter_mut().for_each(|v| *v *= self.scale);
        values.sort_by(|a, b| b.total_cmp(a));
        Ok(values)
    }

    /// Orthonormal eigenvectors (n × `values.len()`) of `A` for the eigenvalues `values` (those of
    /// [`Tridiagonal::eigenvalues`], or a prefix of them), step 3 of the module docs.
    pub(crate) fn eigenvectors(&self, values: &[f64]) -> Result<DMatrix<f64>, MusicError> {
        let n = self.n;
        if values.len() > n {
            return Err(MusicError::Layout(format!(
                "{} eigenvectors of a {n} × {n} matrix",
                values.len()
            )));
        }
        let t_norm = self.norm();
        if t_norm == 0.0 {
            // The zero matrix: any orthonormal vectors are eigenvectors.
            return Ok(DMatrix::identity(n, values.len()));
        }
        let floor = f64::EPSILON * t_norm;
        let mut lu = ShiftedLu::default();
        let mut found = vec![0.0; n * values.len()];
        for (j, &value) in values.iter().enumerate() {
            lu.factor(&self.diag, &self.off, value / self.scale, floor);
            let (before, rest) = found.split_at_mut(j * n);
            inverse_iteration(&lu, t_norm, before, j, &mut rest[..n])?;
        }
        for y in found.chunks_exact_mut(n) {
            self.apply_q(y);
        }
        Ok(DMatrix::from_vec(n, values.len(), found))
    }

    /// `y ← Q·y = H₀·H₁⋯H_{n−3}·y`.
    fn apply_q(&self, y: &mut [f64]) {
        let n = self.n;
        for k in (0..n.saturating_sub(2)).rev() {
            let b = self.beta[k];
            if b == 0.0 {
                continue;
            }
            let v = &self.reflectors[k * n + k + 1..(k + 1) * n];
            let tail = &mut y[k + 1..];
            let s = b * dot(v, tail);
            tail.iter_mut().zip(v).for_each(|(t, a)| *t -= s * a);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SymmetricEigen;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_symmetric(n: usize, seed: u64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let g = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5);
        &g + g.transpose()
    }

    fn random_orthogonal(n: usize, seed: u64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5)
            .qr()
            .q()
    }

    /// nalgebra's eigenvalues and eigenvectors, largest first.
    fn reference(a: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
        let eig = SymmetricEigen::new(a.clone());
        let mut order: Vec<usize> = (0..a.nrows()).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
        let values = order.iter().map(|&i| eig.eigenvalues[i]).collect();
        let vectors =
            DMatrix::from_fn(a.nrows(), a.nrows(), |r, c| eig.eigenvectors[(r, order[c])]);
        (values, vectors)
    }

    fn projector(v: &DMatrix<f64>) -> DMatrix<f64> {
        v * v.transpose()
    }

    fn orthonormality_error(v: &DMatrix<f64>) -> f64 {
        (v.transpose() * v - DMatrix::identity(v.ncols(), v.ncols())).norm()
    }

    /// Values against nalgebra to `1e-12·|λ|max`; for every L ≤ 5 the vectors are orthonormal,
    /// satisfy `A·V = V·Λ`, and (where `λ_L` and `λ_{L+1}` are apart) span nalgebra's subspace.
    fn check_against_nalgebra(a: &DMatrix<f64>, label: &str) {
        let n = a.nrows();
        let (want_values, want_vectors) = reference(a);
        let tri = Tridiagonal::new(a).unwrap();
        let values = tri.eigenvalues().unwrap();
        let top = want_values[0].abs().max(want_values[n - 1].abs());
        for (got, want) in values.iter().zip(&want_values) {
            assert!(
                (got - want).abs() <= 1e-12 * top,
                "{label}: {got} vs {want}"
            );
        }
        for l in 1..=n.min(5) {
            let v = tri.eigenvectors(&values[..l]).unwrap();
            assert!(orthonormality_error(&v) < 1e-12, "{label}, L = {l}");
            let lambda = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&values[..l]));
            let residual = (a * &v - &v * lambda).norm();
            assert!(
                residual < 1e-11 * top,
                "{label}, L = {l}: residual {residual}"
            );
            let gap = if l < n {
                values[l - 1] - values[l]
            } else {
                top
            };
            if gap > 1e-3 * top {
                let want = projector(&want_vectors.columns(0, l).into_owned());
                let err = (projector(&v) - want).norm();
                assert!(err < 1e-9, "{label}, L = {l}: projector off by {err}");
            }
        }
    }

    #[test]
    fn random_symmetric_matrices_match_nalgebra() {
        for n in [2, 3, 5, 16, 30] {
            for seed in 0..5 {
                check_against_nalgebra(&random_symmetric(n, 100 * n as u64 + seed), "random");
            }
        }
    }

    #[test]
    fn low_rank_covariances_like_the_real_ones_match_nalgebra() {
        // t = Yr·Yrᵀ + Yi·Yiᵀ: 3 strong paths, noise 40 dB down; fewer snapshots than n makes
        // t rank-deficient (a few huge eigenvalues, the rest ~0).
        for (n, snapshots, seed) in [(16, 30, 1), (16, 5, 2), (30, 32, 3), (30, 4, 4), (5, 2, 5)] {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut gauss =
                |r: usize, c: usize| DMatrix::from_fn(r, c, |_, _| rng.random::<f64>() - 0.5);
            let paths = 3.min(n);
            let (ur, ui) = (gauss(n, paths), gauss(n, paths));
            let (gr, gi) = (gauss(paths, snapshots), gauss(paths, snapshots));
            let yr = &ur * &gr - &ui * &gi + gauss(n, snapshots) * 1e-2;
            let yi = &ur * &gi + &ui * &gr + gauss(n, snapshots) * 1e-2;
            let t = (&yr * yr.transpose() + &yi * yi.transpose()) * (1e-6 / snapshots as f64);
            check_against_nalgebra(&t, &format!("{n} × {snapshots}"));
        }
    }

    #[test]
    fn repeated_top_eigenvalues_give_an_orthonormal_basis_of_their_subspace() {
        for (n, seed) in [(16, 7), (30, 8), (4, 9)] {
            let u = random_orthogonal(n, seed);
            let mut spectrum = vec![5.0, 5.0, 5.0];
            spectrum.extend((3..n).map(|i| 1.0 - 0.01 * i as f64));
            // Also a near-repeat: 5 ± a few ε.
            for bump in [0.0, 4e-15, 1e-9] {
                let mut s = spectrum.clone();
                s[1] += bump;
                s[2] -= bump;
                let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(s));
                let a = &u * d * u.transpose();
                let tri = Tridiagonal::new(&a).unwrap();
                let values = tri.eigenvalues().unwrap();
                assert!((values[2] - 5.0).abs() < bump + 1e-13 && values[3] < 1.0);
                let v = tri.eigenvectors(&values[..3]).unwrap();
                assert!(orthonormality_error(&v) < 1e-12, "n = {n}, bump {bump}");
                let want = projector(&u.columns(0, 3).into_owned());
                let err = (projector(&v) - want).norm();
                assert!(err < 1e-9, "n = {n}, bump {bump}: projector off by {err}");
            }
        }
    }

    #[test]
    fn diagonal_tridiagonal_zero_and_tiny_inputs() {
        // Diagonal with a repeated value in separate places: vectors are unit vectors.
        let d = [2.0, 7.0, -1.0, 7.0, 3.0];
        let a = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&d));
        let tri = Tridiagonal::new(&a).unwrap();
        assert_eq!(tri.eigenvalues().unwrap(), vec![7.0, 7.0, 3.0, 2.0, -1.0]);
        let v = tri.eigenvectors(&[7.0, 7.0, 3.0]).unwrap();
        assert!(orthonormality_error(&v) < 1e-12);
        let mut want = DMatrix::zeros(5, 5);
        want[(1, 1)] = 1.0;
        want[(3, 3)] = 1.0;
        want[(4, 4)] = 1.0;
        assert!((projector(&v) - want).norm() < 1e-12);
        check_against_nalgebra(&a, "diagonal");
        // Already tridiagonal: no reflector at all.
        let t = DMatrix::from_fn(16, 16, |r, c| match r.abs_diff(c) {
            0 => 2.0 + 0.1 * r as f64,
            1 => -1.0,
            _ => 0.0,
        });
        let tri = Tridiagonal::new(&t).unwrap();
        assert!(tri.beta.iter().all(|&b| b == 0.0));
        check_against_nalgebra(&t, "tridiagonal");
        // The zero matrix: zero values, orthonormal vectors.
        let tri = Tridiagonal::new(&DMatrix::zeros(6, 6)).unwrap();
        assert_eq!(tri.eigenvalues().unwrap(), vec![0.0; 6]);
        assert!(orthonormality_error(&tri.eigenvectors(&[0.0, 0.0]).unwrap()) < 1e-15);
        // 2 × 2 in closed form: [[2, 1], [1, 2]] has 3 along (1, 1) and 1 along (1, −1).
        let a = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let tri = Tridiagonal::new(&a).unwrap();
        let values = tri.eigenvalues().unwrap();
        assert!((values[0] - 3.0).abs() < 1e-15 && (values[1] - 1.0).abs() < 1e-15);
        let v = tri.eigenvectors(&values[..1]).unwrap();
        assert!((v[(0, 0)].abs() - 0.5f64.sqrt()).abs() < 1e-15);
        assert!((v[(0, 0)] - v[(1, 0)]).abs() < 1e-15);
        // 1 × 1, and a scale far from 1 (the scaling keeps tolerances relative).
        let tri = Tridiagonal::new(&DMatrix::from_element(1, 1, -4.0)).unwrap();
        assert_eq!(tri.eigenvalues().unwrap(), vec![-4.0]);
        assert_eq!(tri.eigenvectors(&[-4.0]).unwrap()[(0, 0)].abs(), 1.0);
        check_against_nalgebra(&(random_symmetric(16, 3) * 1e-150), "tiny");
        check_against_nalgebra(&(random_symmetric(16, 4) * 1e150), "huge");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(
            Tridiagonal::new(&DMatrix::zeros(3, 4)),
            Err(MusicError::Layout(_))
        ));
        assert!(matches!(
            Tridiagonal::new(&DMatrix::zeros(0, 0)),
            Err(MusicError::Layout(_))
        ));
        let mut a = random_symmetric(5, 1);
        a[(4, 2)] = f64::INFINITY;
        assert!(matches!(Tridiagonal::new(&a), Err(MusicError::NonFinite)));
        let tri = Tridiagonal::new(&random_symmetric(3, 1)).unwrap();
        assert!(matches!(
            tri.eigenvectors(&[1.0; 4]),
            Err(MusicError::Layout(_))
        ));
    }
}
