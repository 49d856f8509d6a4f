use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::*;
use crate::imu::STANDARD_GRAVITY_M_S2;
use crate::time::NANOS_PER_SEC;

const RATE_HZ: i64 = 200;

fn noise() -> ImuNoise {
    ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: 2e-4,
        gyro_bias_random_walk_rad_s2_sqrt_hz: 0.0,
        gyro_turn_on_bias_rad_s: 2e-3,
        accel_noise_density_m_s2_sqrt_hz: 2e-3,
        accel_bias_random_walk_m_s3_sqrt_hz: 0.0,
        accel_turn_on_bias_m_s2: 0.05,
    }
}

/// A flight of `duration_s`: `rest_s` at rest at the origin, then a circle of radius 2 m at 1 m
/// height entered smoothly, heading along the track.
fn flight(duration_s: f64, rest_s: f64) -> Vec<Pose> {
    let n = (duration_s * RATE_HZ as f64) as i64;
    (0..=n)
        .map(|i| {
            let t = i as f64 / RATE_HZ as f64;
            let s = (t - rest_s).max(0.0);
            // Angle along the circle with a smooth start (0.6 rad/s after 3 s).
            let ramp = 3.0;
            let angle = if s < ramp {
                0.6 * s * s * s / (ramp * ramp) * (1.0 - s / (2.0 * ramp))
            } else {
                0.6 * (s - ramp) + 0.6 * ramp / 2.0
            };
            let p = Vector3::new(
                2.0 * angle.sin(),
                2.0 - 2.0 * angle.cos(),
                0.2 * angle.min(5.0),
            );
            Pose {
                t: Timestamp(i * NANOS_PER_SEC / RATE_HZ),
                p_b_in_w: p,
                world_from_body: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3 * angle),
            }
        })
        .collect()
}

fn input(poses: Vec<Pose>, aps: &[Vector3<f64>], packet_hz: i64) -> BoundInput {
    let end = poses[poses.len() - 1].t.as_nanos();
    let period = NANOS_PER_SEC / packet_hz;
    let packets = aps
        .iter()
        .enumerate()
        .map(|(a, _)| {
            (0..)
                .map(|k| Timestamp(k * period + a as i64 * 1_000_000))
                .take_while(|t| t.as_nanos() <= end)
                .collect()
        })
        .collect();
    BoundInput {
        poses,
        noise: noise(),
        vibration: None,
        body_from_array: Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.08),
            UnitQuaternion::identity(),
        ),
        aps: aps.to_vec(),
        packets,
        baro: Vec::new(),
        gravity_m_s2: STANDARD_GRAVITY_M_S2,
    }
}

fn one_ap() -> Vec<Vector3<f64>> {
    vec![Vector3::new(6.0, 1.0, 2.5)]
}

fn two_aps() -> Vec<Vector3<f64>> {
    vec![Vector3::new(6.0, 1.0, 2.5), Vector3::new(-3.0, 5.0, 2.0)]
}

fn bound(input: &BoundInput, config: &BoundConfig) -> FlightBound {
    flight_bound(input, config).expect("a bound")
}

#[test]
fn more_information_never_raises_the_bound() {
    let config = BoundConfig::default();
    let one = bound(&input(flight(20.0, 2.0), &one_ap(), 20), &config);
    let two = bound(&input(flight(20.0, 2.0), &two_aps(), 20), &config);
    let denser = bound(&input(flight(20.0, 2.0), &one_ap(), 80), &config);
    let sharper = bound(
        &input(flight(20.0, 2.0), &one_ap(), 20),
        &BoundConfig {
            bearing_sigma_rad: config.bearing_sigma_rad / 4.0,
            ..config
        },
    );
    for b in [&one, &two, &denser, &sharper] {
        assert!(b.ate_rmse_m.is_finite() && b.ate_rmse_m > 0.0, "{b:?}");
    }
    assert!(
        two.ate_rmse_m < one.ate_rmse_m,
        "{} vs {}",
        two.ate_rmse_m,
        one.ate_rmse_m
    );
    assert!(denser.ate_rmse_m < one.ate_rmse_m);
    assert!(sharper.ate_rmse_m < denser.ate_rmse_m);
    // Errors that persist: a denser AP adds next to nothing.
    let persistent = BoundConfig {
        bearing_correlation_s: 2.0,
        ..config
    };
    let slow = bound(&input(flight(20.0, 2.0), &one_ap(), 20), &persistent);
    let fast = bound(&input(flight(20.0, 2.0), &one_ap(), 80), &persistent);
    assert!(slow.ate_rmse_m > one.ate_rmse_m);
    let change = (fast.ate_rmse_m / slow.ate_rmse_m - 1.0).abs();
    assert!(change < 0.05, "{} vs {}", fast.ate_rmse_m, slow.ate_rmse_m);
    // The same AP is placed better with more bearings.
    assert!(denser.ap_sigma_m[0] < one.ap_sigma_m[0]);
    assert_eq!(one.bearings, 401);
    assert_eq!(
        two.bearings, 801,
        "the second AP's last packet is after the end"
    );
}

#[test]
fn without_bearings_the_imu_alone_drifts() {
    let config = BoundConfig::default();
    let mut blind = input(flight(20.0, 2.0), &one_ap(), 20);
    blind.packets = vec![Vec::new()];
    let blind = bound(&blind, &config);
    let seen = bound(&input(flight(20.0, 2.0), &one_ap(), 20), &config);
    let sigma = |b: &FlightBound, s: f64| {
        b.keyframes
            .iter()
            .find(|k| k.t.as_secs_f64() >= s)
            .expect("a keyframe")
            .position_sigma_m
    };
    // At rest the velocity is known: little drifts until the flight starts.
    assert!(sigma(&blind, 1.5) < 0.05, "{}", sigma(&blind, 1.5));
    assert!(sigma(&blind, 10.0) > 2.0 * sigma(&blind, 5.0));
    assert!(sigma(&blind, 20.0) > 4.0 * sigma(&seen, 20.0));
    assert!(
        blind.ap_sigma_m[0] > 50.0,
        "no bearing: only the loose prior"
    );
    assert_eq!(blind.bearings, 0);
}

#[test]
fn the_scored_part_is_what_from_s_says() {
    let all = bound(
        &input(flight(20.0, 2.0), &two_aps(), 20),
        &BoundConfig::default(),
    );
    let late = bound(
        &input(flight(20.0, 2.0), &two_aps(), 20),
        &BoundConfig {
            from_s: 10.0,
            ..BoundConfig::default()
        },
    );
    assert_ne!(all.ate_rmse_m, late.ate_rmse_m);
    assert_eq!(all.keyframes, late.keyframes);
    assert_eq!(all.keyframes.len(), 41);
}

#[test]
fn a_bad_flight_is_an_error_not_a_panic() {
    let config = BoundConfig::default();
    let mut short = input(flight(20.0, 2.0), &one_ap(), 20);
    short.poses.truncate(2);
    assert!(matches!(
        flight_bound(&short, &config),
        Err(BoundError::Input(_))
    ));
    let mut mismatched = input(flight(5.0, 2.0), &one_ap(), 20);
    mismatched.packets.push(Vec::new());
    assert!(matches!(
        flight_bound(&mismatched, &config),
        Err(BoundError::Input(_))
    ));
    let mut ideal = input(flight(5.0, 2.0), &one_ap(), 20);
    ideal.noise.accel_noise_density_m_s2_sqrt_hz = 0.0;
    assert!(matches!(
        flight_bound(&ideal, &config),
        Err(BoundError::Input(_))
    ));
    let mut backwards = input(flight(5.0, 2.0), &one_ap(), 20);
    backwards.poses.swap(3, 4);
    assert!(matches!(
        flight_bound(&backwards, &config),
        Err(BoundError::Input(_))
    ));
}

#[test]
fn the_rotors_vibration_counts_as_noise_while_they_spin() {
    let config = BoundConfig::default();
    let still = input(flight(20.0, 2.0), &one_ap(), 20);
    let end = still.poses[still.poses.len() - 1].t;
    let vibration = ImuVibration {
        from: Timestamp(0),
        to: end,
        accel_density_m_s2_sqrt_hz: 0.02,
        gyro_density_rad_s_sqrt_hz: 1e-3,
    };
    let mut shaken = still.clone();
    shaken.vibration = Some(vibration);
    // The same as a sensor that noisy, the powers added.
    let mut noisier = still.clone();
    let n = &mut noisier.noise;
    n.accel_noise_density_m_s2_sqrt_hz = n.accel_noise_density_m_s2_sqrt_hz.hypot(0.02);
    n.gyro_noise_density_rad_s_sqrt_hz = n.gyro_noise_density_rad_s_sqrt_hz.hypot(1e-3);
    let (b_still, b_shaken) = (bound(&still, &config), bound(&shaken, &config));
    let b_noisier = bound(&noisier, &config);
    assert!(
        b_shaken.ate_rmse_m > 1.5 * b_still.ate_rmse_m,
        "{b_shaken:?} {b_still:?}"
    );
    assert!((b_shaken.ate_rmse_m / b_noisier.ate_rmse_m - 1.0).abs() < 1e-9);
    // Not counted when asked, nor outside the rotors' interval.
    let bench = BoundConfig {
        imu_vibration: false,
        ..config
    };
    assert_eq!(bound(&shaken, &bench).ate_rmse_m, b_still.ate_rmse_m);
    shaken.vibration = Some(ImuVibration {
        from: Timestamp(end.as_nanos() + 1),
        to: Timestamp(end.as_nanos() + 2),
        ..vibration
    });
    assert_eq!(bound(&shaken, &config).ate_rmse_m, b_still.ate_rmse_m);
}

#[test]
fn a_simulated_dataset_gives_its_bound() {
    let mut scenario = crate::sim::Scenario::built_in("paper-circle").expect("built-in");
    scenario.duration_s = 20.0;
    let out = crate::sim::simulate(&scenario, &mut |_| {}).expect("simulated");
    let dir = std::env::temp_dir().join(format!("wins-bound-{}", std::process::id()));
    crate::sim::write_dataset(&dir, &scenario, &out).expect("written");
    let loaded = load_bound_input(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    let loaded = loaded.expect("loaded");
    // Its rotors shake the IMU from the take-off to the landing (`[imu.vibration]`).
    let v = loaded.vibration.expect("the truth records the vibration");
    assert!(v.from > Timestamp(0) && v.to > v.from, "{v:?}");
    assert!(v.accel_density_m_s2_sqrt_hz > loaded.noise.accel_noise_density_m_s2_sqrt_hz);
    let b = bound(&loaded, &BoundConfig::default());
    let received = out.aps.iter().map(|a| a.received().count()).sum::<usize>();
    assert_eq!(b.bearings, received);
    assert!(b.ate_rmse_m > 0.0 && b.ate_rmse_m < 0.3, "{}", b.ate_rmse_m);
    assert!(
        b.ap_sigma_m.iter().all(|s| *s > 0.0 && *s < 1.0),
        "{:?}",
        b.ap_sigma_m
    );
    let mut no_truth = std::env::temp_dir().join(format!("wins-bound-none-{}", std::process::id()));
    no_truth.push("nothing");
    assert!(load_bound_input(&no_truth).is_err());
}
