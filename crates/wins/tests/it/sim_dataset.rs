//! The simulator's files. The IMU integrates back to the trajectory, the logs read back
//! bit for bit, the clocks line up, and each random stream is independent of the others.

use super::pipeline_run::temp_dir;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use wins::csi::intel5300::read_log;
use wins::dataset::Dataset;
use wins::dataset::truth::Truth;
use wins::imu::ImuSample;
use wins::sim::imu::ImuModel;
use wins::sim::{Scenario, SimOutput, simulate, write_dataset};

fn scenario(name: &str) -> Scenario {
    Scenario::built_in(name)
        .unwrap()
        .airborne()
        .without_vibration()
}

fn run(s: &Scenario) -> SimOutput {
    simulate(s, &mut |_| {}).unwrap()
}

/// Classical RK4 over (q, v, p) with step 2Δt, using samples k, k+1 (midpoint) and k+2.
fn integrate(
    imu: &[ImuSample],
    g: f64,
    mut q: UnitQuaternion<f64>,
    mut v: Vector3<f64>,
    mut p: Vector3<f64>,
) -> (UnitQuaternion<f64>, Vector3<f64>, Vector3<f64>, i64) {
    let gravity = Vector3::new(0.0, 0.0, -g);
    let deriv = |q: &Quaternion<f64>, v: &Vector3<f64>, s: &ImuSample| {
        let w = s.gyro_rad_s;
        let dq = q * Quaternion::new(0.0, w.x, w.y, w.z) * 0.5;
        let r = UnitQuaternion::from_quaternion(*q);
        (dq, r * s.accel_m_s2 + gravity, *v)
    };
    let mut k = 0;
    while k + 2 < imu.len() {
        let h = (imu[k + 2].t.as_nanos() - imu[k].t.as_nanos()) as f64 * 1e-9;
        let (s0, s1, s2) = (&imu[k], &imu[k + 1], &imu[k + 2]);
        let q0 = *q.quaternion();
        let (k1q, k1v, k1p) = deriv(&q0, &v, s0);
        let (k2q, k2v, k2p) = deriv(&(q0 + k1q * (h / 2.0)), &(v + k1v * (h / 2.0)), s1);
        let (k3q, k3v, k3p) = deriv(&(q0 + k2q * (h / 2.0)), &(v + k2v * (h / 2.0)), s1);
        let (k4q, k4v, k4p) = deriv(&(q0 + k3q * h), &(v + k3v * h), s2);
        q = UnitQuaternion::from_quaternion(q0 + (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0));
        p += (k1p + k2p * 2.0 + k3p * 2.0 + k4p) * (h / 6.0);
        v += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
        k += 2;
    }
    (q, v, p, imu[k].t.as_nanos())
}

#[test]
fn noise_free_imu_from_the_dataset_integrates_back_to_the_truth_over_60_s() {
    for name in ["paper-circle", "figure8-yaw"] {
        let mut s = scenario(name);
        s.imu.model = ImuModel::Ideal;
        s.duration_s = 60.0;
        let dir = temp_dir(name);
        let out = run(&s);
        write_dataset(&dir, &s, &out).unwrap();
        // Everything from disk: the IMU CSV and the TUM truth, as a user would.
        let data = Dataset::load(&dir).unwrap();
        let truth = Truth::load(&dir).unwrap();
        let first = &truth.poses[0];
        // Initial velocity from the truth poses' neighbours is not exact; take it from the model.
        let v0 = out.states[0].1.v_b_in_w;
        let (q, _, p, t_end) = integrate(
            &data.imu,
            s.gravity_m_s2,
            first.world_from_body,
            v0,
            first.p_b_in_w,
        );
        let end = truth
            .poses
            .iter()
            .find(|x| x.t.as_nanos() == t_end)
            .unwrap();
        let dp = (p - end.p_b_in_w).norm();
        let dq = (q.inverse() * end.world_from_body).angle();
        assert!(t_end >= 59_990_000_000, "{t_end}");
        // The issue asks ≤ 1 mm; measured 1.8e-8 m / 6.7e-12 rad (circle) and 1.4e-7 m /
        // 1.8e-10 rad (figure-eight), so a tighter bound catches subtler regressions.
        assert!(dp <= 1e-5, "{name}: position error {dp} m after 60 s");
        assert!(dq <= 1e-8, "{name}: attitude error {dq} rad after 60 s");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn hovering_accelerometer_reads_plus_g() {
    let mut s = scenario("hover");
    s.imu.model = ImuModel::Ideal;
    s.duration_s = 2.0;
    let out = run(&s);
    for sample in &out.imu {
        assert!((sample.accel_m_s2 - Vector3::new(0.0, 0.0, s.gravity_m_s2)).norm() < 1e-12);
        assert!(sample.gyro_rad_s.norm() < 1e-12);
    }
}

#[test]
fn logs_read_back_identically_and_clocks_line_up_across_a_wrap() {
    let mut s = scenario("paper-circle-3ap");
    s.duration_s = 20.0;
    // The NIC's 32-bit microsecond clock wraps 10 s into the flight.
    s.radio.nic_clock_at_imu_zero_us = (1u64 << 32) - 10_000_000;
    let out = run(&s);
    let dir = temp_dir("wrap");
    let report = write_dataset(&dir, &s, &out).unwrap();
    assert_eq!(report.packets.len(), 3);
    let data = Dataset::load(&dir).unwrap();
    let truth = Truth::load(&dir).unwrap();
    assert_eq!(truth.aps.len(), 3);
    for (i, ap) in out.aps.iter().enumerate() {
        let log = read_log(dir.join(format!("{}.dat", ap.config.name))).unwrap();
        assert!(log.skips.is_empty());
        let sent: Vec<_> = ap.received().map(|(_, r)| r).collect();
        assert_eq!(log.records.len(), sent.len());
        assert!(sent.len() as f64 > 0.9 * 50.0 * 20.0, "{}", sent.len());
        for (read, written) in log.records.iter().zip(&sent) {
            assert_eq!(read.header, written.header);
            assert_eq!(read.csi(), written.csi());
        }
        let wrapped = sent
            .windows(2)
            .any(|w| w[1].header.timestamp_low < w[0].header.timestamp_low);
        assert!(wrapped, "the clock wrapped during the flight");
        // Loader times (NIC clock + manifest offset) equal the truth times to the microsecond.
        let rows: Vec<_> = truth.packets[i].iter().filter(|r| r.received).collect();
        assert_eq!(rows.len(), data.aps[i].packets.len());
        for (row, pkt) in rows.iter().zip(&data.aps[i].packets) {
            assert_eq!(pkt.t.as_nanos(), row.t_ns.div_euclid(1000) * 1000);
            assert_eq!(
                pkt.record.intel5300().unwrap().header.bfee_count,
                row.bfee_count
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn each_random_stream_has_its_own_seed() {
    let base = {
        let mut s = scenario("paper-circle");
        s.duration_s = 10.0;
        s
    };
    let a = run(&base);

    // Changing the CSI rate does not change the IMU noise draw.
    let mut faster = base.clone();
    faster.radio.packet_rate_hz = 20.0;
    let b = run(&faster);
    assert_eq!(a.imu, b.imu);
    assert_ne!(a.aps[0].packets.len(), b.aps[0].packets.len());

    // Adding an AP leaves the first AP's packets alone.
    let mut more = base.clone();
    let mut ap1 = more.aps[0].clone();
    ap1.name = "ap1".into();
    ap1.position_m = [11.0, 1.0, 2.0];
    more.aps.push(ap1);
    let c = run(&more);
    let pa: Vec<_> = a.aps[0].received().map(|(_, r)| r.clone()).collect();
    let pc: Vec<_> = c.aps[0].received().map(|(_, r)| r.clone()).collect();
    assert_eq!(pa, pc);
    assert_eq!(a.imu, c.imu);

    // A different IMU model changes only the IMU.
    let mut consumer = base.clone();
    consumer.imu.model = ImuModel::ConsumerMems;
    let d = run(&consumer);
    assert_ne!(a.imu, d.imu);
    assert_eq!(a.aps[0].packets.len(), d.aps[0].packets.len());
    for (x, y) in a.aps[0].packets.iter().zip(&d.aps[0].packets) {
        assert_eq!(x.record, y.record);
    }

    // And the same seed reproduces everything.
    let again = run(&base);
    assert_eq!(a.imu, again.imu);
    for (x, y) in a.aps[0].packets.iter().zip(&again.aps[0].packets) {
        assert_eq!(x.record, y.record);
        assert_eq!(x.t, y.t);
    }
}

#[test]
fn the_obstacle_scenario_blocks_the_direct_path_and_lowers_the_k_factor() {
    let mut clear = scenario("paper-circle");
    clear.duration_s = 10.0;
    let mut blocked = scenario("paper-circle-obstacle");
    blocked.duration_s = 10.0;
    let (c, b) = (run(&clear).summary(), run(&blocked).summary());
    assert_eq!(c.aps[0].obstructed, 0.0);
    assert!(b.aps[0].obstructed > 0.99, "{}", b.aps[0].obstructed);
    // The board takes 10 dB off the direct path, but also off the reflections that cross it
    // (the floor bounce near the AP), so K drops by less than 10 dB.
    assert!(
        b.aps[0].k_factor_db < c.aps[0].k_factor_db - 3.0,
        "{} vs {}",
        b.aps[0].k_factor_db,
        c.aps[0].k_factor_db
    );
}

#[test]
fn figure8_yaw_turns_the_ap_behind_the_array_and_paper_circle_does_not() {
    let circle = run(&scenario("paper-circle")).summary();
    assert_eq!(circle.aps[0].in_front, 1.0);
    assert!(circle.aps[0].aoa_deg.0 > -60.0 && circle.aps[0].aoa_deg.1 < 60.0);
    let eight = run(&scenario("figure8-yaw")).summary();
    assert!(
        (0.2..0.8).contains(&eight.aps[0].in_front),
        "{}",
        eight.aps[0].in_front
    );
}

#[test]
fn a_phased_flight_writes_its_barometer_and_its_truth_and_reads_back() {
    // The built-in flight as shipped: on the ground, take-off, the circle, landing.
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.duration_s = 30.0;
    assert!(s.phases.is_some() && s.baro.is_some());
    let out = run(&s);
    let dir = temp_dir("baro");
    write_dataset(&dir, &s, &out).unwrap();
    let data = Dataset::load(&dir).unwrap();
    assert_eq!(data.baro, out.baro);
    let rate_hz = s.baro.as_ref().unwrap().rate_hz;
    assert_eq!(data.baro.len(), (30.0 * rate_hz) as usize + 1);
    // Reading = truth height + offset + drift + white noise; the truth height is the flight's.
    let truth_rows: Vec<f64> = std::fs::read_to_string(dir.join("truth/baro.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(truth_rows.len(), out.baro_truth.len());
    for (row, t) in truth_rows.iter().zip(&out.baro_truth) {
        assert_eq!(*row, t.height_m);
    }
    let flight = s.build_flight();
    for t in &out.baro_truth {
        let z = flight.at(t.t.as_secs_f64()).translation.p_b_in_w.z;
        assert!((t.height_m - z).abs() < 1e-12, "{} vs {z}", t.height_m);
    }
    // On the ground at the start, at the mission's height in the middle.
    assert!((out.baro_truth[0].height_m - 0.1).abs() < 1e-12);
    assert!((out.baro_truth[out.baro_truth.len() / 2].height_m - 1.5).abs() < 0.05);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dataset_without_a_barometer_stays_valid() {
    let mut s = scenario("paper-circle");
    s.baro = None;
    s.duration_s = 5.0;
    let out = run(&s);
    assert!(out.baro.is_empty());
    let dir = temp_dir("no-baro");
    write_dataset(&dir, &s, &out).unwrap();
    assert!(!dir.join("baro.csv").exists() && !dir.join("truth/baro.csv").exists());
    let data = Dataset::load(&dir).unwrap();
    assert!(data.baro.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn on_the_ground_the_imu_reads_gravity_plus_its_biases_only() {
    // The paper's circle as shipped, with an IMU that has turn-on biases and no noise.
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.duration_s = 30.0;
    s.imu.model = ImuModel::Custom(wins::rig::ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: 0.0,
        gyro_bias_random_walk_rad_s2_sqrt_hz: 0.0,
        gyro_turn_on_bias_rad_s: 2e-3,
        accel_noise_density_m_s2_sqrt_hz: 0.0,
        accel_bias_random_walk_m_s3_sqrt_hz: 0.0,
        accel_turn_on_bias_m_s2: 0.05,
    });
    let out = run(&s);
    let rest_s = s.phases.as_ref().unwrap().rest_s;
    let mut on_ground = 0;
    for ((sample, biases), (t, _)) in out.imu.iter().zip(&out.imu_biases).zip(&out.states) {
        if t.as_secs_f64() >= rest_s {
            break;
        }
        on_ground += 1;
        let g = Vector3::new(0.0, 0.0, s.gravity_m_s2);
        assert!(
            (sample.gyro_rad_s - biases.gyro_rad_s).norm() < 1e-12,
            "{t:?}"
        );
        assert!(
            (sample.accel_m_s2 - g - biases.accel_m_s2).norm() < 1e-12,
            "{t:?}"
        );
    }
    assert!(on_ground as f64 >= rest_s * s.imu.rate_hz);
    assert!(out.imu_biases[0].gyro_rad_s.norm() > 0.0);
}
