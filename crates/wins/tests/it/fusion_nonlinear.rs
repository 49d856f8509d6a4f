//! The nonlinear window on simulated flights with truth bearings (2° noise), the AoA stage left
//! out: started at the truth it stays there, started off it comes back, and its information has
//! the nullspace of the true system (translation and yaw) after marginalizations.

use nalgebra::{Isometry3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wins::fusion::bearing::{Bearing, Side};
use wins::fusion::nonlinear::state::{Mat15, NavState};
use wins::fusion::nonlinear::{NonlinearConfig, NonlinearWindow, SubFrame};
use wins::imu::{ImuBiases, Preintegrated, Preintegrator};
use wins::sim::run::{SimOutput, simulate};
use wins::sim::scenario::Scenario;

/// A window built on the truth of `scenario` over `[from_s, to_s)` with keyframes every 0.1 s
/// and one bearing per AP every 20 ms; the states, APs and barometer offset at the truth.
struct Built {
    window: NonlinearWindow,
    truth: Vec<NavState>,
    aps: Vec<Vector3<f64>>,
}

fn build(scenario: &Scenario, from_s: f64, to_s: f64, seed: u64, baro: bool) -> Built {
    build_sliding(scenario, from_s, to_s, seed, baro, None).0
}

/// [`build`], solving and marginalizing down to `slide` keyframes at every keyframe when given;
/// also the newest keyframe's position error after each solve.
fn build_sliding(
    scenario: &Scenario,
    from_s: f64,
    to_s: f64,
    seed: u64,
    baro: bool,
    slide: Option<usize>,
) -> (Built, Vec<f64>) {
    build_with(scenario, from_s, to_s, seed, baro, slide, true, 1e6, None)
}

/// [`build_sliding`] with first-estimate Jacobians on or off and the first keyframe's attitude
/// and position prior information `gauge` (1/σ²); `sin_bias = (β, σ)`: every bearing's sin θ
/// offset by β (a chain phase step the calibration missed) and β estimated from 0 with prior σ.
#[allow(clippy::too_many_arguments)]
fn build_with(
    scenario: &Scenario,
    from_s: f64,
    to_s: f64,
    seed: u64,
    baro: bool,
    slide: Option<usize>,
    fej: bool,
    gauge: f64,
    sin_bias: Option<(f64, f64)>,
) -> (Built, Vec<f64>) {
    let out: SimOutput = simulate(scenario, &mut |_| {}).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 2f64.to_radians()).unwrap();
    let g = scenario.gravity_m_s2;
    let noise_model = scenario.imu.model.noise();
    let state_at = |i: usize| {
        let (t, s) = &out.states[i];
        let b = out.imu_biases[i];
        NavState {
            t: *t,
            world_from_body: s.world_from_body,
            p_b_in_w: s.p_b_in_w,
            v_b_in_w: s.v_b_in_w,
            gyro_bias_rad_s: b.gyro_rad_s,
            accel_bias_m_s2: b.accel_m_s2,
        }
    };
    let aps: Vec<Vector3<f64>> = scenario
        .aps
        .iter()
        .map(|a| Vector3::from(a.position_m))
        .collect();
    // Frames every 20 ms on IMU sample times; keyframes every fifth.
    let i0 = out
        .imu
        .iter()
        .position(|s| s.t.as_secs_f64() >= from_s)
        .unwrap();
    let step = (0.02 / out.imu[1].t.secs_since(out.imu[0].t)).round() as usize;
    let mut pre = Preintegrator::new(noise_model.clone(), ImuBiases::zero());
    pre.push(&out.imu[i0]).unwrap();
    let baro_offset = out.baro_truth.first().map(|b| b.offset_m).unwrap_or(0.0);
    let mut window: Option<NonlinearWindow> = None;
    let mut truth = Vec::new();
    let mut since: Option<Preintegrated> = None;
    let mut i = i0;
    let mut n_frame = 0;
    let mut errors = Vec::new();
    while out.imu[i].t.as_secs_f64() < to_s {
        let t = out.imu[i].t;
        let bearings: Vec<Bearing> = aps
            .iter()
            .enumerate()
            .map(|(l, c)| {
                let x = state_at(i);
                let a = world_from_array(&x, &scenario.body_from_array());
                let d = a.inverse_transform_point(&(*c).into()).coords;
                let offset = sin_bias.map_or(0.0, |b| b.0);
                let aoa =
                    (d.y / d.norm() + offset).clamp(-1.0, 1.0).asin() + noise.sample(&mut rng);
                Bearing {
                    ap: l,
                    aoa_rad: aoa,
                    side: Side::Front,
                    sigma_rad: 2f64.to_radians(),
                }
            })
            .collect();
        let altitude_m = (baro && n_frame % 2 == 0).then(|| {
            state_at(i).p_b_in_w.z + baro_offset + 0.25 * noise.sample(&mut rng) / 2f64.to_radians()
        });
        let is_key = n_frame % 5 == 0;
        let partial = since
            .clone()
            .unwrap_or_else(|| Preintegrated::empty(t, pre.bias()));
        let frame = SubFrame {
            partial: if is_key {
                Preintegrated::empty(t, pre.bias())
            } else {
                partial.clone()
            },
            bearings,
            altitude_m,
        };
        match (&mut window, is_key) {
            (None, _) => {
                let x0 = state_at(i);
                let mut prior = Mat15::identity() * 1e-6;
                for k in 0..6 {
                    prior[(k, k)] = gauge;
                }
                if gauge >= 1.0 {
                    // A start that knows the first state as the estimator's does (a rest, or
                    // the last good state): velocity to 0.05 m/s, biases to their turn-on
                    // spreads.
                    for k in 0..3 {
                        prior[(6 + k, 6 + k)] = 0.05f64.powi(-2);
                        prior[(9 + k, 9 + k)] = noise_model.gyro_turn_on_bias_rad_s.powi(-2);
                        prior[(12 + k, 12 + k)] = noise_model.accel_turn_on_bias_m_s2.powi(-2);
                    }
                }
                let config = NonlinearConfig {
                    max_keyframes: 1000,
                    ..NonlinearConfig::default()
                };
                let w = NonlinearWindow::new(
                    config,
                    g,
                    noise_model.clone(),
                    scenario.body_from_array(),
                    x0,
                    vec![frame],
                    &prior,
                    aps.iter().copied().map(Some).collect(),
                    baro.then_some(baro_offset),
                    sin_bias
                        .filter(|b| b.1 > 0.0)
                        .map(|(_, sigma)| (0.0, sigma)),
                );
                window = Some(if fej { w } else { w.without_fej() });
                truth.push(x0);
            }
            (Some(w), true) => {
                w.push_keyframe(state_at(i), partial.clone(), vec![frame])
                    .unwrap();
                truth.push(state_at(i));
                if let Some(n) = slide {
                    w.optimize(2).unwrap();
                    while w.len() > n {
                        w.marginalize_oldest();
                    }
                    errors.push((w.newest().unwrap().p_b_in_w - state_at(i).p_b_in_w).norm());
                }
            }
            (Some(w), false) => w.push_frame(frame),
        }
        since = Some(if is_key {
            Preintegrated::empty(t, pre.bias())
        } else {
            partial
        });
        // Integrate to the next frame.
        for j in i + 1..=i + step {
            let cut_here = j == i + step;
            if cut_here {
                let iv = pre.cut(out.imu[j].t, &out.imu[j]).unwrap();
                let mut acc = since.take().unwrap();
                acc.append(&iv).unwrap();
                since = Some(acc);
            }
            pre.push(&out.imu[j]).unwrap();
        }
        i += step;
        n_frame += 1;
    }
    (
        Built {
            window: window.unwrap(),
            truth,
            aps,
        },
        errors,
    )
}

fn world_from_array(x: &NavState, body_from_array: &Isometry3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(x.p_b_in_w.into(), x.world_from_body) * body_from_array
}

fn max_position_error(w: &NonlinearWindow, truth: &[NavState]) -> f64 {
    w.keyframes()
        .zip(truth)
        .map(|(x, t)| (x.p_b_in_w - t.p_b_in_w).norm())
        .fold(0.0, f64::max)
}

fn airborne(name: &str) -> Scenario {
    Scenario::built_in(name)
        .unwrap()
        .airborne()
        .without_vibration()
}

#[test]
fn started_at_the_truth_the_window_stays_and_its_cost_is_chi2() {
    let b = build(&airborne("paper-circle"), 2.0, 12.0, 1, true);
    let mut w = b.window;
    let fit = w.fit();
    // At the truth every residual is noise: χ² with as many degrees as residuals.
    let dof = (fit.imu_dof + fit.bearings + fit.baro) as f64;
    let cost = fit.imu_chi2 + fit.bearing_chi2 + fit.baro_chi2;
    assert!((cost - dof).abs() < 4.0 * (2.0 * dof).sqrt(), "{fit:?}");
    w.optimize(10).unwrap();
    let err = max_position_error(&w, &b.truth);
    let ap = (w.aps()[0] - b.aps[0]).norm();
    eprintln!("max position error {err:.3} m, AP {ap:.3} m");
    assert!(err < 0.1 && ap < 0.1, "{err} {ap}");
}

/// Bearing-only geometry is not convex, and a Levenberg–Marquardt damped relative to the stiff
/// IMU information stopped metres away from half the true scale, at a cost 20 % above the
/// truth's. The solve (Gauss–Newton first, a line search, damping only after a rejected step)
/// reaches the truth's cost from there.
#[test]
fn a_start_at_half_the_scale_reaches_the_truths_cost() {
    let b = build(&airborne("paper-circle"), 2.0, 12.0, 2, true);
    let mut at_truth = b.window.clone();
    at_truth.optimize(20).unwrap();
    let truth_cost = at_truth.optimize(1).unwrap().cost_after;
    let mut w = b.window;
    let p0 = b.truth[0].p_b_in_w;
    w.perturb_for_test(
        &|x: &NavState| NavState {
            p_b_in_w: p0 + (x.p_b_in_w - p0) * 0.5,
            v_b_in_w: x.v_b_in_w * 0.5,
            ..*x
        },
        &|c| p0 + (c - p0) * 0.5,
    );
    let r = w.optimize(200).unwrap();
    assert!(
        r.cost_after < truth_cost * 1.05,
        "{} vs {truth_cost}",
        r.cost_after
    );
}

/// Known limitation, measured: started at the truth in the air, with no rest, the sliding
/// window drifts along the AP's range (4.7 m worst, the AP 53 m off over 38 s) once the solve
/// is undamped; the flights the pipeline runs (a rest, then the inertial start) do not
/// (docs/ESTIMATOR.md). Asserted: no further than measured, +20 %; the aim is 0.3 m for both.
#[test]
#[ignore = "heavy: run by `cargo test --release -- --ignored` (CI runs it)"]
fn sliding_from_the_truth_the_window_drifts_no_further_than_measured() {
    let (b, errors) = build_sliding(&airborne("paper-circle"), 2.0, 40.0, 3, true, Some(20));
    let worst = errors.iter().copied().fold(0.0, f64::max);
    let last = errors.last().copied().unwrap_or(f64::NAN);
    let ap = (b.window.aps()[0] - b.aps[0]).norm();
    eprintln!("worst {worst:.3} last {last:.3} AP {ap:.3} (aim: 0.3 m both)");
    assert!(worst < 4.74 * 1.2 && ap < 53.3 * 1.2, "{worst} {ap}");
}

/// `‖H N‖ / (‖H‖ ‖N‖)` of the window's information (prior included) and its nullspace.
fn nullspace_leak(w: &NonlinearWindow) -> f64 {
    let h = w.information(true);
    let n = w.nullspace();
    (&h * &n).norm() / (h.norm() * n.norm())
}

/// With no gauge prior (1/σ² = 10⁻⁶ on the first keyframe), after 30 s of marginalization the
/// window's information (prior included) has the true 4-D nullspace — translation and yaw — with
/// first-estimate Jacobians, and gains information along it without them.
#[test]
fn marginalization_keeps_the_true_nullspace_with_first_estimate_jacobians() {
    let sc = airborne("paper-circle");
    let (fej, _) = build_with(&sc, 2.0, 32.0, 4, true, Some(15), true, 1e-6, None);
    let (plain, _) = build_with(&sc, 2.0, 32.0, 4, true, Some(15), false, 1e-6, None);
    assert!(fej.window.marginalized() > 250);
    let (with, without) = (nullspace_leak(&fej.window), nullspace_leak(&plain.window));
    eprintln!("leak with FEJ {with:.2e}, without {without:.2e}");
    assert!(with < 1e-9, "{with}");
    assert!(without > 100.0 * with, "{without} vs {with}");
}

/// Bearings whose sin θ are all offset by β (a chain phase step the calibration missed, 0.05 is
/// 9° of phase at λ/2): with β in the window (from 0, prior σ 0.1) the solve finds it and keeps
/// the trajectory near the truth; without it the same bearings pull the trajectory off.
#[test]
fn a_common_offset_of_the_bearings_sin_is_estimated_with_the_trajectory() {
    let sc = airborne("paper-circle");
    let beta = 0.05;
    let (with, _) = build_with(&sc, 2.0, 14.0, 5, true, None, true, 1e6, Some((beta, 0.1)));
    let mut w = with.window;
    w.optimize(30).unwrap();
    let (got, sigma) = w.sin_bias().unwrap();
    let err = max_position_error(&w, &with.truth);
    eprintln!("β {got:.4} ± {sigma:.4} (true {beta}), max position error {err:.3} m");
    assert!(
        (got - beta).abs() < 3.0 * sigma.max(1e-3),
        "{got} ± {sigma}"
    );
    assert!(sigma < 0.05, "the bearings did not inform β: {sigma}");
    assert!(err < 0.15, "{err}");
    // The same offset bearings, β not estimated: the window cannot explain them.
    let (fixed, _) = build_with(&sc, 2.0, 14.0, 5, true, None, true, 1e6, Some((beta, 0.0)));
    let mut f = fixed.window;
    f.optimize(30).unwrap();
    let fixed_err = max_position_error(&f, &fixed.truth);
    eprintln!(
        "β not estimated: max position error {fixed_err:.3} m, bearing χ² {:.1} vs {:.1}",
        f.fit().bearing_chi2,
        w.fit().bearing_chi2
    );
    assert!(fixed_err > 1.5 * err, "{fixed_err} vs {err}");
}

/// β in the border leaves the window's true nullspace (translation and yaw) as it is.
#[test]
fn the_bearings_offset_keeps_the_true_nullspace() {
    let sc = airborne("paper-circle");
    let (b, _) = build_with(
        &sc,
        2.0,
        20.0,
        6,
        true,
        Some(15),
        true,
        1e-6,
        Some((0.02, 0.1)),
    );
    assert!(b.window.sin_bias().is_some());
    let leak = nullspace_leak(&b.window);
    assert!(leak < 1e-9, "{leak}");
}

/// Bearings whose errors persist (`[nonlinear] bearing_correlation_s`) count their share of an
/// independent measurement: the window's degrees of freedom fall by the long-run variance
/// ratio of the AP's rate, and its σ on the AP grows (the IMU holds part of it).
#[test]
fn persistent_bearing_errors_weigh_their_share() {
    let b = build(&airborne("paper-circle"), 2.0, 12.0, 1, true);
    let mut independent = b.window;
    independent.optimize(10).unwrap();
    let mut correlated = independent.clone();
    correlated.set_bearing_correlation_s(0.3);
    correlated.optimize(10).unwrap();
    let (fi, fc) = (independent.fit(), correlated.fit());
    assert_eq!(fi.bearings, fc.bearings);
    assert!((fi.bearing_dof - fi.bearings as f64).abs() < 1e-9, "{fi:?}");
    let span_s = 10.0;
    let expected =
        wins::fusion::nonlinear::solve::shares::variance_ratio(fi.bearings as f64 / span_s, 0.3);
    let ratio = fi.bearing_dof / fc.bearing_dof;
    assert!(
        (ratio / expected - 1.0).abs() < 0.1,
        "{ratio} vs {expected}"
    );
    let (si, sc) = (
        independent.ap_sigma_m(0).unwrap(),
        correlated.ap_sigma_m(0).unwrap(),
    );
    eprintln!("ratio {ratio:.1}, AP σ {si:.3} → {sc:.3} m");
    assert!(sc > 1.5 * si, "{si} {sc}");
}
