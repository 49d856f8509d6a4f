use super::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_points(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|_| Vector3::new(rng.random(), rng.random(), rng.random()) * 10.0)
        .collect()
}

/// `points` moved by `t`.
fn moved(t: &Isometry3<f64>, points: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    points
        .iter()
        .map(|p| t.transform_point(&(*p).into()).coords)
        .collect()
}

fn random_transform(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
    let axis_angle = Vector3::new(rng.random(), rng.random(), rng.random()) * 2.0;
    let t = Vector3::new(rng.random(), rng.random(), rng.random()) * 20.0;
    Isometry3::from_parts(t.into(), UnitQuaternion::from_scaled_axis(axis_angle))
}

#[test]
fn recovers_a_known_rigid_transform_exactly() {
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let est = random_points(&mut rng, 3 + seed as usize);
        let truth_from_est = random_transform(&mut rng);
        let truth = moved(&truth_from_est, &est);
        let found = umeyama(&est, &truth).expect("aligned").isometry();
        let dr = found.rotation.angle_to(&truth_from_est.rotation);
        let dt = (found.translation.vector - truth_from_est.translation.vector).norm();
        assert!(dr < 1e-12 && dt < 1e-11, "seed {seed}: {dr} rad, {dt} m");
    }
}

#[test]
fn planar_points_align_without_reflection() {
    // With a zero singular value the SVD's third axes have arbitrary signs: only the
    // reflection guard (Umeyama eq. 43) keeps the rotation right for every seed.
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let est: Vec<_> = random_points(&mut rng, 50)
            .into_iter()
            .map(|p| Vector3::new(p.x, p.y, 1.5))
            .collect();
        let truth_from_est = random_transform(&mut rng);
        let truth = moved(&truth_from_est, &est);
        let found = umeyama(&est, &truth).expect("aligned").isometry();
        let dr = found.rotation.angle_to(&truth_from_est.rotation);
        assert!(dr < 1e-12, "seed {seed}: {dr} rad");
    }
}

#[test]
fn degenerate_inputs_are_errors() {
    let p = |x: f64| Vector3::new(x, 2.0 * x, -x);
    let line: Vec<_> = (0..10).map(|i| p(i as f64)).collect();
    assert!(matches!(
        umeyama(&line, &line),
        Err(EvalError::Degenerate { .. })
    ));
    let still = vec![Vector3::new(1.0, 2.0, 3.0); 10];
    assert!(matches!(
        umeyama(&still, &still),
        Err(EvalError::Degenerate { .. })
    ));
    assert!(matches!(
        umeyama(&line[..2], &line[..2]),
        Err(EvalError::TooFewPairs {
            pairs: 2,
            needed: 3
        })
    ));
    assert!(matches!(
        umeyama(&line[..4], &line[..3]),
        Err(EvalError::LengthMismatch { est: 4, truth: 3 })
    ));
}

#[test]
fn alignment_round_trips_through_json() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let a = Alignment::from_isometry(&random_transform(&mut rng));
    let text = serde_json::to_string(&a).expect("json");
    assert!(text.contains("\"rotation_xyzw\"") && text.contains("\"translation_m\""));
    let back: Alignment = serde_json::from_str(&text).expect("parsed");
    let p = Vector3::new(1.0, -2.0, 0.5);
    assert!((back.apply_point(&p) - a.apply_point(&p)).norm() < 1e-12);
    assert_eq!(Alignment::identity().apply_point(&p), p);
}

/// The ATE of `est` against `truth` under `mode`'s alignment.
fn ate(est: &[Vector3<f64>], truth: &[Vector3<f64>], mode: AlignMode) -> f64 {
    let a = align(est, truth, mode).expect("aligned");
    let sq: f64 = est
        .iter()
        .zip(truth)
        .map(|(e, t)| (a.apply_point(e) - t).norm_squared())
        .sum();
    (sq / est.len() as f64).sqrt()
}

#[test]
fn the_yaw_alignment_recovers_a_heading_and_a_translation_exactly() {
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
        let est = random_points(&mut rng, 3 + seed as usize);
        let yaw = (rng.random::<f64>() - 0.5) * 6.0;
        let t = Vector3::new(rng.random(), rng.random(), rng.random()) * 20.0;
        let truth_from_est = Isometry3::from_parts(
            t.into(),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
        );
        let truth = moved(&truth_from_est, &est);
        let found = align(&est, &truth, AlignMode::PosYaw)
            .expect("aligned")
            .isometry();
        let dr = found.rotation.angle_to(&truth_from_est.rotation);
        let dt = (found.translation.vector - t).norm();
        assert!(dr < 1e-12 && dt < 1e-11, "seed {seed}: {dr} rad, {dt} m");
    }
}

/// A flight on a circle with some climb, estimated upside down (turned 180° about a
/// horizontal axis, which mirrors its horizontal track): any rotation aligns it onto the
/// truth, the heading alone cannot. With noise, the yaw found is the least-squares one: no
/// nearby heading does better.
#[test]
fn an_upside_down_estimate_is_not_aligned_away() {
    let truth: Vec<Vector3<f64>> = (0..200)
        .map(|k| {
            let a = k as f64 * 0.05;
            Vector3::new(2.5 * a.cos(), 2.5 * a.sin(), 1.5 + 0.3 * (0.5 * a).sin())
        })
        .collect();
    let flip = Isometry3::from_parts(
        Vector3::new(3.0, -1.0, 2.0).into(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    );
    let est = moved(&flip, &truth);
    assert!(ate(&est, &truth, AlignMode::Se3) < 1e-9);
    assert!(ate(&est, &truth, AlignMode::PosYaw) > 1.5);

    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noisy: Vec<Vector3<f64>> = truth
        .iter()
        .map(|p| {
            let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.1);
            tilt * p + Vector3::new(rng.random(), rng.random(), rng.random()) * 0.2
        })
        .collect();
    let best = align(&noisy, &truth, AlignMode::PosYaw).expect("aligned");
    let cost = |a: &Alignment| -> f64 {
        noisy
            .iter()
            .zip(&truth)
            .map(|(e, t)| (a.apply_point(e) - t).norm_squared())
            .sum()
    };
    for dyaw in [-0.01, 0.01] {
        let turned =
            best.isometry().rotation * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), dyaw);
        let mean_est = noisy.iter().sum::<Vector3<f64>>() / noisy.len() as f64;
        let mean_truth = truth.iter().sum::<Vector3<f64>>() / truth.len() as f64;
        let other = Alignment::from_isometry(&Isometry3::from_parts(
            (mean_truth - turned * mean_est).into(),
            turned,
        ));
        assert!(cost(&other) > cost(&best), "{dyaw}");
    }
    // A vertical line has no heading to find.
    let column: Vec<Vector3<f64>> = (0..10).map(|k| Vector3::new(1.0, 2.0, k as f64)).collect();
    assert!(matches!(
        align(&column, &column, AlignMode::PosYaw),
        Err(EvalError::Degenerate { .. })
    ));
}
