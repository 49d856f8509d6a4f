//! Tests of joining intervals ([`Preintegrated::append`]): three appended equal one integrated,
//! the error composition against finite differences, a refused gap and a corrected bias.

use super::*;

/// A random but smooth IMU stream at 200 Hz: a few sinusoids per axis with seeded amplitudes,
/// frequencies and phases, the specific force around the 1 g of hover.
fn random_stream(n: usize, seed: u64) -> Vec<ImuSample> {
    use rand::RngExt;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut waves = Vec::new();
    for _ in 0..6 {
        let mut axis = Vec::new();
        for _ in 0..3 {
            axis.push((
                rng.random::<f64>() - 0.5,
                0.2 + 3.0 * rng.random::<f64>(),
                std::f64::consts::TAU * rng.random::<f64>(),
            ));
        }
        waves.push(axis);
    }
    (0..n)
        .map(|i| {
            let t_ns = 2_000_000_000 + i as i64 * PERIOD_NS;
            let t = t_ns as f64 * 1e-9;
            let v = |k: usize| -> f64 {
                waves[k]
                    .iter()
                    .map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
                    .sum()
            };
            ImuSample {
                t: Timestamp(t_ns),
                gyro_rad_s: Vector3::new(v(0), v(1), v(2)) * 1.5,
                accel_m_s2: Vector3::new(v(3), v(4), 9.8 + v(5)) + Vector3::new(v(5), 0.0, 0.0),
            }
        })
        .collect()
}

/// Integrates `samples` with cuts at the given sample indices (cut times on sample times, so no
/// interpolation) and returns the intervals between consecutive cuts.
fn integrate_with_cuts(
    samples: &[ImuSample],
    noise: &ImuNoise,
    bias: ImuBiases,
    cuts: &[usize],
) -> Vec<Preintegrated> {
    let mut p = Preintegrator::new(noise.clone(), bias);
    let mut out = Vec::new();
    for (i, s) in samples.iter().enumerate() {
        if i > 0 && cuts.contains(&i) {
            out.push(p.cut(s.t, s).unwrap());
        }
        p.push(s).unwrap();
    }
    out
}

fn test_bias() -> ImuBiases {
    ImuBiases {
        gyro_rad_s: Vector3::new(0.01, -0.02, 0.015),
        accel_m_s2: Vector3::new(0.05, 0.02, -0.03),
    }
}

fn rel(a: &SMatrix<f64, 9, 9>, b: &SMatrix<f64, 9, 9>) -> f64 {
    (a - b).norm() / b.norm()
}

#[test]
fn appending_three_intervals_equals_integrating_one() {
    let noise = crate::sim::imu::ImuModel::ConsumerMems.noise();
    let samples = random_stream(301, 11);
    let bias = test_bias();
    let whole = integrate_with_cuts(&samples, &noise, bias, &[0, 300]);
    assert_eq!(whole.len(), 1);
    let whole = &whole[0];
    let parts = integrate_with_cuts(&samples, &noise, bias, &[0, 70, 181, 300]);
    assert_eq!(parts.len(), 3);
    let mut joined = parts[0].clone();
    for p in &parts[1..] {
        joined.append(p).unwrap();
    }
    assert_eq!((joined.start, joined.end), (whole.start, whole.end));
    assert!((joined.alpha - whole.alpha).norm() < 1e-9);
    assert!((joined.beta - whole.beta).norm() < 1e-9);
    assert!(log(&(whole.bk_from_bk1.inverse() * joined.bk_from_bk1)).norm() < 1e-9);
    // Not a vacuous comparison: the motion is large against the tolerance.
    assert!(whole.alpha.norm() > 1.0 && log(&whole.bk_from_bk1).norm() > 0.1);
    // The bias Jacobians are exact linearizations of the same discrete scheme: equal up to
    // rounding.
    let ej = (joined.jacobian_bias - whole.jacobian_bias).norm() / whole.jacobian_bias.norm();
    assert!(ej < 1e-9, "{ej}");
    // The covariances differ by the endpoint-noise sharing at the two cuts only: in one interval
    // the cut sample's noise η enters both neighbouring sub-intervals as η/2 (correlated, the
    // cross term), appended it enters each side independently. For an integrated rate that is
    // (N − ½) vs (N − ½ − ½·cuts) sample variances, i.e. a relative difference of
    // cuts/(2N) = 2/600 ≈ 0.33%; α and β weight the samples unevenly, so allow 2×.
    let ec = rel(&joined.covariance, &whole.covariance);
    eprintln!("relative covariance difference {ec:.2e}");
    assert!(ec < 2.0 * 2.0 / (2.0 * 300.0), "{ec}");
    for k in 0..3 {
        let a = joined.covariance.fixed_view::<3, 3>(3 * k, 3 * k).trace();
        let b = whole.covariance.fixed_view::<3, 3>(3 * k, 3 * k).trace();
        eprintln!("block {k}: trace ratio {}", a / b);
        assert!(a < b && a / b > 1.0 - 2.0 / 300.0, "block {k}: {a} vs {b}");
    }
}

/// The error-composition matrices `A` and `B` of `append` (read back through the bias Jacobian,
/// which composes as `A J_1 + B J_2`) match finite differences of the appended means, perturbing
/// `[δα, δβ, δθ]` of either interval (rotation on the right).
#[test]
fn append_error_composition_matches_finite_differences() {
    let samples = random_stream(120, 5);
    let parts = integrate_with_cuts(&samples, &zero_noise(), test_bias(), &[0, 50, 119]);
    let (first, second) = (&parts[0], &parts[1]);
    let joined = |p1: &Preintegrated, p2: &Preintegrated| {
        let mut j = p1.clone();
        j.append(p2).unwrap();
        j
    };
    // A and B column blocks from the Jacobian composition (J = identity columns).
    let read_back = |which: usize| {
        let mut m = Covariance9::zeros();
        for half in 0..2 {
            let (mut p1, mut p2) = (first.clone(), second.clone());
            p1.jacobian_bias = BiasJacobian::zeros();
            p2.jacobian_bias = BiasJacobian::zeros();
            let target = if which == 0 { &mut p1 } else { &mut p2 };
            for c in 0..6 {
                target.jacobian_bias[(c + 3 * half, c)] = 1.0;
            }
            let j = joined(&p1, &p2);
            for c in 0..6 {
                m.set_column(c + 3 * half, &j.jacobian_bias.column(c));
            }
        }
        m
    };
    let base = joined(first, second);
    let h = 1e-6;
    for which in 0..2 {
        let analytic = read_back(which);
        for c in 0..9 {
            let mut plus = [first.clone(), second.clone()];
            let mut minus = [first.clone(), second.clone()];
            for (p, s) in [(&mut plus[which], h), (&mut minus[which], -h)] {
                let mut d = Vector3::zeros();
                d[c % 3] = s;
                match c / 3 {
                    0 => p.alpha += d,
                    1 => p.beta += d,
                    _ => p.bk_from_bk1 *= exp(&d),
                }
            }
            let (jp, jm) = (joined(&plus[0], &plus[1]), joined(&minus[0], &minus[1]));
            let mut fd = SVector::<f64, 9>::zeros();
            fd.fixed_rows_mut::<3>(0)
                .copy_from(&((jp.alpha - jm.alpha) / (2.0 * h)));
            fd.fixed_rows_mut::<3>(3)
                .copy_from(&((jp.beta - jm.beta) / (2.0 * h)));
            let rp = log(&(base.bk_from_bk1.inverse() * jp.bk_from_bk1));
            let rm = log(&(base.bk_from_bk1.inverse() * jm.bk_from_bk1));
            fd.fixed_rows_mut::<3>(6)
                .copy_from(&((rp - rm) / (2.0 * h)));
            let an = analytic.column(c);
            assert!(
                (fd - an).norm() < 1e-6 * (1.0 + an.norm()),
                "interval {which}, column {c}: {fd} vs {an}"
            );
        }
    }
}

#[test]
fn append_refuses_a_gap_and_corrects_another_bias() {
    let samples = random_stream(120, 9);
    let bias = test_bias();
    let parts = integrate_with_cuts(&samples, &zero_noise(), bias, &[0, 40, 80, 119]);
    let mut first = parts[0].clone();
    assert_eq!(
        first.append(&parts[2]),
        Err(PreintegrationError::NotContiguous {
            end_ns: parts[0].end.0,
            next_start_ns: parts[2].start.0
        })
    );
    assert_eq!(first, parts[0]);
    // The second interval integrated with a bias 1e-3 away: appending it equals appending the one
    // integrated with `bias`, to second order in the bias change.
    let mut other = bias;
    other.gyro_rad_s += Vector3::new(1e-3, -2e-3, 1e-3);
    other.accel_m_s2 += Vector3::new(-2e-3, 1e-3, 3e-3);
    let moved = integrate_with_cuts(&samples, &zero_noise(), other, &[0, 40, 80]);
    let mut a = parts[0].clone();
    a.append(&parts[1]).unwrap();
    let mut b = parts[0].clone();
    b.append(&moved[1]).unwrap();
    let mut c = parts[0].clone();
    let mut uncorrected = moved[1].clone();
    uncorrected.bias = bias;
    c.append(&uncorrected).unwrap();
    let err = (a.alpha - b.alpha).norm() + (a.beta - b.beta).norm();
    let without = (a.alpha - c.alpha).norm() + (a.beta - c.beta).norm();
    assert!(err < 1e-6 && err < 1e-3 * without, "{err} vs {without}");
    assert!(log(&(a.bk_from_bk1.inverse() * b.bk_from_bk1)).norm() < 1e-6);
    // An empty interval appends as the identity.
    let mut d = a.clone();
    d.append(&Preintegrated::empty(a.end, bias)).unwrap();
    assert!((d.alpha - a.alpha).norm() < 1e-15 && (d.covariance - a.covariance).norm() < 1e-20);
}
