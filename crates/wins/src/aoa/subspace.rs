//! Signal subspace of the smoothed CSI matrix X (n × N): eigenvectors of the sample covariance
//! with the largest eigenvalues, and how many of them are paths.
//!
//! **Forward–backward averaging, done in real arithmetic.** With the phase reference at the
//! window centre, the steering vector `a(θ) ⊗ b(τ)` of a uniform window is conjugate
//! centro-symmetric (`J·s̄ = s` up to a scalar), so the forward–backward covariance
//! `R_fb = (X·Xᴴ + J·X̄·Xᵀ·J) / 2` has the same signal subspace as `X·Xᴴ` and decorrelates coherent
//! paths further (it doubles the snapshots). For the sparse unitary `Q` of Huarng & Yeh (1991) /
//! Linebarger et al. (1994), `Qᴴ·R_fb·Q = Re(Qᴴ·X·Xᴴ·Q)` is real symmetric: one n × n real
//! eigendecomposition replaces the complex one (about 4× less work), and `Q·v` maps its
//! eigenvectors back. Without forward–backward averaging (needed when the array response is not
//! centro-symmetric, e.g. uncalibrated chains) the complex Hermitian route is used.

use nalgebra::{DMatrix, SymmetricEigen};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::music::error::MusicError;
use super::top_eigen::Tridiagonal;

/// How many eigenvectors count as paths.
///
/// The noise floor is the median of the eigenvalues ranked `max_paths + 1 …` up to the rank the
/// snapshots allow; eigenvalues more than `floor_margin_db` above it and at most
/// `max_below_largest_db` below the largest are paths, at least one and at most `max_paths`. The
/// median (not the mean) keeps a few unresolved weak paths from lifting the floor; a margin well
/// above the floor's spread (about ±3 dB for 15–60 snapshots) keeps noise eigenvalues out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PathCount {
    /// Most paths a packet may hold.
    pub max_paths: usize,
    /// Margin above the noise floor, dB.
    pub floor_margin_db: f64,
    /// Eigenvalues more than this far below the largest are not paths, dB: the dynamic range of
    /// the NIC's CSI. Real Intel 5300 captures show eigenvalues decaying steadily into a floor of
    /// model error (subcarrier ripple, residual sampling offsets) about 20 dB below the strongest
    /// path, well above the thermal floor: counted as paths, those eigenvectors add spurious
    /// peaks that change from packet to packet (docs/VALIDATION.md, "Per-packet AoA on real
    /// captures"). The simulator's CSI carries the same floor (the 5300's measured response
    /// over the band, [`crate::csi::intel5300::receiver_response`]). Default 20.
    pub max_below_largest_db: f64,
}

impl Default for PathCount {
    fn default() -> Self {
        Self {
            max_paths: 5,
            floor_margin_db: 15.0,
            max_below_largest_db: 20.0,
        }
    }
}

impl PathCount {
    /// `(paths, noise floor)` for eigenvalues sorted largest first, of which the first `rank` can
    /// be non-zero (the snapshots limit the rank).
    pub fn judge(&self, values: &[f64], rank: usize) -> (usize, f64) {
        let rank = rank.clamp(1, values.len().max(1));
        let Some(&largest) = values.first() else {
            return (1, 0.0);
        };
        let max_paths = self.max_paths.clamp(1, rank.saturating_sub(1).max(1));
        let tail = &values[max_paths.min(rank - 1)..rank];
        let noise_floor = median(tail).max(largest * 1e-12);
        let threshold = (noise_floor * 10f64.powf(self.floor_margin_db / 10.0))
            .max(largest * 10f64.powf(-self.max_below_largest_db / 10.0));
        let paths = values[..max_paths.min(values.len())]
            .iter()
            .take_while(|&&v| v > threshold)
            .count()
            .max(1);
        (paths, noise_floor)
    }
}

/// The signal subspace of one packet.
#[derive(Clone, Debug, PartialEq)]
pub struct Subspace {
    /// Orthonormal basis of the signal subspace, n × L (L = paths).
    pub basis: DMatrix<Complex64>,
    /// All eigenvalues of the covariance, largest first (normalized by the snapshots).
    pub eigenvalues: Vec<f64>,
    /// The noise floor the path count was judged against.
    pub noise_floor: f64,
}

impl Subspace {
    /// Number of paths L.
    pub fn num_paths(&self) -> usize {
        self.basis.ncols()
    }
}

/// The signal subspace of `x` (see the module docs). `forward_backward` selects the real route.
pub fn signal_subspace(
    x: &DMatrix<Complex64>,
    forward_backward: bool,
    count: &PathCount,
) -> Result<Subspace, MusicError> {
    let (n, snapshots) = x.shape();
    if n < 2 || snapshots == 0 {
        return Err(MusicError::Layout(format!(
            "{n} × {snapshots} smoothed matrix"
        )));
    }
    if x.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
        return Err(MusicError::NonFinite);
    }
    let scale = 1.0 / snapshots as f64;
    if forward_backward {
        let y = unitary_adjoint_times(x);
        let (yr, yi) = (y.map(|v| v.re), y.map(|v| v.im));
        let t = (&yr * yr.transpose() + &yi * yi.transpose()) * scale;
        let tri = Tridiagonal::new(&t)?;
        let values = tri.eigenvalues()?;
        check_signal(&values)?;
        let (paths, noise_floor) = count.judge(&values, (2 * snapshots).min(n));
        let real_vectors = tri.eigenvectors(&values[..paths])?;
        return Ok(Subspace {
            basis: unitary_times(&real_vectors),
            eigenvalues: values,
            noise_floor,
        });
    }
    let r = x * x.adjoint() * Complex64::new(scale, 0.0);
    let eig = SymmetricEigen::new(r);
    let order = descending(eig.eigenvalues.as_slice());
    let values: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    check_signal(&values)?;
    let (paths, noise_floor) = count.judge(&values, snapshots.min(n));
    Ok(Subspace {
        basis: DMatrix::from_fn(n, paths, |r, c| eig.eigenvectors[(r, order[c])]),
        eigenvalues: values,
        noise_floor,
    })
}

/// Eigenvalues (largest first) with a positive largest one, or [`MusicError::NoSignal`].
fn check_signal(values: &[f64]) -> Result<(), MusicError> {
    match values.first() {
        Some(&largest) if largest > 0.0 && values.iter().all(|v| v.is_finite()) => Ok(()),
        _ => Err(MusicError::NoSignal),
    }
}

/// Indices sorting `v` largest first.
fn descending(v: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[b].total_cmp(&v[a]));
    idx
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => 0.0,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The nonzero entries of column `c` of the n × n unitary `Q`: `(row, value)` pairs.
///
/// Even n = 2k: `Q = [[I, jI], [J, −jJ]] / √2`; odd n = 2k + 1 adds a middle row and column
/// holding 1 (Huarng & Yeh 1991).
fn q_column(n: usize, c: usize) -> [(usize, Complex64); 2] {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let k = n / 2;
    let zero = (0, Complex64::new(0.0, 0.0));
    if c < k {
        [
            (c, Complex64::new(h, 0.0)),
            (n - 1 - c, Complex64::new(h, 0.0)),
        ]
    } else if n % 2 == 1 && c == k {
        [(k, Complex64::new(1.0, 0.0)), zero]
    } else {
        let i = c - (n - k);
        [
            (i, Complex64::new(0.0, h)),
            (n - 1 - i, Complex64::new(0.0, -h)),
        ]
    }
}

/// `Qᴴ·x` in O(n·N).
fn unitary_adjoint_times(x: &DMatrix<Complex64>) -> DMatrix<Complex64> {
    let (n, cols) = x.shape();
    let mut y = DMatrix::zeros(n, cols);
    for c in 0..n {
        for (r, q) in q_column(n, c) {
            if q.norm_sqr() == 0.0 {
                continue;
            }
            for j in 0..cols {
                y[(c, j)] += q.conj() * x[(r, j)];
            }
        }
    }
    y
}

/// `Q·v` for a real n × m matrix `v`, in O(n·m).
fn unitary_times(v: &DMatrix<f64>) -> DMatrix<Complex64> {
    let (n, cols) = v.shape();
    let mut out = DMatrix::zeros(n, cols);
    for c in 0..n {
        for (r, q) in q_column(n, c) {
            if q.norm_sqr() == 0.0 {
                continue;
            }
            for j in 0..cols {
                out[(r, j)] += q * v[(c, j)];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(n: usize, m: usize, seed: u64) -> DMatrix<Complex64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| {
            Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5)
        })
    }

    fn dense_q(n: usize) -> DMatrix<Complex64> {
        let mut q = DMatrix::zeros(n, n);
        for c in 0..n {
            for (r, v) in q_column(n, c) {
                q[(r, c)] += v;
            }
        }
        q
    }

    fn exchange(n: usize) -> DMatrix<Complex64> {
        DMatrix::from_fn(n, n, |r, c| {
            Complex64::new(f64::from(u8::from(r + c == n - 1)), 0.0)
        })
    }

    #[test]
    fn q_is_unitary_and_makes_the_forward_backward_covariance_real() {
        for n in [2, 5, 16, 30] {
            let q = dense_q(n);
            let eye = DMatrix::<Complex64>::identity(n, n);
            assert!((q.adjoint() * &q - eye).norm() < 1e-12, "n = {n}");
            let x = random(n, 7, n as u64);
            let r = &x * x.adjoint();
            let j = exchange(n);
            let r_fb = (&r + &j * r.conjugate() * &j) * Complex64::new(0.5, 0.0);
            let t = q.adjoint() * &r_fb * &q;
            assert!(t.map(|v| v.im.abs()).max() < 1e-12, "n = {n}");
            let t_real = (q.adjoint() * &r * &q).map(|v| v.re);
            assert!((t.map(|v| v.re) - t_real).norm() < 1e-12);
            let y = unitary_adjoint_times(&x);
            assert!((y - q.adjoint() * &x).norm() < 1e-12);
        }
    }

    #[test]
    fn real_route_spans_the_same_subspace_as_the_complex_forward_backward_evd() {
        let n = 16;
        let x = random(n, 30, 7);
        let count = PathCount {
            max_paths: 4,
            floor_margin_db: -100.0,
            max_below_largest_db: 300.0,
        };
        let fast = signal_subspace(&x, true, &count).unwrap();
        let j = exchange(n);
        let aug = {
            let back = &j * x.conjugate();
            let mut a = DMatrix::zeros(n, 60);
            a.columns_mut(0, 30).copy_from(&x);
            a.columns_mut(30, 30).copy_from(&back);
            a * Complex64::new(0.5f64.sqrt(), 0.0)
        };
        let slow = signal_subspace(&aug, false, &count).unwrap();
        assert_eq!(fast.num_paths(), 4);
        assert_eq!(slow.num_paths(), 4);
        for (a, b) in fast.eigenvalues.iter().zip(&slow.eigenvalues) {
            assert!(
                (a - 2.0 * b).abs() < 1e-10 * fast.eigenvalues[0],
                "{a} vs {b}"
            );
        }
        let pf = &fast.basis * fast.basis.adjoint();
        let ps = &slow.basis * slow.basis.adjoint();
        assert!((pf - ps).norm() < 1e-9);
        let gram = fast.basis.adjoint() * &fast.basis;
        assert!((gram - DMatrix::<Complex64>::identity(4, 4)).norm() < 1e-12);
    }

    #[test]
    fn path_count_follows_the_eigenvalue_gap() {
        // Rank-2 signal 30 dB over white noise in 16 × 30 snapshots.
        let n = 16;
        let u = random(n, 2, 11);
        let gains = random(2, 30, 12);
        let noise = random(n, 30, 13) * Complex64::new(10f64.powf(-1.5), 0.0);
        let x = &u * gains + noise;
        let s = signal_subspace(&x, false, &PathCount::default()).unwrap();
        assert_eq!(s.num_paths(), 2, "{:?}", s.eigenvalues);
        // Pure noise: one (the minimum).
        let s = signal_subspace(&random(n, 30, 14), false, &PathCount::default()).unwrap();
        assert_eq!(s.num_paths(), 1, "{:?}", s.eigenvalues);
    }

    #[test]
    fn paths_far_below_the_largest_are_not_counted() {
        // Paths at 0, −10 and −25 dB, 50 dB over white noise: the floor rule alone keeps all
        // three, a 20 dB dynamic range the two within it.
        let n = 16;
        let u = random(n, 3, 21);
        let mut gains = random(3, 30, 22);
        for (row, db) in [(1, -10.0), (2, -25.0)] {
            let a: f64 = 10f64.powf(db / 20.0);
            gains.row_mut(row).scale_mut(a);
        }
        let noise = random(n, 30, 23) * Complex64::new(10f64.powf(-2.5), 0.0);
        let x = &u * gains + noise;
        let wide = PathCount {
            max_below_largest_db: 100.0,
            ..PathCount::default()
        };
        assert_eq!(signal_subspace(&x, false, &wide).unwrap().num_paths(), 3);
        let real = PathCount {
            max_below_largest_db: 20.0,
            ..PathCount::default()
        };
        let s = signal_subspace(&x, false, &real).unwrap();
        assert_eq!(s.num_paths(), 2, "{:?}", s.eigenvalues);
    }

    #[test]
    fn degenerate_input_is_an_error() {
        let zero = DMatrix::<Complex64>::zeros(16, 30);
        assert!(matches!(
            signal_subspace(&zero, true, &PathCount::default()),
            Err(MusicError::NoSignal)
        ));
        let mut nan = random(16, 30, 1);
        nan[(3, 3)] = Complex64::new(f64::NAN, 0.0);
        assert!(matches!(
            signal_subspace(&nan, true, &PathCount::default()),
            Err(MusicError::NonFinite)
        ));
    }
}
