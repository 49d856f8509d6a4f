//! WINS on the simulator's `paper-circle` with true AoA plus 2° Gaussian noise at 50 Hz and the
//! MicroStrain IMU, the estimator alone (no AoA stage): position and AP error after convergence,
//! convergence time, attitude error; and robustness (motion toward the AP, outages, a still
//! start). Three studies are in the heavy tier (`#[ignore]`d); run them with
//! `cargo test --release -p wins --test it -- --ignored --nocapture NAME` (docs/RESULTS.md).

use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wins::fusion::arrow::Vec9;
use wins::fusion::bearing::{Bearing, Side};
use wins::fusion::paper::estimator::{LinearConfig, LinearEstimator};
use wins::fusion::pose::PoseEstimate;
use wins::sim::motion::{BodyState, sample};
use wins::sim::run::{SimOutput, simulate};
use wins::sim::scenario::Scenario;
use wins::so3::log;
use wins::time::Timestamp;

/// A flight and its packets' truth bearings with noise; `keep(t_s)` drops packets (outages).
struct Run {
    poses: Vec<PoseEstimate>,
    wins: LinearEstimator,
    truth_at: Box<dyn Fn(f64) -> BodyState>,
    b0: BodyState,
    aps_w: Vec<Vector3<f64>>,
}

fn run(
    scenario: &Scenario,
    sigma_deg: f64,
    seed: u64,
    estimate_gyro_bias: bool,
    keep: impl Fn(f64) -> bool,
) -> Run {
    run_with_offset(
        scenario,
        sigma_deg,
        seed,
        estimate_gyro_bias,
        keep,
        |_| 0.0,
        None,
    )
}

/// The converged estimate started at the truth once the window holds `after_s` of frames, the
/// window `max_frames` long and never declared lost (see `the_information_floor`).
#[derive(Clone, Copy)]
struct TruthStart {
    after_s: f64,
    max_frames: usize,
}

/// [`run`] with `offset_deg(t_s)` added to every bearing (a broken AoA stage) and, with
/// `truth_start`, the converged estimate started at the true state.
fn run_with_offset(
    scenario: &Scenario,
    sigma_deg: f64,
    seed: u64,
    estimate_gyro_bias: bool,
    keep: impl Fn(f64) -> bool,
    offset_deg: impl Fn(f64) -> f64,
    truth_start: Option<TruthStart>,
) -> Run {
    let out: SimOutput = simulate(scenario, &mut |_| {}).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma_deg.to_radians()).unwrap();
    // Every AP's packet slots, merged by time.
    let mut packets: Vec<(Timestamp, Bearing)> = Vec::new();
    for (l, ap) in out.aps.iter().enumerate() {
        for p in &ap.packets {
            if !keep(p.t.as_secs_f64()) {
                continue;
            }
            let offset = offset_deg(p.t.as_secs_f64()).to_radians();
            let aoa = (p.truth.aoa_rad + offset + noise.sample(&mut rng))
                .clamp(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2);
            packets.push((
                p.t,
                Bearing {
                    ap: l,
                    aoa_rad: aoa,
                    side: if p.truth.in_front {
                        Side::Front
                    } else {
                        Side::Back
                    },
                    sigma_rad: sigma_deg.to_radians(),
                },
            ));
        }
    }
    packets.sort_by_key(|(t, _)| *t);
    let mut config = LinearConfig::new(scenario.imu.model.noise());
    config.window.body_from_array = scenario.body_from_array();
    config.window.estimate_gyro_bias = estimate_gyro_bias;
    if let Some(start) = truth_start {
        config.window.max_frames = start.max_frames;
        config.window.lost_residual_rms = f64::INFINITY;
    }
    let mut wins = LinearEstimator::new(config);
    let traj = scenario.build_flight();
    let yaw = scenario.yaw.clone();
    let g = scenario.gravity_m_s2;
    let truth_at = Box::new(move |t_s: f64| sample(&traj, &yaw, g, t_s));
    let aps_w: Vec<Vector3<f64>> = scenario
        .aps
        .iter()
        .map(|a| Vector3::from(a.position_m))
        .collect();
    let mut pending_start = truth_start;
    let mut poses = Vec::new();
    let mut next = 0;
    for s in &out.imu {
        while next < packets.len() && packets[next].0 <= s.t {
            wins.push_bearings(packets[next].0, vec![packets[next].1])
                .unwrap();
            next += 1;
        }
        let step = wins.push_imu(s).unwrap();
        for p in &step.frames {
            assert!(p.p_b_in_w.iter().all(|x| x.is_finite()), "NaN at {:?}", p.t);
        }
        poses.extend(step.frames);
        let first = wins.window().frames().next().map(|f| f.t);
        if let (Some(start), Some(t0)) = (pending_start, first)
            && s.t.as_secs_f64() - t0.as_secs_f64() >= start.after_s
        {
            pending_start = None;
            start_at_truth(&mut wins, &truth_at, t0, &aps_w, g);
        }
    }
    let b0 = truth_at(poses[0].t.as_secs_f64());
    Run {
        poses,
        wins,
        truth_at,
        b0,
        aps_w,
    }
}

/// [`LinearEstimator::converge_from`] the true state: `b0` is the body at the window's first frame `t0`.
fn start_at_truth(
    wins: &mut LinearEstimator,
    truth_at: &dyn Fn(f64) -> BodyState,
    t0: Timestamp,
    aps_w: &[Vector3<f64>],
    g: f64,
) {
    let b0 = truth_at(t0.as_secs_f64());
    let b0_from_w = b0.world_from_body.inverse();
    let state_of = |t: Timestamp| {
        let s = truth_at(t.as_secs_f64());
        let bk_from_w = s.world_from_body.inverse();
        let mut x = Vec9::zeros();
        x.fixed_rows_mut::<3>(0)
            .copy_from(&(b0_from_w * (s.p_b_in_w - b0.p_b_in_w)));
        x.fixed_rows_mut::<3>(3)
            .copy_from(&(bk_from_w * s.v_b_in_w));
        x.fixed_rows_mut::<3>(6)
            .copy_from(&(bk_from_w * Vector3::new(0.0, 0.0, g)));
        x
    };
    let aps_in_b0: Vec<Vector3<f64>> = aps_w
        .iter()
        .map(|a| b0_from_w * (a - b0.p_b_in_w))
        .collect();
    wins.converge_from(&state_of, &aps_in_b0, 10).unwrap();
}

struct Errors {
    position_mean_m: f64,
    position_max_m: f64,
    attitude_mean_deg: f64,
    /// Mean |yaw error| (rotation about the upward axis of b0's gravity), degrees.
    yaw_mean_deg: f64,
    ap_m: Vec<f64>,
    converged_s: Option<f64>,
}

impl Run {
    fn to_b0(&self, p_w: &Vector3<f64>) -> Vector3<f64> {
        self.b0.world_from_body.inverse() * (p_w - self.b0.p_b_in_w)
    }

    /// Errors in `b0` over the frames after `from_s` (seconds since the first frame).
    fn errors(&self, from_s: f64) -> Errors {
        self.errors_between(from_s, f64::INFINITY)
    }

    /// Errors in `b0` over the frames from `from_s` to before `to_s` (seconds since the first
    /// frame).
    fn errors_between(&self, from_s: f64, to_s: f64) -> Errors {
        let t0 = self.poses[0].t.as_secs_f64();
        let (mut sum_p, mut max_p, mut sum_r, mut sum_y, mut n) = (0.0, 0.0f64, 0.0, 0.0, 0);
        let up_in_b0 = self.b0.world_from_body.inverse() * Vector3::z();
        for p in self
            .poses
            .iter()
            .filter(|p| (from_s..to_s).contains(&(p.t.as_secs_f64() - t0)))
        {
            let s = (self.truth_at)(p.t.as_secs_f64());
            let e = (p.p_b_in_b0 - self.to_b0(&s.p_b_in_w)).norm();
            let r_true: UnitQuaternion<f64> = self.b0.world_from_body.inverse() * s.world_from_body;
            sum_p += e;
            max_p = max_p.max(e);
            let err_in_b0 = log(&(p.b0_from_body * r_true.inverse()));
            sum_r += err_in_b0.norm().to_degrees();
            sum_y += err_in_b0.dot(&up_in_b0).abs().to_degrees();
            n += 1;
        }
        let w = self.wins.window();
        Errors {
            position_mean_m: sum_p / n as f64,
            position_max_m: max_p,
            attitude_mean_deg: sum_r / n as f64,
            yaw_mean_deg: sum_y / n as f64,
            ap_m: (0..self.aps_w.len())
                .map(|l| (w.ap_in_b0(l).unwrap() - self.to_b0(&self.aps_w[l])).norm())
                .collect(),
            converged_s: w.converged_at().map(|t| t.as_secs_f64() - t0),
        }
    }
}

fn scenario(name: &str, seconds: f64) -> Scenario {
    let mut s = Scenario::built_in(name)
        .unwrap()
        .airborne()
        .without_vibration();
    s.duration_s = seconds;
    s
}

#[test]
fn paper_circle_with_two_degree_bearings() {
    let sc = scenario("paper-circle", 40.0);
    let r = run(&sc, 2.0, 11, true, |_| true);
    let converged_s = r.errors(0.0).converged_s;
    let e = r.errors(converged_s.unwrap_or(0.0));
    eprintln!(
        "paper-circle 40 s, 2° AoA, MicroStrain: converged at {:?} s; after convergence position mean {:.3} m (max {:.3}), AP {:.3} m, attitude {:.3}° (yaw {:.3}°); stats {:?}",
        e.converged_s,
        e.position_mean_m,
        e.position_max_m,
        e.ap_m[0],
        e.attitude_mean_deg,
        e.yaw_mean_deg,
        r.wins.stats()
    );
    // The AP range from b0 against the truth (the algebraic AoA rows shrank it by 25 % before
    // the angle rows and the joint gyro bias).
    let est = r.wins.window().ap_in_b0(0).unwrap().norm();
    let truth = r.to_b0(&r.aps_w[0]).norm();
    eprintln!(
        "AP range from b0: {est:.2} m estimated, {truth:.2} m true ({:+.1} %)",
        100.0 * (est / truth - 1.0)
    );
    // The aims are 10 s, 0.15 m, 0.15 m and 0.5°; not met yet (docs/RESULTS.md). These bounds
    // are 20 % above what the estimator does today (11.5 s, 0.32 m, 0.16 m, 0.52°), so a 20 %
    // regression fails them.
    assert!(
        e.converged_s.is_some_and(|t| t <= 13.8),
        "{:?}",
        e.converged_s
    );
    assert!(e.position_mean_m <= 0.39, "{}", e.position_mean_m);
    assert!(e.ap_m[0] <= 0.19, "{}", e.ap_m[0]);
    assert!(e.attitude_mean_deg <= 0.63, "{}", e.attitude_mean_deg);
    assert!((est / truth - 1.0).abs() < 0.05);
}

/// Study: what limits [`paper_circle_with_two_degree_bearings`]. The same flights with the
/// gyro's turn-on bias known (removed from the simulated MicroStrain, every other noise kept)
/// meet the 0.15 m aim on the median of three noise seeds, with the attitude error falling from
/// 0.55–1.35° to ~0.05°. One AP observes a ±0.08 °/s turn-on bias only slowly; the first seconds
/// after convergence carry metre errors while it settles.
#[test]
#[ignore = "heavy: a study (docs/RESULTS.md); run by `cargo test --release -- --ignored` (CI runs it)"]
fn with_the_gyro_turn_on_bias_known_the_aims_are_met() {
    let mut sc = scenario("paper-circle", 40.0);
    let mut noise = sc.imu.model.noise();
    noise.gyro_turn_on_bias_rad_s = 0.0;
    sc.imu.model = wins::sim::imu::ImuModel::Custom(noise);
    let mut position = Vec::new();
    for seed in [11, 12, 13] {
        let r = run(&sc, 2.0, seed, true, |_| true);
        let converged_s = r.errors(0.0).converged_s;
        let e = r.errors(converged_s.unwrap_or(0.0));
        eprintln!(
            "seed {seed}, gyro turn-on bias known: converged at {converged_s:?} s; position {:.3} m, AP {:.3} m, attitude {:.3}°",
            e.position_mean_m, e.ap_m[0], e.attitude_mean_deg
        );
        // Convergence: 11.5 s (the aim of 10 s is not met; docs/RESULTS.md).
        assert!(converged_s.is_some_and(|t| t <= 12.0), "{converged_s:?}");
        assert!(e.position_mean_m <= 0.25, "{}", e.position_mean_m);
        assert!(e.ap_m[0] <= 0.2, "{}", e.ap_m[0]);
        assert!(e.attitude_mean_deg <= 0.1, "{}", e.attitude_mean_deg);
        position.push(e.position_mean_m);
    }
    position.sort_by(f64::total_cmp);
    assert!(position[1] <= 0.15, "median {}", position[1]);
}

/// Study: the aims (0.15 m with a 10 s convergence) against what the data hold. The estimate
/// started at the TRUE state at 10 s
/// (every frame, the AP; [`LinearEstimator::converge_from`]), re-linearized every frame, the window 10 s
/// long and never declared lost, is the best an estimator converging at 10 s can do on this
/// flight. With the MicroStrain's turn-on gyro bias unknown its mean position error over
/// 10–40 s is 0.23–0.33 m on seeds 11–13 (0.33–0.68 m over 10–15 s): the 0.15 m aim with a
/// 10 s convergence is beyond the information in the data, for any estimator (with the bias
/// removed from the simulated IMU the same start nearly meets it). It asserts that the floor is
/// still above the aim: a better data model would fail it, which is why it is a study.
#[test]
#[ignore = "heavy: a study (docs/RESULTS.md); run by `cargo test --release -- --ignored` (CI runs it)"]
fn the_information_floor() {
    let sc = scenario("paper-circle", 40.0);
    let start = TruthStart {
        after_s: 10.0,
        max_frames: 500,
    };
    let mut position = Vec::new();
    for seed in [11, 12, 13] {
        let r = run_with_offset(&sc, 2.0, seed, true, |_| true, |_| 0.0, Some(start));
        let e = r.errors(10.0);
        let early = r.errors_between(10.0, 15.0);
        let late = r.errors(20.0).position_mean_m;
        eprintln!(
            "seed {seed}, started at the truth at 10 s: position {:.3} m (10–15 s: {:.3} m, from 20 s: {late:.3} m), AP {:.3} m, attitude {:.3}°",
            e.position_mean_m, early.position_mean_m, e.ap_m[0], e.attitude_mean_deg
        );
        // The start took (the window's own convergence comes at 11.5 s on these seeds).
        let converged_s = r.errors(0.0).converged_s;
        assert!(converged_s.is_some_and(|t| t <= 10.1), "{converged_s:?}");
        // Started at the truth, it stays near it: settled after 20 s, the AP within 0.25 m.
        assert!(late <= 0.3, "{late}");
        assert!(e.ap_m[0] <= 0.25, "{}", e.ap_m[0]);
        position.push(e.position_mean_m);
    }
    position.sort_by(f64::total_cmp);
    // The floor: well above the 0.15 m aim on the median seed. If a better model of the data
    // lowers it, this fails, and the aim may be within reach again.
    assert!(position[1] > 0.2, "median {}", position[1]);
}

/// Study: the three-AP aim (≤ 0.15 m) against the paper's 5-DoF model: its AoA rows take each AP
/// at the array's height, which `paper-circle-3ap` breaks on purpose (APs 0.7 m above and 0.5 m
/// below the flight). With true bearings plus 2° noise, started at the TRUE state at 10 s (the
/// floor, as in [`the_information_floor`]), the off-plane APs stay ~0.6 m off and the position
/// above 0.2 m; the same flight with all three APs at the flight's height, started from zeros,
/// meets the aim. So on this flight the aim needs the APs' heights, which a linear array sees only
/// through the MAV's small tilts and the range (the exact cone row, `cone_rows`, finds them on
/// these bearings but fails for APs in the flight's plane and in the pipeline: docs/RESULTS.md).
/// It asserts the off-plane APs stay off, so a better model fails it: a study.
#[test]
#[ignore = "heavy: a study (docs/RESULTS.md); run by `cargo test --release -- --ignored` (CI runs it)"]
fn three_aps_off_the_flight_plane() {
    let off_plane = scenario("paper-circle-3ap", 40.0);
    // `ap0` is at the flight's height (1.5 m); the others are moved to it.
    let mut in_plane = off_plane.clone();
    let height_m = off_plane.aps[0].position_m[2];
    for ap in &mut in_plane.aps {
        ap.position_m[2] = height_m;
    }
    let start = TruthStart {
        after_s: 10.0,
        max_frames: 500,
    };
    let floor = run_with_offset(&off_plane, 2.0, 11, true, |_| true, |_| 0.0, Some(start));
    let f = floor.errors(10.0);
    let flat = run(&in_plane, 2.0, 11, true, |_| true);
    let converged_s = flat.errors(0.0).converged_s;
    let e = flat.errors(converged_s.unwrap_or(f64::INFINITY));
    eprintln!(
        "paper-circle-3ap 40 s, 2° AoA: started at the truth at 10 s, position {:.3} m, APs {:.2?} m, attitude {:.2}°; APs at the flight's height, from zeros: converged at {converged_s:?} s, position {:.3} m, APs {:.2?} m, attitude {:.2}°",
        f.position_mean_m,
        f.ap_m,
        f.attitude_mean_deg,
        e.position_mean_m,
        e.ap_m,
        e.attitude_mean_deg
    );
    // The AP on the flight's height is found; the two off it are not, even from the truth.
    assert!(f.ap_m[0] < 0.2, "{:?}", f.ap_m);
    assert!(f.ap_m[1] > 0.4 && f.ap_m[2] > 0.4, "{:?}", f.ap_m);
    assert!(f.position_mean_m > 0.2, "{}", f.position_mean_m);
    // In the plane the window's own estimate meets the aim.
    assert!(converged_s.is_some_and(|t| t <= 10.0), "{converged_s:?}");
    assert!(e.position_mean_m <= 0.15, "{}", e.position_mean_m);
    assert!(e.ap_m.iter().all(|&a| a <= 0.15), "{:?}", e.ap_m);
}

#[test]
fn the_joint_gyro_bias_and_yaw_drift() {
    // The attitude with and without the window's gyro-bias estimate: on the MicroStrain (turn-on
    // 0.08 °/s per axis) it removes most of the drift (on a consumer MEMS gyro, 0.5 °/s, it does
    // not yet: docs/RESULTS.md).
    let from = |r: &Run| r.errors(r.errors(0.0).converged_s.unwrap_or(10.0));
    let sc = scenario("paper-circle", 40.0);
    let (a, b) = (
        from(&run(&sc, 2.0, 11, true, |_| true)),
        from(&run(&sc, 2.0, 11, false, |_| true)),
    );
    eprintln!(
        "MicroStrain, 40 s, after convergence, gyro bias estimated / not: yaw {:.2}° / {:.2}°, attitude {:.2}° / {:.2}°, position {:.3} m / {:.3} m, AP {:.3} m / {:.3} m",
        a.yaw_mean_deg,
        b.yaw_mean_deg,
        a.attitude_mean_deg,
        b.attitude_mean_deg,
        a.position_mean_m,
        b.position_mean_m,
        a.ap_m[0],
        b.ap_m[0]
    );
    assert!(a.attitude_mean_deg < 0.6 * b.attitude_mean_deg);
    assert!(a.ap_m[0] < 0.2 * b.ap_m[0]);
}

#[test]
fn ideal_imu_and_precise_bearings_converge_to_centimetres() {
    let mut sc = scenario("paper-circle", 30.0);
    sc.imu.model = wins::sim::imu::ImuModel::Ideal;
    let r = run(&sc, 0.1, 12, true, |_| true);
    let e = r.errors(15.0);
    eprintln!(
        "paper-circle 30 s, ideal IMU, 0.1° AoA: converged at {:?} s; after 15 s position {:.3} m (max {:.3}), AP {:.3} m",
        e.converged_s, e.position_mean_m, e.position_max_m, e.ap_m[0]
    );
    assert!(e.converged_s.is_some_and(|t| t <= 15.0));
    assert!(
        e.position_mean_m <= 0.1 && e.ap_m[0] <= 0.15,
        "{} {}",
        e.position_mean_m,
        e.ap_m[0]
    );
}

#[test]
fn outages_and_a_still_start_stay_finite_and_recover() {
    // Five seconds without any bearing in the middle of the flight.
    let sc = scenario("paper-circle", 30.0);
    let mut sc_ideal = sc.clone();
    sc_ideal.imu.model = wins::sim::imu::ImuModel::Ideal;
    let r = run(&sc_ideal, 0.1, 13, true, |t| !(12.0..17.0).contains(&t));
    let e = r.errors(25.0);
    eprintln!(
        "5 s outage (12–17 s): after 25 s position {:.3} m, AP {:.3} m",
        e.position_mean_m, e.ap_m[0]
    );
    assert!(e.position_mean_m <= 0.2, "{}", e.position_mean_m);
    // A still start: the built-in hover never moves, so nothing is observable; the estimate must
    // stay finite (asserted per frame in `run`) and must not claim convergence.
    let mut hover = Scenario::built_in("hover")
        .unwrap()
        .airborne()
        .without_vibration();
    hover.duration_s = 5.0;
    let r = run(&hover, 2.0, 14, true, |_| true);
    assert!(r.wins.window().converged_at().is_none());
    assert!(
        r.poses
            .iter()
            .all(|p| p.p_b_in_w.iter().all(|x| x.is_finite()))
    );
}

#[test]
fn a_lost_estimate_restarts_where_it_was() {
    // From 20 s the bearings swing ±40° at 3.7 Hz (a broken AoA stage; a constant offset is
    // absorbed by moving the AP): the converged window stops fitting, is declared lost
    // and starts over; the output world must not jump back to the first frame's origin, and the
    // convergence time stays the first one.
    let sc = scenario("paper-circle", 26.0);
    let r = run_with_offset(
        &sc,
        2.0,
        11,
        true,
        |_| true,
        |t| {
            if t >= 20.0 {
                40.0 * (std::f64::consts::TAU * 3.7 * t).sin()
            } else {
                0.0
            }
        },
        None,
    );
    let stats = r.wins.stats();
    assert!(stats.restarts >= 1, "{stats:?}");
    let first = r.wins.converged_at().map(|t| t.as_secs_f64());
    assert!(first.is_some_and(|t| t < 20.0), "{first:?}");
    // The restart: the first pose of a new window (its b0 is its first frame, p_b_in_b0 ≈ 0).
    let i = (1..r.poses.len())
        .rfind(|&i| r.poses[i].p_b_in_b0.norm() < 0.01 && r.poses[i - 1].p_b_in_b0.norm() > 0.5)
        .expect("a new window's first frame");
    assert!(i > 0 && r.poses[i].t.as_secs_f64() > 20.0);
    let jump = (r.poses[i].p_b_in_w - r.poses[i - 1].p_b_in_w).norm();
    let from_origin = r.poses[i - 1].p_b_in_w.norm();
    eprintln!(
        "restart at {:.2} s: output moved {jump:.3} m (the lost pose is {from_origin:.2} m from the origin); {stats:?}",
        r.poses[i].t.as_secs_f64()
    );
    assert!(
        from_origin > 1.0,
        "the test needs a restart away from the origin"
    );
    // The anchor is the last pose that still fitted, up to `lost_after_frames` (0.5 s) back.
    assert!(jump < 1.0, "{jump}");
}
