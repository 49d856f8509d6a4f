use nalgebra::Vector3;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::*;
use crate::time::Timestamp;

const PERIOD_NS: i64 = 5_000_000;

fn datasheet(accel: f64, gyro: f64) -> ImuNoise {
    ImuNoise {
        gyro_noise_density_rad_s_sqrt_hz: gyro,
        gyro_bias_random_walk_rad_s2_sqrt_hz: 1e-5,
        gyro_turn_on_bias_rad_s: 1e-3,
        accel_noise_density_m_s2_sqrt_hz: accel,
        accel_bias_random_walk_m_s3_sqrt_hz: 1e-4,
        accel_turn_on_bias_m_s2: 0.05,
    }
}

/// `seconds` of a manoeuvring flight's samples (accelerations of 2 m/s² and rates of 1 rad/s
/// at 0.5 Hz) with white noise of densities `(accel, gyro)` at 200 Hz.
fn flight(accel: f64, gyro: f64, seconds: f64, seed: u64) -> Vec<ImuSample> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let dt = PERIOD_NS as f64 * 1e-9;
    let na = Normal::new(0.0, accel / dt.sqrt()).unwrap();
    let ng = Normal::new(0.0, gyro / dt.sqrt()).unwrap();
    (0..(seconds / dt) as i64)
        .map(|k| {
            let t = k as f64 * dt;
            let w = std::f64::consts::TAU * 0.5 * t;
            ImuSample {
                t: Timestamp(k * PERIOD_NS),
                accel_m_s2: Vector3::new(2.0 * w.sin(), 2.0 * w.cos(), 9.8 + w.sin())
                    + Vector3::from_fn(|_, _| na.sample(&mut rng)),
                gyro_rad_s: Vector3::new(w.cos(), 0.3 * w.sin(), w.sin())
                    + Vector3::from_fn(|_, _| ng.sample(&mut rng)),
            }
        })
        .collect()
}

#[test]
fn white_noise_under_motion_is_measured_at_its_density() {
    for (accel, gyro) in [(0.002, 1e-4), (0.02, 0.001)] {
        let mut m = NoiseMeter::new(1.0);
        for s in flight(accel, gyro, 20.0, 7) {
            m.push(&s);
        }
        let (a, g) = m.densities().unwrap();
        assert!((a / accel - 1.0).abs() < 0.1, "accel {a} against {accel}");
        assert!((g / gyro - 1.0).abs() < 0.1, "gyro {g} against {gyro}");
        assert!(m.blocks() >= 195, "{} blocks", m.blocks());
    }
}

#[test]
fn the_datasheet_is_a_floor_and_more_noise_raises_it() {
    let mut m = NoiseMeter::new(1.0);
    let floor = datasheet(0.002, 1e-4);
    assert_eq!(m.effective(&floor), floor, "nothing measured yet");
    // Quieter than the datasheet: the datasheet stays.
    for s in flight(0.0005, 2e-5, 5.0, 1) {
        m.push(&s);
    }
    assert_eq!(m.effective(&floor), floor);
    // Ten times noisier: raised to what the samples show, the rest unchanged.
    let mut m = NoiseMeter::new(1.0);
    for s in flight(0.02, 0.001, 5.0, 2) {
        m.push(&s);
    }
    let e = m.effective(&floor);
    assert!((e.accel_noise_density_m_s2_sqrt_hz / 0.02 - 1.0).abs() < 0.15);
    assert!((e.gyro_noise_density_rad_s_sqrt_hz / 0.001 - 1.0).abs() < 0.15);
    assert_eq!(
        e.accel_bias_random_walk_m_s3_sqrt_hz,
        floor.accel_bias_random_walk_m_s3_sqrt_hz
    );
    assert_eq!(e.gyro_turn_on_bias_rad_s, floor.gyro_turn_on_bias_rad_s);
}

#[test]
fn the_estimate_follows_a_change_within_its_time_constant() {
    let mut m = NoiseMeter::new(1.0);
    let quiet = flight(0.002, 1e-4, 10.0, 3);
    let loud: Vec<ImuSample> = flight(0.02, 1e-3, 3.0, 4)
        .into_iter()
        .map(|s| ImuSample {
            t: Timestamp(s.t.0 + 10_000_000_000),
            ..s
        })
        .collect();
    for s in &quiet {
        m.push(s);
    }
    let before = m.densities().unwrap().0;
    assert!(before < 0.0025, "{before}");
    for s in &loud {
        m.push(s);
    }
    // After three time constants, within 5 % of the new level (e^-3 of the old gap).
    let after = m.densities().unwrap().0;
    assert!((after / 0.02 - 1.0).abs() < 0.15, "{after}");
}

#[test]
fn a_gap_or_a_sample_out_of_order_starts_a_new_block() {
    let mut m = NoiseMeter::new(1.0);
    let s = flight(0.002, 1e-4, 1.0, 5);
    // Ten samples, a 0.2 s gap, ten more: no block spans 0.1 s of samples.
    for x in s.iter().take(10) {
        assert!(!m.push(x));
    }
    for x in s.iter().skip(50).take(10) {
        assert!(!m.push(x));
    }
    // A jump back in time starts again too, and a step of 10 m/s² across it is never scatter.
    let mut stepped = s[0];
    stepped.accel_m_s2.x += 10.0;
    assert!(!m.push(&stepped));
    assert_eq!(m.blocks(), 0);
    assert!(m.densities().is_none());
}

#[test]
fn a_parabola_through_the_samples_leaves_no_scatter() {
    let t: Vec<f64> = (0..20).map(|k| 3.0 + k as f64 * 0.005).collect();
    let x: Vec<f64> = t.iter().map(|t| 3.0 - 40.0 * t + 7.0 * t * t).collect();
    let s = scatter(&parabola_basis(&t), x);
    assert!(s < 1e-18, "{s}");
    // Alternating ±1: almost all of it is scatter (n − 3 degrees of freedom).
    let x: Vec<f64> = (0..20)
        .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let s = scatter(&parabola_basis(&t), x);
    assert!((s - 20.0 / 17.0).abs() < 0.02, "{s}");
}
