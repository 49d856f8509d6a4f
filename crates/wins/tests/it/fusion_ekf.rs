//! The EKF of the paper's feasibility study (Sec. III): 1 AP, 1° bearings, 100 Hz IMU with
//! σ 0.01 m/s² and 0.01 rad/s per sample, IMU only vs 2 Hz vs 20 Hz bearings; and the EKF's
//! dependence on its initial guess.

use nalgebra::{DMatrix, Isometry3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wins::aoa::steering::aoa_rad;
use wins::fusion::bearing::{Bearing, side_of};
use wins::fusion::paper::ekf::state::POSITION;
use wins::fusion::paper::ekf::{Ekf, EkfConfig, EkfReport, EkfState};
use wins::imu::ImuSample;
use wins::sim::imu::ImuModel;
use wins::sim::motion::BodyState;
use wins::sim::run::world_from_array;
use wins::sim::{Scenario, simulate};

/// The paper's IMU rate, Hz.
const IMU_RATE_HZ: f64 = 100.0;
/// The paper's per-sample IMU noise: accelerometer m/s², gyro rad/s.
const ACCEL_SIGMA_PER_SAMPLE: f64 = 0.01;
const GYRO_SIGMA_PER_SAMPLE: f64 = 0.01;
/// The paper's AoA noise, 1°.
const AOA_SIGMA_DEG: f64 = 1.0;
/// Flight length, s.
const FLIGHT_S: f64 = 30.0;

/// A noise-free flight of the paper's circle: truth at every IMU sample, and the perfect IMU.
struct Flight {
    states: Vec<BodyState>,
    imu: Vec<ImuSample>,
    ap_in_w: Vector3<f64>,
    body_from_array: Isometry3<f64>,
    gravity_m_s2: f64,
}

fn paper_circle(duration_s: f64) -> Flight {
    let mut s = Scenario::built_in("paper-circle")
        .expect("built in")
        .airborne()
        .without_vibration();
    s.duration_s = duration_s;
    s.imu.rate_hz = IMU_RATE_HZ;
    s.imu.model = ImuModel::Ideal;
    // Bearings are computed from the states below: keep the (slow) CSI synthesis minimal.
    s.radio.packet_rate_hz = 0.1;
    let out = simulate(&s, &mut |_| {}).expect("valid scenario");
    Flight {
        states: out.states.iter().map(|(_, b)| *b).collect(),
        imu: out.imu,
        ap_in_w: Vector3::from(out.aps[0].config.position_m),
        body_from_array: s.body_from_array(),
        gravity_m_s2: s.gravity_m_s2,
    }
}

/// The paper's IMU noise per sample, added to the perfect readings: one stream per sensor.
fn noisy_imu(imu: &[ImuSample], seed: u64) -> Vec<ImuSample> {
    let mut gyro_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6759_0000);
    let mut accel_rng = ChaCha8Rng::seed_from_u64(seed ^ 0xACCE_0000);
    let g = Normal::new(0.0, GYRO_SIGMA_PER_SAMPLE).expect("valid σ");
    let a = Normal::new(0.0, ACCEL_SIGMA_PER_SAMPLE).expect("valid σ");
    imu.iter()
        .map(|u| ImuSample {
            t: u.t,
            gyro_rad_s: u.gyro_rad_s + Vector3::from_fn(|_, _| g.sample(&mut gyro_rng)),
            accel_m_s2: u.accel_m_s2 + Vector3::from_fn(|_, _| a.sample(&mut accel_rng)),
        })
        .collect()
}

fn ekf_config(flight: &Flight) -> EkfConfig {
    let dt = 1.0 / IMU_RATE_HZ;
    EkfConfig {
        // Continuous densities from the per-sample σ: σ_c = σ_d·√Δt (docs/DESIGN.md §2).
        gyro_noise_density_rad_s_sqrt_hz: GYRO_SIGMA_PER_SAMPLE * dt.sqrt(),
        accel_noise_density_m_s2_sqrt_hz: ACCEL_SIGMA_PER_SAMPLE * dt.sqrt(),
        gravity_m_s2: flight.gravity_m_s2,
        body_from_array: flight.body_from_array,
        mahalanobis_gate: None,
    }
}

fn truth(flight: &Flight, i: usize) -> EkfState {
    let s = &flight.states[i];
    EkfState {
        t: flight.imu[i].t,
        world_from_body: s.world_from_body,
        v_b_in_w: s.v_b_in_w,
        p_b_in_w: s.p_b_in_w,
        c_in_w: vec![flight.ap_in_w],
    }
}

/// Error-state covariance with the given standard deviations (attitude rad, velocity m/s,
/// position m, AP m).
fn covariance(att: f64, vel: f64, pos: f64, ap: f64) -> DMatrix<f64> {
    DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        12,
        [att, vel, pos, ap].iter().flat_map(|s| [s * s; 3]),
    ))
}

/// The true bearing at sample `i` plus N(0, 1°), side resolved from the truth.
fn bearing(flight: &Flight, i: usize, noise: &Normal<f64>, rng: &mut ChaCha8Rng) -> Bearing {
    let world_from_array = world_from_array(&flight.states[i], &flight.body_from_array);
    let ap_in_a = world_from_array
        .inverse_transform_point(&flight.ap_in_w.into())
        .coords;
    let half_pi = std::f64::consts::FRAC_PI_2;
    Bearing {
        ap: 0,
        aoa_rad: (aoa_rad(&ap_in_a) + noise.sample(rng)).clamp(-half_pi, half_pi),
        side: side_of(&ap_in_a),
        sigma_rad: AOA_SIGMA_DEG.to_radians(),
    }
}

struct RunResult {
    end_position_error_m: f64,
    end_ap_error_m: f64,
    /// Normalized estimation error squared of the end position, `eᵀ P_pp⁻¹ e` (χ², 3 dof when
    /// the filter is consistent).
    end_position_nees: f64,
    report: EkfReport,
}

/// Runs the EKF over `imu` from `initial`, with a bearing every `bearing_every` samples (none if
/// `None`), and measures the errors at the end.
fn run(
    flight: &Flight,
    config: EkfConfig,
    imu: &[ImuSample],
    initial: EkfState,
    p0: DMatrix<f64>,
    bearing_every: Option<usize>,
    seed: u64,
) -> RunResult {
    let mut ekf = Ekf::new(config, initial, p0).expect("valid initial state");
    let noise = Normal::new(0.0, AOA_SIGMA_DEG.to_radians()).expect("valid σ");
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xB0A0_0000);
    for (i, u) in imu.iter().enumerate() {
        ekf.propagate(u);
        if let Some(every) = bearing_every
            && i > 0
            && i.is_multiple_of(every)
        {
            ekf.update(&bearing(flight, i, &noise, &mut rng));
        }
    }
    let last = flight.states.len() - 1;
    let s = ekf.state();
    let e = s.p_b_in_w - flight.states[last].p_b_in_w;
    let p_pp = ekf
        .covariance()
        .fixed_view::<3, 3>(POSITION, POSITION)
        .into_owned();
    let end_position_nees = p_pp
        .cholesky()
        .map_or(f64::INFINITY, |c| e.dot(&c.solve(&e)));
    RunResult {
        end_position_error_m: e.norm(),
        end_ap_error_m: (s.c_in_w[0] - flight.ap_in_w).norm(),
        end_position_nees,
        report: *ekf.report(),
    }
}

/// With a perfect IMU the mid-point propagation reproduces the simulated flight: the EKF's
/// integration is not what limits it.
#[test]
fn noise_free_imu_reproduces_the_flight() {
    let flight = paper_circle(FLIGHT_S);
    let r = run(
        &flight,
        ekf_config(&flight),
        &flight.imu,
        truth(&flight, 0),
        covariance(1e-3, 1e-3, 1e-3, 1e-3),
        None,
        0,
    );
    eprintln!(
        "noise-free IMU, {FLIGHT_S} s at {IMU_RATE_HZ} Hz: end position error {:.4} m",
        r.end_position_error_m
    );
    assert!(r.end_position_error_m < 0.05, "{}", r.end_position_error_m);
    assert_eq!(r.report.imu_propagated, flight.imu.len() - 1);
}

/// Root mean square over runs.
fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// Runs per case (fixed seeds); the ordering is asserted on the RMS over them, since single
/// runs of the 2 Hz and 20 Hz filters overlap.
const SEEDS: [u64; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

/// Paper Sec. III: end errors 0.0293 m (20 Hz AoA), 1.2583 m (2 Hz), 2.6905 m (IMU only). The
/// paper does not give its trajectory or AP placement; on the paper's circle (AP 2.5–7.5 m away)
/// we measure, over 8 seeds (`cargo test -p wins --test it fusion_ekf -- --nocapture`), an RMS
/// end error of 11.6 m for the IMU alone, 0.76 m with 2 Hz and 0.30 m with 20 Hz bearings, the
/// 20 Hz filter consistent with its covariance (mean NEES 1.6, slightly conservative). A 1° bearing at 5 m is 9 cm across, and the
/// range is only observable through the motion: 3 cm is not reachable here.
#[test]
fn feasibility_study_bearings_correct_the_imu_drift() {
    let flight = paper_circle(FLIGHT_S);
    let config = ekf_config(&flight);
    let p0 = covariance(0.1f64.to_radians(), 0.01, 0.01, 0.01);
    let every_20_hz = (IMU_RATE_HZ / 20.0) as usize;
    let every_2_hz = (IMU_RATE_HZ / 2.0) as usize;
    let mut runs = Vec::new();
    for seed in SEEDS {
        let imu = noisy_imu(&flight.imu, seed);
        let x0 = truth(&flight, 0);
        let case = |every| {
            run(
                &flight,
                config.clone(),
                &imu,
                x0.clone(),
                p0.clone(),
                every,
                seed,
            )
        };
        let (only, slow, fast) = (case(None), case(Some(every_2_hz)), case(Some(every_20_hz)));
        eprintln!(
            "seed {seed}: end position error IMU only {:.4} m, 2 Hz {:.4} m, 20 Hz {:.4} m \
             (NEES {:.2}, AP error {:.4} m)",
            only.end_position_error_m,
            slow.end_position_error_m,
            fast.end_position_error_m,
            fast.end_position_nees,
            fast.end_ap_error_m,
        );
        assert_eq!(fast.report.bearings_applied, flight.imu.len() / every_20_hz);
        assert_eq!(slow.report.bearings_applied, flight.imu.len() / every_2_hz);
        runs.push((only, slow, fast));
    }
    let only = rms(runs.iter().map(|r| r.0.end_position_error_m));
    let slow = rms(runs.iter().map(|r| r.1.end_position_error_m));
    let fast = rms(runs.iter().map(|r| r.2.end_position_error_m));
    let mean_nees = runs.iter().map(|r| r.2.end_position_nees).sum::<f64>() / runs.len() as f64;
    eprintln!(
        "RMS over {} seeds, {FLIGHT_S} s: IMU only {only:.4} m, 2 Hz {slow:.4} m, 20 Hz {fast:.4} m \
         (paper: 2.6905, 1.2583, 0.0293); 20 Hz mean position NEES {mean_nees:.2} (3 if consistent)",
        SEEDS.len()
    );
    assert!(fast < slow && slow < only, "{fast} < {slow} < {only}");
    assert!(fast < 0.4, "20 Hz RMS end error {fast} m");
    assert!(slow < 0.2 * only, "2 Hz {slow} m vs IMU only {only} m");
    assert!(
        mean_nees < 9.0,
        "20 Hz filter overconfident: mean NEES {mean_nees}"
    );
}

/// The paper's case against the EKF: it needs a good initial guess. The vehicle starts at the
/// truth but the AP is guessed 3 m too far along the first line of sight (so the first bearings
/// agree with the guess: a bearing carries no range) with a confident σ of 0.1 m. Measured over 4
/// seeds: the EKF does pull the AP back, slowly, but after 30 s both the AP (≈ 1.5 m) and the
/// vehicle (1.3–1.9 m) are still off by more than 4× the truth-initialized error; with a
/// Mahalanobis gate it rejects the correct bearings and fails worse (2.3 m to tens of metres).
/// Only an honest σ of 3 m lets the same guess recover (≈ 0.4 m).
#[test]
fn a_confident_wrong_initial_guess_is_not_recovered() {
    let flight = paper_circle(FLIGHT_S);
    let config = ekf_config(&flight);
    let gated = EkfConfig {
        mahalanobis_gate: Some(CHI2_1DOF_999),
        ..config.clone()
    };
    let mut x0 = truth(&flight, 0);
    x0.c_in_w[0] += AP_GUESS_OFFSET_M;
    let confident = covariance(0.1f64.to_radians(), 0.01, 0.01, 0.1);
    let honest = covariance(0.1f64.to_radians(), 0.01, 0.01, 3.0);
    let seeds = &SEEDS[..4];
    let mut rows = Vec::new();
    for &seed in seeds {
        let imu = noisy_imu(&flight.imu, seed);
        let case = |c: &EkfConfig, p0: &DMatrix<f64>| {
            run(
                &flight,
                c.clone(),
                &imu,
                x0.clone(),
                p0.clone(),
                Some(5),
                seed,
            )
        };
        let (bad, bad_gated, ok) = (
            case(&config, &confident),
            case(&gated, &confident),
            case(&config, &honest),
        );
        let rejected = bad_gated.report.bearings_gated + bad_gated.report.bearings_side_mismatch;
        eprintln!(
            "seed {seed}: AP guessed 3 m off, σ 0.1 m: vehicle {:.3} m, AP {:.3} m; gated: \
             vehicle {:.3} m, AP {:.3} m, {rejected} of 600 bearings rejected; σ 3 m: vehicle \
             {:.3} m, AP {:.3} m",
            bad.end_position_error_m,
            bad.end_ap_error_m,
            bad_gated.end_position_error_m,
            bad_gated.end_ap_error_m,
            ok.end_position_error_m,
            ok.end_ap_error_m,
        );
        assert!(rejected > 150, "{rejected}");
        rows.push((bad, bad_gated, ok));
    }
    let bad = rms(rows.iter().map(|r| r.0.end_position_error_m));
    let bad_ap = rms(rows.iter().map(|r| r.0.end_ap_error_m));
    let bad_gated = rms(rows.iter().map(|r| r.1.end_position_error_m));
    let ok = rms(rows.iter().map(|r| r.2.end_position_error_m));
    eprintln!(
        "RMS: confident wrong guess {bad:.3} m (AP {bad_ap:.3} m), gated {bad_gated:.3} m, \
         honest covariance {ok:.3} m"
    );
    assert!(bad > 1.0 && bad_ap > 1.0, "vehicle {bad} m, AP {bad_ap} m");
    assert!(bad_gated > 2.0, "{bad_gated}");
    assert!(ok < 0.6, "{ok}");
}

/// The AP guess of [`a_confident_wrong_initial_guess_is_not_recovered`]: 3 m farther along the
/// first line of sight (the flight starts at (8.5, 4, 1.5) looking at the AP at (1, 4, 1.5)).
const AP_GUESS_OFFSET_M: Vector3<f64> = Vector3::new(-3.0, 0.0, 0.0);
/// χ² 99.9 % quantile, 1 degree of freedom.
const CHI2_1DOF_999: f64 = 10.83;
