//! Tests of `csi`.

use super::cards::{identity_antenna_sel, quantize};
use super::*;
use crate::csi::Bandwidth;
use crate::rig::array::CHANNEL_64_HZ;
use crate::sim::rng;
use std::f64::consts::TAU;

fn wrap(x: f64) -> f64 {
    (x + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI
}

fn single_path(theta_deg: f64, length_m: f64) -> Path {
    let t = theta_deg.to_radians();
    Path {
        length_m,
        toward_source_in_w: Vector3::new(t.cos(), t.sin(), 0.0),
        gain: 1.0,
        order: 0,
        obstructed: false,
    }
}

#[test]
fn single_path_phases_follow_the_steering_vector_and_the_time_of_flight() {
    for bandwidth in [Bandwidth::Ht20, Bandwidth::Ht40] {
        let radio = RadioConfig {
            bandwidth,
            ..RadioConfig::default()
        };
        let g = ArrayGeometry::default();
        let synth = CsiSynth::new(&radio, g, &[0.0; 3], 15.0);
        let offsets = bandwidth.subcarrier_offsets_hz();
        for (theta_deg, length_m) in [(0.0, 3.0), (25.0, 5.0), (-60.0, 7.3), (80.0, 2.0)] {
            let h = synth.channel(
                &[single_path(theta_deg, length_m)],
                &UnitQuaternion::identity(),
            );
            let sin_t = f64::sin(f64::to_radians(theta_deg));
            let tau = length_m / SPEED_OF_LIGHT_M_S;
            let expected_amp = db_to_power(19.0).sqrt() * radio.free_space_amplitude(length_m);
            for k in 0..NUM_SUBCARRIERS {
                let f = CHANNEL_64_HZ + offsets[k];
                for m in 1..3 {
                    // Inter-antenna phase 2π·d·sin θ/λ at this subcarrier's frequency.
                    let d = (h[m][k] * h[m - 1][k].conj()).arg();
                    let want = TAU * g.spacing_m * sin_t * f / SPEED_OF_LIGHT_M_S;
                    assert!((d - want).abs() < 1e-9, "{theta_deg}: {d} vs {want}");
                }
                // Subcarrier phase slope is the ToF: φ_k − φ_0 = −2π(Δf_k − Δf_0)τ.
                let d = (h[1][k] * h[1][0].conj()).arg();
                let want = wrap(-TAU * (offsets[k] - offsets[0]) * tau);
                assert!(wrap(d - want).abs() < 1e-6, "{d} vs {want}");
                assert!((h[1][k].norm() - expected_amp).abs() < 1e-12 * expected_amp.max(1.0));
            }
        }
    }
}

#[test]
fn reflections_below_the_noise_floor_are_skipped_and_the_direct_path_never() {
    let radio = RadioConfig::default();
    let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &[0.0; 3], 15.0);
    let direct = single_path(10.0, 5.0);
    let unit_power_mw = {
        let h = synth.channel(std::slice::from_ref(&direct), &UnitQuaternion::identity());
        h[0][0].norm_sqr()
    };
    let floor_mw = db_to_power(radio.noise_floor_dbm());
    // A reflection with power 10 dB below the limit, and one 10 dB above it.
    let with_gain = |power_mw: f64| Path {
        gain: (power_mw / unit_power_mw).sqrt(),
        ..single_path(-40.0, 5.0)
    };
    let weak = with_gain(0.1 * NEGLIGIBLE_PATH_POWER_RATIO * floor_mw);
    let strong = with_gain(10.0 * NEGLIGIBLE_PATH_POWER_RATIO * floor_mw);
    let q = UnitQuaternion::identity();
    let alone = synth.channel(std::slice::from_ref(&direct), &q);
    assert_eq!(synth.channel(&[direct, weak], &q), alone);
    assert_ne!(synth.channel(&[direct, strong], &q), alone);
    // A direct path as weak as the skipped reflection is still synthesized.
    let faint = synth.channel(std::slice::from_ref(&weak), &q);
    assert!(faint[0][0].norm_sqr() > 0.0);
}

#[test]
fn packet_carries_exactly_the_impairments_its_truth_reports() {
    let radio = RadioConfig::default();
    let offsets_rad = [0.3, -2.0, 1.1];
    let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &offsets_rad, 15.0);
    let paths = [single_path(20.0, 4.0), {
        let mut p = single_path(-50.0, 9.0);
        p.gain = 0.3;
        p.order = 1;
        p
    }];
    let q = UnitQuaternion::identity();
    let h = synth.channel(&paths, &q);
    let ap = Vector3::new(
        4.0 * 20f64.to_radians().cos(),
        4.0 * 20f64.to_radians().sin(),
        0.0,
    );
    let mut r = rng::stream(5, "test");
    let freq = radio.bandwidth.subcarrier_offsets_hz();
    for n in 0..50 {
        let (rec, truth) = synth.packet(
            &paths,
            &Vector3::zeros(),
            &ap,
            &q,
            Timestamp(n * 20_000_000),
            n as u16,
            &mut r,
        );
        let Logged::Intel5300(rec) = rec else {
            panic!("the default rig is an Intel 5300")
        };
        assert!((truth.aoa_rad.to_degrees() - 20.0).abs() < 1e-9);
        assert!((truth.range_m - 4.0).abs() < 1e-12 && truth.in_front);
        assert_eq!(rec.header.nrx, 3);
        assert_eq!(rec.header.bfee_count, n as u16);
        // Undo the reported impairments: what is left is a real positive gain plus noise.
        let mut residual_phase = Vec::new();
        for m in 0..3 {
            for k in 0..NUM_SUBCARRIERS {
                let c = rec.csi_at(0, m, k).unwrap();
                let c = Complex64::new(f64::from(c.re), f64::from(c.im));
                let applied = truth.common_phase_rad + offsets_rad[m] - TAU * freq[k] * truth.sto_s;
                let z = c * (h[m][k] * Complex64::from_polar(1.0, applied)).conj();
                residual_phase.push(z.arg());
            }
        }
        let rms = (residual_phase.iter().map(|p| p * p).sum::<f64>() / 90.0).sqrt();
        // 30 dB implementation SNR and 8-bit quantization: a few degrees of phase noise.
        assert!(rms < 0.15, "packet {n}: residual phase rms {rms}");
        // The RSSI fields give back the received power (get_total_rss.m), within rounding.
        let p_true: f64 = (0..3).map(|m| mean_power(&h[m])).sum();
        assert!(
            (rec.total_rss_dbm() - power_to_db(p_true)).abs() < 1.0,
            "{}",
            rec.total_rss_dbm()
        );
        assert!((truth.snr_db - 29.99).abs() < 0.1, "{}", truth.snr_db);
    }
}

#[test]
fn snr_falls_with_distance_once_thermal_noise_matters() {
    let radio = RadioConfig::default();
    let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &[0.0; 3], -10.0);
    let q = UnitQuaternion::identity();
    let mut r = rng::stream(6, "test");
    let snr = |l: f64, r: &mut ChaCha8Rng| {
        let ap = Vector3::new(l, 0.0, 0.0);
        synth
            .packet(
                &[single_path(0.0, l)],
                &Vector3::zeros(),
                &ap,
                &q,
                Timestamp(0),
                0,
                r,
            )
            .1
            .snr_db
    };
    let (near, far) = (snr(2.0, &mut r), snr(8.0, &mut r));
    // −10 dBm + 4 dBi: −59 dBm at 2 m (thermal SNR 35 dB, 28.8 dB after the 30 dB cap);
    // −71 dBm at 8 m (thermal SNR 23 dB, 22.2 dB).
    assert!(
        (near - 28.8).abs() < 0.5 && (far - 22.2).abs() < 0.5,
        "{near} {far}"
    );
}

#[test]
fn antenna_sel_is_the_identity() {
    assert_eq!(identity_antenna_sel(3), 0b10_01_00);
    assert_eq!(identity_antenna_sel(2), 0b01_00);
    assert_eq!(quantize(200.0), (127, true));
    assert_eq!(quantize(-128.4), (-128, false));
    assert_eq!(quantize(-3.5), (-4, false));
}
