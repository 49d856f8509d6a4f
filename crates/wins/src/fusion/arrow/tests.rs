use super::cholesky::{scale_block, scale_border_t, scale_both_sides};
use super::*;
use nalgebra::{SMatrix, SVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random positive definite arrow system with frame blocks of `D`.
fn random<const D: usize>(n: usize, m: usize, seed: u64) -> ArrowSystem<D> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut s = ArrowSystem::<D>::zeros(n, m);
    // Sum of random rank-limited factors with the arrow's sparsity.
    for k in 0..n {
        let j = DMatrix::from_fn(D + 3, 2 * D + m, |_, _| rng.random::<f64>() - 0.5);
        let jt_j = j.transpose() * &j;
        let two = if k + 1 < n { 2 } else { 1 };
        for a in 0..two {
            for c in 0..two {
                let blk: BlockOf<D> = jt_j.fixed_view::<D, D>(a * D, c * D).into_owned();
                match (a, c) {
                    (0, 0) => s.diag[k] += blk,
                    (1, 1) => s.diag[k + 1] += blk,
                    (1, 0) => s.lower[k] += blk,
                    _ => {}
                }
            }
            let bb = jt_j.view((a * D, 2 * D), (D, m));
            s.frame_border[k + a] += bb;
        }
        s.corner += jt_j.view((2 * D, 2 * D), (m, m));
        s.diag[k] += BlockOf::<D>::identity() * 0.1;
        s.rhs_frames[k] = VecOf::<D>::from_fn(|_, _| rng.random::<f64>() - 0.5);
    }
    s.corner += DMatrix::identity(m, m) * 0.1;
    s.rhs_border = DVector::from_fn(m, |_, _| rng.random::<f64>() - 0.5);
    s
}

/// Frobenius distance within `rel` of `b`'s norm.
fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, rel: f64, what: &str) {
    assert_eq!(a.shape(), b.shape(), "{what}: shape");
    let d = (a - b).norm();
    assert!(d <= rel * b.norm(), "{what}: {d} vs {}", b.norm());
}

/// The arrow solve against a dense Cholesky of the same system: solution, border covariance
/// and the last frame's covariance blocks.
fn matches_a_dense_solve<const D: usize>(n: usize, m: usize, seed: u64) {
    let s = random::<D>(n, m, seed);
    let sol = s.solve().unwrap();
    let (h, b) = s.to_dense();
    let dense = h.clone().cholesky().unwrap();
    let x = dense.solve(&b);
    let cov = dense.inverse();
    let what = format!("D {D} n {n} m {m}");
    assert_eq!(sol.frames.len(), n);
    for k in 0..n {
        let d = (sol.frames[k] - x.rows(k * D, D)).norm();
        assert!(d < 1e-9 * (1.0 + x.norm()), "{what} frame {k}: {d}");
    }
    assert_eq!(sol.border.len(), m);
    assert_eq!(sol.border_covariance.shape(), (m, m));
    assert_eq!(sol.last_frame_border_covariance.shape(), (D, m));
    if m > 0 {
        assert!((&sol.border - x.rows(n * D, m)).norm() < 1e-9 * (1.0 + x.norm()));
        let cb = cov.view((n * D, n * D), (m, m)).into_owned();
        assert_close(&sol.border_covariance, &cb, 1e-9, &what);
    }
    if n > 0 {
        let f = (n - 1) * D;
        let cff = cov.view((f, f), (D, D)).into_owned();
        let got = DMatrix::from_column_slice(D, D, sol.last_frame_covariance.as_slice());
        assert_close(&got, &cff, 1e-9, &format!("{what} Σ_ff"));
        if m > 0 {
            let cfb = cov.view((f, n * D), (D, m)).into_owned();
            let got = DMatrix::from_column_slice(D, m, sol.last_frame_border_covariance.as_slice());
            assert_close(&got, &cfb, 1e-9, &format!("{what} Σ_fB"));
        }
    } else {
        assert_eq!(sol.last_frame_covariance, BlockOf::<D>::zeros());
        assert!(sol.last_frame_border_covariance.iter().all(|&v| v == 0.0));
    }
}

const CASES: [(usize, usize, u64); 8] = [
    (1, 0, 1),
    (2, 3, 2),
    (30, 6, 3),
    (7, 12, 4),
    (1, 5, 6),
    (4, 0, 7),
    (0, 4, 8),
    (0, 0, 9),
];

#[test]
fn arrow_cholesky_matches_a_dense_solve() {
    for (n, m, seed) in CASES {
        matches_a_dense_solve::<FRAME_DIM>(n, m, seed);
    }
}

#[test]
fn arrow_cholesky_matches_a_dense_solve_with_15_blocks() {
    for (n, m, seed) in CASES {
        matches_a_dense_solve::<15>(n, m, seed);
    }
}

/// Jacobi scaling is undone in the covariances: the same check on a badly scaled system.
#[test]
fn last_frame_covariance_survives_bad_scaling() {
    let (n, m) = (5, 6);
    let mut s = random::<FRAME_DIM>(n, m, 10);
    let scales = DVector::from_fn(n * FRAME_DIM + m, |i, _| 10f64.powi((i % 7) as i32 - 3));
    // H ← D H D, b ← D b with D far from the identity.
    for k in 0..n {
        let sk = scales.fixed_rows::<FRAME_DIM>(k * FRAME_DIM).into_owned();
        scale_block(&mut s.diag[k], &sk, &sk);
        if k + 1 < n {
            let sn = scales
                .fixed_rows::<FRAME_DIM>((k + 1) * FRAME_DIM)
                .into_owned();
            scale_block(&mut s.lower[k], &sn, &sk);
        }
        let sb = scales.rows(n * FRAME_DIM, m).into_owned();
        scale_border_t(&mut s.frame_border[k], &sk, &sb);
        s.rhs_frames[k].component_mul_assign(&sk);
    }
    let sb = scales.rows(n * FRAME_DIM, m).into_owned();
    scale_both_sides(&mut s.corner, &sb);
    s.rhs_border.component_mul_assign(&sb);
    let sol = s.solve().unwrap();
    let cov = s.to_dense().0.cholesky().unwrap().inverse();
    let f = (n - 1) * FRAME_DIM;
    let cff = cov.view((f, f), (FRAME_DIM, FRAME_DIM)).into_owned();
    let got =
        DMatrix::from_column_slice(FRAME_DIM, FRAME_DIM, sol.last_frame_covariance.as_slice());
    assert_close(&got, &cff, 1e-8, "Σ_ff");
    let cfb = cov.view((f, n * FRAME_DIM), (FRAME_DIM, m)).into_owned();
    let got = DMatrix::from_column_slice(FRAME_DIM, m, sol.last_frame_border_covariance.as_slice());
    assert_close(&got, &cfb, 1e-8, "Σ_fB");
}

#[test]
fn indefinite_systems_are_refused() {
    let mut s = random::<FRAME_DIM>(3, 3, 5);
    s.diag[1] = -Block::identity();
    assert!(s.solve().is_none());
}

/// `Jᵀ W J` and `−Jᵀ W r` of a factor, dense, over `n` frames of 4 and a border of `m`: the
/// reference for [`ArrowSystem::add`].
fn dense_factor<const R: usize>(
    f: &Linearized<R, 4>,
    n: usize,
    m: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let dim = 4 * n + m;
    let mut j = DMatrix::zeros(R, dim);
    for (k, jk) in f.frames() {
        j.view_mut((0, 4 * k), (R, 4)).copy_from(jk);
    }
    for c in f.border() {
        j.view_mut((0, 4 * n + c.offset), (R, c.cols))
            .copy_from(&c.jacobian.columns(0, c.cols));
    }
    let w = match f.weight {
        Weight::Scalar(w) => DMatrix::identity(R, R) * w,
        Weight::Matrix(w) => DMatrix::from_fn(R, R, |a, b| w[(a, b)]),
    };
    let r = DVector::from_fn(R, |a, _| f.residual[a]);
    let jt_w = j.transpose() * w;
    (&jt_w * &j, -(jt_w * r))
}

#[test]
fn any_factor_adds_its_normal_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut rand = || rng.random::<f64>() - 0.5;
    let (n, m) = (3, 5);
    // A factor between frames 1 and 2 with a full weight, one on frame 0 with an AP block and a
    // scalar of the border, and one on frame 2 alone.
    let w = SMatrix::<f64, 2, 2>::from_fn(|_, _| rand());
    let between = Linearized::between(
        (1, SMatrix::<f64, 2, 4>::from_fn(|_, _| rand())),
        (2, SMatrix::<f64, 2, 4>::from_fn(|_, _| rand())),
        SVector::<f64, 2>::from_fn(|_, _| rand()),
        Weight::Matrix(w * w.transpose()),
    );
    let cone = Linearized::on_frame(
        0,
        SMatrix::<f64, 1, 4>::from_fn(|_, _| rand()),
        SVector::<f64, 1>::new(rand()),
        Weight::Scalar(2.5),
    )
    .with_border(BorderBlock::three(
        2,
        SMatrix::<f64, 1, 3>::from_fn(|_, _| rand()),
    ))
    .with_border(BorderBlock::one(0, SVector::<f64, 1>::new(1.0)));
    let alone = Linearized::on_frame(
        2,
        SMatrix::<f64, 3, 4>::from_fn(|_, _| rand()),
        SVector::<f64, 3>::from_fn(|_, _| rand()),
        Weight::Scalar(0.7),
    );
    let mut sys = ArrowSystem::<4>::zeros(n, m);
    sys.add(&between);
    sys.add(&cone);
    sys.add(&alone);
    let (h, b) = sys.to_dense();
    let (h1, b1) = dense_factor(&between, n, m);
    let (h2, b2) = dense_factor(&cone, n, m);
    let (h3, b3) = dense_factor(&alone, n, m);
    assert_close(&h, &(h1 + h2 + h3), 1e-12, "information matrix");
    let b_ref = b1 + b2 + b3;
    assert_close(
        &DMatrix::from_column_slice(b.len(), 1, b.as_slice()),
        &DMatrix::from_column_slice(b_ref.len(), 1, b_ref.as_slice()),
        1e-12,
        "information vector",
    );
}

#[test]
fn information_blocks_land_with_their_mirror() {
    let mut sys = ArrowSystem::<2>::zeros(2, 3);
    let block = SMatrix::<f64, 2, 1>::new(1.0, 2.0);
    // Frame 1's rows against border column 2, given either way round.
    sys.add_information(At::Frame(1, 0), At::Border(2), &block);
    sys.add_information(At::Border(2), At::Frame(1, 0), &block.transpose());
    // Border 0 against border 1: both triangles.
    sys.add_information(
        At::Border(0),
        At::Border(1),
        &SMatrix::<f64, 1, 1>::new(3.0),
    );
    // Frame 0 against frame 1 from above the diagonal.
    sys.add_information(
        At::Frame(0, 1),
        At::Frame(1, 0),
        &SMatrix::<f64, 1, 1>::new(4.0),
    );
    let (h, _) = sys.to_dense();
    assert_eq!(h[(2, 6)], 2.0);
    assert_eq!(h[(3, 6)], 4.0);
    assert_eq!(h[(6, 3)], 4.0);
    assert_eq!(h[(4, 5)], 3.0);
    assert_eq!(h[(5, 4)], 3.0);
    assert_eq!(h[(1, 2)], 4.0);
    assert_eq!(h[(2, 1)], 4.0);
    assert_eq!(h, h.transpose());
}
