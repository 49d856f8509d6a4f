use std::f64::consts::TAU;

use super::butterworth::Butterworth2;
use super::*;
use crate::sim::rng;
use crate::sim::run::rotors_interval_s;
use crate::sim::{Scenario, simulate};

/// 200 Hz, as the scenarios' IMU.
const PERIOD_NS: i64 = 5_000_000;
const IMU_HZ: f64 = 200.0;

/// `seconds` of hover samples from the generator (after 1 s of spin-up), as
/// (accelerometer, gyro) per axis.
fn hover_samples(config: &VibrationConfig, seed: u64, seconds: f64) -> [Vec<[f64; 3]>; 2] {
    config.validate("v", PERIOD_NS as f64 * 1e-9).unwrap();
    let mut g = VibrationGenerator::new(config, PERIOD_NS, rng::stream(seed, "test"));
    for _ in 0..IMU_HZ as usize {
        g.next(1.0);
    }
    let n = (seconds * IMU_HZ) as usize;
    let (mut acc, mut gyr) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        let s = g.next(1.0);
        acc.push([s.accel_m_s2.x, s.accel_m_s2.y, s.accel_m_s2.z]);
        gyr.push([s.gyro_rad_s.x, s.gyro_rad_s.y, s.gyro_rad_s.z]);
    }
    [acc, gyr]
}

fn axis_rms(x: &[[f64; 3]]) -> [f64; 3] {
    let n = x.len() as f64;
    [0, 1, 2].map(|j| (x.iter().map(|v| v[j] * v[j]).sum::<f64>() / n).sqrt())
}

/// RMS per axis over the three axes, `√(E|v|²/3)`.
fn rms_over_axes(x: &[[f64; 3]]) -> f64 {
    (axis_rms(x).iter().map(|r| r * r).sum::<f64>() / 3.0).sqrt()
}

/// Welch periodogram (Hann, 1000-sample segments, no overlap: 0.2 Hz bins at 200 Hz) of each
/// axis, summed over the axes; power per bin, bins `k · 0.2` Hz, `k = 0…500`.
fn periodogram(x: &[[f64; 3]]) -> Vec<f64> {
    const L: usize = 1000;
    let window: Vec<f64> = (0..L)
        .map(|n| 0.5 - 0.5 * (TAU * n as f64 / L as f64).cos())
        .collect();
    let (cos, sin): (Vec<f64>, Vec<f64>) = (0..L)
        .map(|n| (TAU * n as f64 / L as f64).sin_cos())
        .map(|(s, c)| (c, s))
        .unzip();
    let mut psd = vec![0.0; L / 2 + 1];
    for segment in x.chunks_exact(L) {
        for j in 0..3 {
            let w: Vec<f64> = segment.iter().zip(&window).map(|(v, h)| v[j] * h).collect();
            for (k, p) in psd.iter_mut().enumerate() {
                let (mut re, mut im) = (0.0, 0.0);
                for (n, wn) in w.iter().enumerate() {
                    let i = (k * n) % L;
                    re += wn * cos[i];
                    im -= wn * sin[i];
                }
                *p += re * re + im * im;
            }
        }
    }
    psd
}

fn bin(f_hz: f64) -> usize {
    (f_hz / 0.2).round() as usize
}

/// Power in the bins within `half_width_hz` of `f_hz`.
fn band(psd: &[f64], f_hz: f64, half_width_hz: f64) -> f64 {
    let lo = bin((f_hz - half_width_hz).max(0.0));
    let hi = bin(f_hz + half_width_hz).min(psd.len() - 1);
    psd[lo..=hi].iter().sum()
}

#[test]
fn hover_rms_is_the_configured_rms_in_the_samples() {
    let broadband_only = VibrationConfig {
        broadband_fraction: 1.0,
        ..VibrationConfig::typical(0.5, 0.02)
    };
    let lines_only = VibrationConfig {
        broadband_fraction: 0.0,
        ..VibrationConfig::typical(0.1, 0.005)
    };
    let equal_axes = VibrationConfig {
        accel_axis_weights: [1.0; 3],
        gyro_axis_weights: [1.0; 3],
        ..VibrationConfig::typical(0.3, 0.01)
    };
    for (seed, config) in [
        VibrationConfig::typical(0.3, 0.01),
        broadband_only,
        lines_only,
        equal_axes,
    ]
    .iter()
    .enumerate()
    {
        let [acc, gyr] = hover_samples(config, seed as u64, 120.0);
        for (x, rms, w) in [
            (&acc, config.accel_rms_m_s2, config.accel_axis_weights),
            (&gyr, config.gyro_rms_rad_s, config.gyro_axis_weights),
        ] {
            let total = rms_over_axes(x);
            assert!(
                (total / rms - 1.0).abs() < 0.03,
                "{config:?}: {total} vs {rms}"
            );
            let mean_square = w.iter().map(|v| v * v).sum::<f64>() / 3.0;
            for (j, r) in axis_rms(x).iter().enumerate() {
                let expected = rms * w[j] / mean_square.sqrt();
                assert!(
                    (r / expected - 1.0).abs() < 0.05,
                    "axis {j}: {r} vs {expected}"
                );
            }
        }
    }
}

#[test]
fn the_spectrum_peaks_where_the_rotor_lines_alias() {
    // A 130 Hz rotor on a 200 Hz IMU: every line lies above the IMU's Nyquist frequency, and
    // 1×, 2×, 3× fold to 70, 60 and 10 Hz. Motors nearly in tune and little broadband, so that
    // even the third harmonic (30 dB under the first after the filter) stands out.
    let config = VibrationConfig {
        rotor_hover_hz: 130.0,
        harmonic_amplitudes: vec![1.0, 1.0, 1.0],
        broadband_fraction: 0.005,
        motor_speed_spread: 0.002,
        ..VibrationConfig::typical(0.3, 0.01)
    };
    let aliases = [1.0, 2.0, 3.0].map(|h| aliased_hz(h * 130.0, IMU_HZ));
    assert_eq!(aliases, [70.0, 60.0, 10.0]);
    let [acc, gyr] = hover_samples(&config, 7, 100.0);
    for x in [&acc, &gyr] {
        let psd = periodogram(x);
        let peak = (1..psd.len())
            .max_by(|a, b| psd[*a].total_cmp(&psd[*b]))
            .unwrap();
        assert!(
            (peak as f64 * 0.2 - 70.0).abs() <= 1.0,
            "highest bin at {} Hz",
            peak as f64 * 0.2
        );
        for f in aliases {
            let line = band(&psd, f, 1.5) / (bin(f + 1.5) - bin(f - 1.5) + 1) as f64;
            let around = (band(&psd, f, 8.0) - band(&psd, f, 3.0)) / 50.0;
            assert!(line > 5.0 * around, "{f} Hz: {line} vs {around} around it");
        }
    }
}

#[test]
fn the_lines_keep_what_the_filter_passes() {
    // Lines alone, at 95 Hz and its harmonics (95, 10 and 85 Hz once sampled): each line's
    // power relative to the first is its amplitude ratio times the filter's gain ratio, squared.
    let config = VibrationConfig {
        broadband_fraction: 0.0,
        harmonic_amplitudes: vec![1.0, 1.0, 1.0],
        motor_speed_spread: 0.002,
        ..VibrationConfig::typical(0.3, 0.01)
    };
    let sensor_hz = config.sensor_steps(1.0 / IMU_HZ) as f64 * IMU_HZ;
    let filter = Butterworth2::new(config.accel_cutoff_hz, sensor_hz);
    let gain = |h: f64| filter.gain_at(h * 95.0, sensor_hz);
    let [acc, _] = hover_samples(&config, 3, 100.0);
    let psd = periodogram(&acc);
    let first = band(&psd, 95.0, 2.0);
    for h in [2.0, 3.0] {
        let measured = band(&psd, aliased_hz(h * 95.0, IMU_HZ), 2.0) / first;
        let predicted = (gain(h) / gain(1.0)).powi(2);
        assert!(
            (measured / predicted - 1.0).abs() < 0.15,
            "{h}×: {measured} vs {predicted}"
        );
    }
    // The second harmonic, at 190 Hz, is 12.6 dB further down than the first.
    assert!((10.0 * (gain(2.0) / gain(1.0)).powi(2).log10() + 12.6).abs() < 0.1);
}

#[test]
fn broadband_noise_above_the_cutoff_is_attenuated_as_the_filter_says() {
    // White noise at the sensor's rate through the filter, then one sample in 8: the power at
    // f is Σ |H(f')|² over the sensor-rate frequencies f' that fold onto f.
    let config = VibrationConfig {
        broadband_fraction: 1.0,
        ..VibrationConfig::typical(0.3, 0.01)
    };
    let sensor_hz = config.sensor_steps(1.0 / IMU_HZ) as f64 * IMU_HZ;
    let filter = Butterworth2::new(config.accel_cutoff_hz, sensor_hz);
    let folded = |f: f64| -> f64 {
        (0..8)
            .flat_map(|m| [m as f64 * IMU_HZ + f, m as f64 * IMU_HZ - f])
            .filter(|x| *x >= 0.0 && *x <= sensor_hz / 2.0)
            .map(|x| filter.gain_at(x, sensor_hz).powi(2))
            .sum()
    };
    let predicted_band =
        |lo: f64, hi: f64| -> f64 { (bin(lo)..=bin(hi)).map(|k| folded(k as f64 * 0.2)).sum() };
    let [acc, _] = hover_samples(&config, 11, 200.0);
    let psd = periodogram(&acc);
    let measured_band = |lo: f64, hi: f64| -> f64 { psd[bin(lo)..=bin(hi)].iter().sum() };
    let reference = measured_band(1.0, 10.0) / predicted_band(1.0, 10.0);
    for (lo, hi) in [(25.0, 35.0), (50.0, 70.0), (80.0, 99.0)] {
        let ratio = measured_band(lo, hi) / predicted_band(lo, hi) / reference;
        assert!((ratio - 1.0).abs() < 0.1, "{lo}–{hi} Hz: {ratio}");
    }
    // What reaches 60 Hz (twice the cutoff) is 12.2 dB down, 90 Hz 17.7 dB.
    assert!((10.0 * folded(60.0).log10() + 12.2).abs() < 0.1);
    assert!((10.0 * folded(90.0).log10() + 17.7).abs() < 0.1);
}

#[test]
fn the_rotor_rate_follows_the_thrust() {
    let g = VibrationGenerator::new(&VibrationConfig::default(), PERIOD_NS, rng::stream(1, "t"));
    assert!((g.sensor_rate_hz() - 1600.0).abs() < 1e-9);
    assert_eq!(g.rotor_hz(1.0), 95.0);
    assert!((g.rotor_hz(1.44) - 114.0).abs() < 1e-9);
    assert_eq!(g.rotor_hz(5.0), 95.0 * MAX_THRUST_PER_WEIGHT.sqrt());
    // Climbing at 0.44 g the lines move up with the rotor: the first from 95 to 114 → 86 Hz.
    let config = VibrationConfig {
        broadband_fraction: 0.0,
        motor_speed_spread: 0.002,
        ..VibrationConfig::default()
    };
    let mut g = VibrationGenerator::new(&config, PERIOD_NS, rng::stream(2, "t"));
    let samples: Vec<[f64; 3]> = (0..20_000)
        .map(|_| g.next(1.44).accel_m_s2)
        .skip(200)
        .map(|a| [a.x, a.y, a.z])
        .collect();
    let psd = periodogram(&samples);
    let peak = (1..psd.len())
        .max_by(|a, b| psd[*a].total_cmp(&psd[*b]))
        .unwrap();
    assert!((peak as f64 * 0.2 - aliased_hz(114.0, IMU_HZ)).abs() <= 1.0);
}

/// The built-in `name` (seed 1) without its vibration ([`Scenario::without_vibration`]), with
/// `imu_keys` added to its `[imu]` table and `tables` appended.
fn scenario_with(name: &str, imu_keys: &str, tables: &str) -> Scenario {
    let text = Scenario::built_in(name)
        .unwrap()
        .without_vibration()
        .to_toml()
        .unwrap()
        .replacen("\n[imu]\n", &format!("\n[imu]\n{imu_keys}"), 1);
    let mut s = Scenario::from_toml(&format!("{text}\n{tables}"), name).unwrap();
    s.seed = 1;
    s
}

#[test]
fn every_built_in_flies_with_rotor_vibration() {
    for (name, _) in crate::sim::scenario::BUILT_IN {
        let s = Scenario::built_in(name).unwrap();
        // A capture on a bench (no take-off) has no rotors spinning.
        if s.phases.is_none() {
            assert_eq!(s.imu.vibration_model(), None, "{name}");
            continue;
        }
        assert_eq!(
            s.imu.vibration_model(),
            Some(VibrationConfig::typical(0.3, 0.01)),
            "{name}"
        );
        assert!(
            s.without_vibration().imu.vibration_model().is_none(),
            "{name}"
        );
    }
}

#[test]
fn no_vibration_leaves_the_flight_bit_for_bit() {
    for name in ["paper-circle", "hover"] {
        let plain = simulate(&scenario_with(name, "", ""), &mut |_| {}).unwrap();
        for (keys, tables) in [
            ("vibration_m_s2 = 0.0\n", ""),
            (
                "",
                "[imu.vibration]\naccel_rms_m_s2 = 0.0\ngyro_rms_rad_s = 0.0\n",
            ),
        ] {
            let s = scenario_with(name, keys, tables);
            assert!(s.imu.vibration_model().is_none());
            let out = simulate(&s, &mut |_| {}).unwrap();
            assert_eq!(out.imu, plain.imu, "{name}: {keys}{tables}");
            assert_eq!(out.imu_biases, plain.imu_biases);
        }
    }
}

#[test]
fn a_simulated_hover_shakes_only_while_the_rotors_spin() {
    let table = "[imu.vibration]\naccel_rms_m_s2 = 0.3\ngyro_rms_rad_s = 0.01\n";
    let shaken = scenario_with("hover", "", table);
    assert_eq!(
        shaken.imu.vibration,
        Some(VibrationConfig::typical(0.3, 0.01))
    );
    let plain = simulate(&scenario_with("hover", "", ""), &mut |_| {}).unwrap();
    let out = simulate(&shaken, &mut |_| {}).unwrap();
    let (on_s, off_s) = rotors_interval_s(&shaken);
    let phases = shaken.phases.clone().unwrap();
    let hover = (on_s + phases.takeoff_s + 1.0, off_s - phases.landing_s);
    let (mut acc, mut gyr) = (Vec::new(), Vec::new());
    for (a, b) in out.imu.iter().zip(&plain.imu) {
        let t_s = a.t.as_secs_f64();
        let (da, dg) = (a.accel_m_s2 - b.accel_m_s2, a.gyro_rad_s - b.gyro_rad_s);
        if t_s < on_s || t_s > off_s {
            assert_eq!(a, b, "vibration at {t_s} s with the rotors off");
        } else {
            assert!(da.norm() > 0.0 && dg.norm() > 0.0, "none at {t_s} s");
        }
        if t_s >= hover.0 && t_s <= hover.1 {
            acc.push([da.x, da.y, da.z]);
            gyr.push([dg.x, dg.y, dg.z]);
        }
    }
    // 16 s of hover.
    assert!(acc.len() >= 3000, "{}", acc.len());
    let (ra, rg) = (rms_over_axes(&acc), rms_over_axes(&gyr));
    assert!((ra / 0.3 - 1.0).abs() < 0.05, "accel {ra}");
    assert!((rg / 0.01 - 1.0).abs() < 0.05, "gyro {rg}");
}

#[test]
fn the_deprecated_key_is_the_typical_model_on_the_accelerometer() {
    let s = scenario_with("hover", "vibration_m_s2 = 0.3\n", "");
    assert_eq!(
        s.imu.vibration_model(),
        Some(VibrationConfig::typical(0.3, 0.0))
    );
    // Neither key is written out when unset.
    let text = scenario_with("hover", "", "").to_toml().unwrap();
    assert!(!text.contains("vibration"), "{text}");
}

fn invalid(imu_keys: &str, table: &str) -> (String, String) {
    let mut s = scenario_with("hover", "", "");
    let text = format!("{}\n{table}", s.to_toml().unwrap());
    let text = text.replacen("[imu]\n", &format!("[imu]\n{imu_keys}"), 1);
    s = toml::from_str(&text).unwrap();
    let e = s.validate().unwrap_err();
    (e.field, e.reason)
}

#[test]
fn invalid_settings_name_their_key() {
    let t = |body: &str| format!("[imu.vibration]\n{body}\n");
    let (field, reason) = invalid("", &t("accel_rms_m_s2 = -0.1"));
    assert_eq!(field, "imu.vibration.accel_rms_m_s2");
    assert!(reason.contains("-0.1 is not in [0, 50]"), "{reason}");
    let (field, reason) = invalid("", &t("gyro_rms_rad_s = nan"));
    assert_eq!(field, "imu.vibration.gyro_rms_rad_s");
    assert!(reason.contains("NaN"), "{reason}");
    // 1600 Hz sensor: the filter's Nyquist frequency is 800 Hz.
    let (field, reason) = invalid("", &t("accel_cutoff_hz = 900.0"));
    assert_eq!(field, "imu.vibration.accel_cutoff_hz");
    assert!(reason.contains("900 Hz is not in (0, 800) Hz"), "{reason}");
    let (field, _) = invalid("", &t("gyro_cutoff_hz = 0.0"));
    assert_eq!(field, "imu.vibration.gyro_cutoff_hz");
    let (field, reason) = invalid("", &t("rotor_hover_hz = 250.0"));
    assert_eq!(field, "imu.vibration.sensor_rate_hz");
    assert!(reason.contains("harmonic 3"), "{reason}");
    let (field, _) = invalid("", &t("harmonic_amplitudes = []"));
    assert_eq!(field, "imu.vibration.harmonic_amplitudes");
    let (field, _) = invalid("", &t("gyro_axis_weights = [0.0, 0.0, 0.0]"));
    assert_eq!(field, "imu.vibration.gyro_axis_weights");
    let (field, _) = invalid("", &t("motor_count = 0"));
    assert_eq!(field, "imu.vibration.motor_count");
    let (field, reason) = invalid("vibration_m_s2 = 0.3\n", &t("accel_rms_m_s2 = 0.3"));
    assert_eq!(field, "imu.vibration_m_s2");
    assert!(reason.contains("deprecated"), "{reason}");
    // Unknown keys are refused by name.
    let text = format!(
        "{}\n{}",
        scenario_with("hover", "", "").to_toml().unwrap(),
        t("accel_rms = 0.3")
    );
    let e = Scenario::from_toml(&text, "hover").unwrap_err().to_string();
    assert!(e.contains("accel_rms"), "{e}");
}

/// The estimator's noise meter, run over a simulated hover's samples, measures the vibration as
/// a white density near its RMS × √(sample period): what it is meant to see.
#[test]
fn the_noise_meter_measures_the_simulated_vibration() {
    use crate::imu::NoiseMeter;
    let shaken = scenario_with(
        "hover",
        "",
        "[imu.vibration]\naccel_rms_m_s2 = 0.5\ngyro_rms_rad_s = 0.02\n",
    );
    let out = simulate(&shaken, &mut |_| {}).unwrap();
    let (on_s, off_s) = rotors_interval_s(&shaken);
    let phases = shaken.phases.clone().unwrap();
    let mut meter = NoiseMeter::new(5.0);
    for s in out.imu.iter().filter(|s| {
        let t = s.t.as_secs_f64();
        t > on_s + phases.takeoff_s + 1.0 && t < off_s - phases.landing_s
    }) {
        meter.push(s);
    }
    let (a, g) = meter.densities().unwrap();
    let white = |rms: f64| rms * (PERIOD_NS as f64 * 1e-9).sqrt();
    // The scatter about a line over 0.1 s misses what lies under ~10 Hz (part of the broadband
    // and the 10 Hz alias): between 70 % and 110 % of the RMS.
    for (got, rms) in [(a, 0.5), (g, 0.02)] {
        let r = got / white(rms);
        assert!((0.7..1.1).contains(&r), "{got} against {}: {r}", white(rms));
    }
}

/// Var of the means over `block` samples, times the block's length: the density² near 0 Hz.
fn low_frequency_density(x: &[[f64; 3]], block: usize) -> [f64; 3] {
    let means: Vec<[f64; 3]> = x
        .chunks_exact(block)
        .map(|c| [0, 1, 2].map(|j| c.iter().map(|v| v[j]).sum::<f64>() / block as f64))
        .collect();
    let n = means.len() as f64;
    let block_s = block as f64 / IMU_HZ;
    [0, 1, 2].map(|j| {
        let mean = means.iter().map(|m| m[j]).sum::<f64>() / n;
        let var = means.iter().map(|m| (m[j] - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (var * block_s).sqrt()
    })
}

#[test]
fn the_broadband_density_is_what_an_integration_sees_of_the_vibration() {
    // Over 0.5 s means (the lines, at 95 Hz and its aliases, average out), the vibration's
    // density is the broadband's at 0 Hz: 0.020 m/s²/√Hz for the default model at 0.3 m/s².
    let config = VibrationConfig::typical(0.6, 0.02);
    let density = broadband_density(&config, PERIOD_NS as f64 * 1e-9);
    let [acc, gyr] = hover_samples(&config, 7, 600.0);
    let measured = [
        low_frequency_density(&acc, 100),
        low_frequency_density(&gyr, 100),
    ];
    for (k, m) in measured.iter().enumerate() {
        for j in 0..3 {
            let expected = density[3 * k + j];
            assert!(
                (m[j] / expected - 1.0).abs() < 0.2,
                "channel {}: {} measured against {expected}",
                3 * k + j,
                m[j]
            );
        }
    }
    // Over the three axes (the z axis shakes 1.5 times the others).
    let default = broadband_density(&VibrationConfig::default(), 0.005);
    let over_axes = (default[..3].iter().map(|d| d * d).sum::<f64>() / 3.0).sqrt();
    assert!((over_axes - 0.020).abs() < 0.001, "{over_axes}");
}
