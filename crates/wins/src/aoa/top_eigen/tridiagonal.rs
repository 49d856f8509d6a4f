//! Eigenvalues and eigenvectors of a symmetric tridiagonal matrix `T` (diagonal `d`, sub-diagonal
//! `e`, `e[i]` coupling `i` and `i + 1`): root-free QR for the values, inverse iteration for the
//! few wanted vectors (steps 2 and 3 of [`super`]).

use crate::aoa::music::error::MusicError;

/// Inverse iterations allowed per eigenvector (two are normal: converge, then refine once).
const MAX_INVERSE_ITERATIONS: usize = 8;
/// Inverse iteration has converged once the residual `‖(T − λ̂I)·v‖` is below this times `‖T‖`.
const INVERSE_ITERATION_RESIDUAL: f64 = 1e-9;

/// The eigenvalues of the symmetric tridiagonal matrix (`diag`, `off`), unordered: shifted QR
/// steps ([`rational_qr_step`]) on the lowest unreduced block, at most `max_steps` of them;
/// `off[i]` is dropped once `|off[i]| ≤ ε(|d_i| + |d_{i+1}|)` (the usual deflation test).
pub(super) fn tridiagonal_eigenvalues(
    diag: &[f64],
    off: &[f64],
    max_steps: usize,
) -> Result<Vec<f64>, MusicError> {
    let n = diag.len();
    let mut d = diag.to_vec();
    let mut e2: Vec<f64> = off.iter().map(|e| e * e).collect();
    let negligible = |e2: f64, a: f64, b: f64| {
        let tol = f64::EPSILON * (a.abs() + b.abs());
        e2 <= tol * tol || e2 < f64::MIN_POSITIVE
    };
    let mut steps = 0;
    let mut hi = n.saturating_sub(1);
    while hi > 0 {
        if negligible(e2[hi - 1], d[hi - 1], d[hi]) {
            hi -= 1;
            continue;
        }
        let mut lo = hi - 1;
        while lo > 0 && !negligible(e2[lo - 1], d[lo - 1], d[lo]) {
            lo -= 1;
        }
        if steps == max_steps {
            return Err(MusicError::NoConvergence {
                stage: "tridiagonal QR",
                iterations: steps,
            });
        }
        steps += 1;
        rational_qr_step(&mut d, &mut e2, lo, hi);
    }
    if d.iter().any(|v| !v.is_finite()) {
        return Err(MusicError::NonFinite);
    }
    Ok(d)
}

/// One QR step `T − σI = QR`, `T ← RQ + σI` on the unreduced block `lo..=hi`, in the root-free
/// form of Pal, Walker & Kahan (Parlett, *The Symmetric Eigenvalue Problem*, ch. 8): it works on
/// the squared off-diagonals `e2` and never takes a square root inside the loop. `σ` is the
/// Wilkinson shift of the trailing 2 × 2.
///
/// Our derivation, for `A = T − σI` (diagonal `a_i`, off-diagonal `b_i`) and Givens rotations
/// `c_i = π_i/r_i`, `s_i = b_i/r_i`, `r_i² = π_i² + b_i²` down the rows: the pivot left in row
/// `i + 1` is `π_{i+1} = c_i·a_{i+1} − s_i·c_{i−1}·b_i`, and `RQ` has `b'_i = s_i·r_{i+1}` and
/// `a'_i = c_{i−1}π_i + s_i²·a_{i+1} + s_i c_i c_{i−1} b_i`. With `γ_i = c_{i−1}·π_i` and
/// `s_i c_i b_i = s_i² π_i` this is `γ_{i+1} = c_i²·a_{i+1} − s_i²·γ_i`,
/// `a'_i = γ_i + a_{i+1} − γ_{i+1}`, `a'_last = γ_last`, and `π_{i+1}² = γ_{i+1}²/c_i²` (or
/// `c_{i−1}²·b_i²` when `c_i = 0`): only squares of `c`, `s`, `b` and `π` appear.
fn rational_qr_step(d: &mut [f64], e2: &mut [f64], lo: usize, hi: usize) {
    let delta = 0.5 * (d[hi - 1] - d[hi]);
    let tail = e2[hi - 1];
    let root = (delta * delta + tail).sqrt();
    let denom = if delta >= 0.0 {
        delta + root
    } else {
        delta - root
    };
    let sigma = d[hi] - tail / denom;
    let mut gamma = d[lo] - sigma;
    let mut pi2 = gamma * gamma;
    let (mut c2, mut s2) = (1.0, 0.0);
    for i in lo..hi {
        let b2 = e2[i];
        // b2 > 0 in an unreduced block, so r2 > 0.
        let r2 = pi2 + b2;
        if i > lo {
            e2[i - 1] = s2 * r2;
        }
        let c2_before = c2;
        let shifted = d[i + 1] - sigma;
        // γ_{i+1}·r_i² and π_{i+1}² = γ_{i+1}²/c_i² = g²/(r_i²·π_i²): one division on the
        // step-to-step dependency chain instead of two.
        let g = pi2 * shifted - b2 * gamma;
        let denom = r2 * pi2;
        c2 = pi2 / r2;
        s2 = b2 / r2;
        let gamma_before = gamma;
        gamma = g / r2;
        d[i] = gamma_before + (d[i + 1] - gamma);
        pi2 = if denom >= f64::MIN_POSITIVE {
            g * g / denom
        } else {
            c2_before * b2
        };
    }
    e2[hi - 1] = s2 * pi2;
    d[hi] = gamma + sigma;
}

/// `T − σI = P·L·U` for tridiagonal `T`, by Gaussian elimination with partial pivoting (U has two
/// super-diagonals); pivots smaller than `floor` in magnitude are replaced by `±floor`. The buffers
/// are reused from one shift to the next.
#[derive(Default)]
pub(super) struct ShiftedLu {
    /// Row i of U: `1/u_ii`, `u_{i,i+1}`, `u_{i,i+2}` (zero past the end).
    rows: Vec<URow>,
    /// Elimination step i: the multiplier applied to row i + 1, and whether rows i, i + 1 swapped.
    steps: Vec<(f64, bool)>,
}

#[derive(Clone, Copy, Default)]
struct URow {
    inv_pivot: f64,
    up1: f64,
    up2: f64,
}

impl ShiftedLu {
    /// Factors `T − σI` (`diag`, `off` as in [`tridiagonal_eigenvalues`], `off.len() + 1 ==
    /// diag.len()`).
    pub(super) fn factor(&mut self, diag: &[f64], off: &[f64], sigma: f64, floor: f64) {
        let n = diag.len();
        self.rows.clear();
        self.rows.extend(
            diag.iter()
                .zip(off.iter().chain([&0.0]))
                .map(|(d, e)| URow {
                    inv_pivot: d - sigma,
                    up1: *e,
                    up2: 0.0,
                }),
        );
        self.steps.clear();
        // Row i holds (pivot, up1) in columns (i, i + 1); row i + 1 holds (off[i], its pivot,
        // its up1) in columns (i, i + 1, i + 2).
        for (i, &below) in off.iter().enumerate().take(n.saturating_sub(1)) {
            let top = self.rows[i];
            let next = self.rows[i + 1];
            if top.inv_pivot.abs() >= below.abs() {
                let l = if top.inv_pivot == 0.0 {
                    0.0
                } else {
                    below / top.inv_pivot
                };
                self.rows[i + 1].inv_pivot -= l * top.up1;
                self.steps.push((l, false));
            } else {
                let l = top.inv_pivot / below;
                self.rows[i] = URow {
                    inv_pivot: below,
                    up1: next.inv_pivot,
                    up2: next.up1,
                };
                self.rows[i + 1].inv_pivot = top.up1 - l * next.inv_pivot;
                self.rows[i + 1].up1 = -l * next.up1;
                self.steps.push((l, true));
            }
        }
        for row in &mut self.rows {
            let u = row.inv_pivot;
            let u = if u.abs() >= floor {
                u
            } else if u < 0.0 {
                -floor
            } else {
                floor
            };
            row.inv_pivot = 1.0 / u;
        }
    }

    /// `b ← (T − σI)⁻¹·b`.
    pub(super) fn solve(&self, b: &mut [f64]) {
        let Some(&first) = b.first() else {
            return;
        };
        let mut carry = first;
        for (i, &(l, swapped)) in self.steps.iter().enumerate() {
            let next = b[i + 1];
            let (top, bottom) = if swapped {
                (next, carry)
            } else {
                (carry, next)
            };
            b[i] = top;
            carry = bottom - l * top;
        }
        if let Some(last) = b.last_mut() {
            *last = carry;
        }
        let (mut y1, mut y2) = (0.0, 0.0);
        for (bi, row) in b.iter_mut().zip(&self.rows).rev() {
            let y = (*bi - row.up1 * y1 - row.up2 * y2) * row.inv_pivot;
            *bi = y;
            y2 = y1;
            y1 = y;
        }
    }
}

/// Inverse iteration for one eigenvector `x` of `T` (Golub & Van Loan §8.2.2): solve, orthogonalize
/// against the unit columns of `found` (twice), normalize; the growth `‖y‖` of a unit right-hand
/// side is the inverse residual, so `1/‖y‖ ≤ tol·‖T‖` means converged; one more iteration then
/// refines it. `start` picks a fixed start vector (a Weyl sequence: deterministic, far from any
/// structured direction).
pub(super) fn inverse_iteration(
    lu: &ShiftedLu,
    t_norm: f64,
    found: &[f64],
    start: usize,
    x: &mut [f64],
) -> Result<(), MusicError> {
    // frac(k·φ) in 64-bit fixed point (φ = golden ratio conjugate · 2⁶⁴): integer arithmetic only.
    const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;
    const TWO_TO_MINUS_64: f64 = 1.0 / 18_446_744_073_709_551_616.0;
    let n = x.len();
    for (i, v) in x.iter_mut().enumerate() {
        let k = (i + 1 + start * n) as u64;
        *v = k.wrapping_mul(GOLDEN) as f64 * TWO_TO_MINUS_64 - 0.5;
    }
    normalize(x);
    let mut converged = false;
    for _ in 0..MAX_INVERSE_ITERATIONS {
        lu.solve(x);
        for _ in 0..2 {
            for f in found.chunks_exact(n) {
                let along = dot(f, x);
                x.iter_mut().zip(f).for_each(|(v, a)| *v -= along * a);
            }
        }
        let growth = normalize(x);
        if !growth.is_finite() {
            return Err(MusicError::NonFinite);
        }
        if growth == 0.0 {
            // x lay in the span of `found`: cannot happen for n > found.len() but for rounding.
            return Err(MusicError::NoConvergence {
                stage: "inverse iteration",
                iterations: 0,
            });
        }
        if converged {
            return Ok(());
        }
        converged = growth * INVERSE_ITERATION_RESIDUAL * t_norm >= 1.0;
    }
    if converged {
        return Ok(());
    }
    Err(MusicError::NoConvergence {
        stage: "inverse iteration",
        iterations: MAX_INVERSE_ITERATIONS,
    })
}

/// Scales `x` to unit length (unless it is zero or not finite); returns its former length.
fn normalize(x: &mut [f64]) -> f64 {
    let norm = dot(x, x).sqrt();
    if norm > 0.0 && norm.is_finite() {
        let inv = 1.0 / norm;
        x.iter_mut().for_each(|v| *v *= inv);
    }
    norm
}

/// `aᵀb` over the shorter of the two, with four partial sums (a quarter of the dependency chain
/// of one running sum; these short dot products are latency-bound).
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let m = a.len().min(b.len());
    let (ca, cb) = (a[..m].chunks_exact(4), b[..m].chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0; 4];
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn dense(d: &[f64], e: &[f64]) -> DMatrix<f64> {
        DMatrix::from_fn(d.len(), d.len(), |r, c| match (r, c) {
            _ if r == c => d[r],
            _ if r == c + 1 => e[c],
            _ if c == r + 1 => e[r],
            _ => 0.0,
        })
    }

    #[test]
    fn laplacian_eigenpairs_in_closed_form() {
        // tridiag(−1, 2, −1): λ_k = 2 − 2cos(kπ/(n+1)), v_k(i) ∝ sin(ikπ/(n+1)), k = 1…n.
        let n = 30;
        let (d, e) = (vec![2.0; n], vec![-1.0; n - 1]);
        let mut values = tridiagonal_eigenvalues(&d, &e, 30 * n).unwrap();
        values.sort_by(|a, b| b.total_cmp(a));
        let h = std::f64::consts::PI / (n + 1) as f64;
        for (j, v) in values.iter().enumerate() {
            let k = (n - j) as f64;
            assert!((v - (2.0 - 2.0 * (k * h).cos())).abs() < 1e-14, "{j}: {v}");
        }
        let mut found = Vec::new();
        let mut lu = ShiftedLu::default();
        for (j, &value) in values.iter().take(3).enumerate() {
            lu.factor(&d, &e, value, f64::EPSILON * 4.0);
            let mut y = vec![0.0; n];
            inverse_iteration(&lu, 4.0, &found, j, &mut y).unwrap();
            let k = (n - j) as f64;
            let want = DVector::from_fn(n, |i, _| ((i + 1) as f64 * k * h).sin()).normalize();
            let dot: f64 = want.iter().zip(&y).map(|(a, b)| a * b).sum();
            assert!((dot.abs() - 1.0).abs() < 1e-13, "{j}: {dot}");
            found.extend(y);
        }
    }

    #[test]
    fn shifted_lu_solves_with_and_without_pivoting() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for n in [1, 2, 3, 16] {
            let d: Vec<f64> = (0..n).map(|_| rng.random::<f64>() - 0.5).collect();
            // Large couplings force row swaps; small ones do not.
            for coupling in [0.01, 10.0] {
                let e: Vec<f64> = (1..n)
                    .map(|_| coupling * (rng.random::<f64>() - 0.5))
                    .collect();
                let sigma = 0.3;
                let mut lu = ShiftedLu::default();
                lu.factor(&d, &e, sigma, 0.0);
                assert_eq!(lu.steps.iter().any(|&(_, s)| s), coupling > 1.0 && n > 1);
                let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
                let mut x = b.clone();
                lu.solve(&mut x);
                let shifted = dense(&d, &e) - DMatrix::identity(n, n) * sigma;
                let back = shifted * DVector::from_vec(x);
                let err = (back - DVector::from_vec(b)).norm();
                assert!(err < 1e-12, "n = {n}, coupling {coupling}: {err}");
            }
        }
    }

    #[test]
    fn an_exact_shift_and_the_step_cap_do_not_hang_or_divide_by_zero() {
        // σ exactly on the eigenvalue 1 of diag(1, 3): pivot 0 lifted to the floor.
        let mut lu = ShiftedLu::default();
        lu.factor(&[1.0, 3.0], &[0.0], 1.0, 1e-16);
        let mut y = [0.0; 2];
        inverse_iteration(&lu, 3.0, &[], 0, &mut y).unwrap();
        assert!((y[0].abs() - 1.0).abs() < 1e-15 && y[1].abs() < 1e-15);
        // The first QR step's shift (0, from the trailing [[1, 1], [1, 1]]) equals d₀: π₀ = 0,
        // so c₀ = 0 and π₁² comes from the c = 0 branch.
        let (d, e) = ([0.0, 1.0, 1.0], [1.0, 1.0]);
        let mut got = tridiagonal_eigenvalues(&d, &e, 90).unwrap();
        got.sort_by(f64::total_cmp);
        let mut want: Vec<f64> = dense(&d, &e)
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .collect();
        want.sort_by(f64::total_cmp);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-14, "{got:?} vs {want:?}");
        }
        // No steps allowed on an unreduced matrix: an error, not a loop.
        assert!(matches!(
            tridiagonal_eigenvalues(&[1.0, 2.0], &[1.0], 0),
            Err(MusicError::NoConvergence { iterations: 0, .. })
        ));
    }
}
