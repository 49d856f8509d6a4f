//! Tests of `spotfi`.

use super::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Group = Vec<Vec<Peak>>;

fn pk(aoa_deg: f64, tof_ns: f64, residual: f64) -> Peak {
    let (aoa_rad, tof_s) = (aoa_deg.to_radians(), tof_ns * 1e-9);
    Peak {
        aoa_rad,
        tof_s,
        residual,
    }
}

fn config_with(edit: impl FnOnce(&mut SpotfiConfig)) -> SpotfiConfig {
    let mut config = SpotfiConfig::default();
    edit(&mut config);
    config
}

/// 10 packets: direct near (10°, −5 ns), a tighter, stronger reflection near (−30°, 40 ns) in
/// every packet, and 0–3 spurious peaks per packet away from both paths.
fn multipath_group(rng: &mut ChaCha8Rng) -> Group {
    let mut group = Group::new();
    for _ in 0..10 {
        let mut jit = |c: f64, h: f64| c + rng.random_range(-h..h);
        let reflection = pk(jit(-30.0, 0.3), jit(40.0, 1.0), 0.01);
        let mut peaks = vec![reflection, pk(jit(10.0, 1.0), jit(-5.0, 2.0), 0.2)];
        for _ in 0..rng.random_range(0..4) {
            let (a, t) = (
                rng.random_range(-80.0..80.0),
                rng.random_range(-20.0..200.0),
            );
            let near = |a0: f64, t0: f64| (a - a0).abs() < 15.0 && (t - t0).abs() < 30.0;
            if !near(10.0, -5.0) && !near(-30.0, 40.0) {
                peaks.push(pk(a, t, 0.3 + 0.7 * rng.random::<f64>()));
            }
        }
        group.push(peaks);
    }
    group
}

#[test]
fn picks_direct_cluster_over_stronger_reflection() {
    for seed in 0..16 {
        let group = multipath_group(&mut ChaCha8Rng::seed_from_u64(seed));
        let dp = direct_path(&group, &SpotfiConfig::default()).expect("direct path");
        let (aoa_deg, tof_ns) = (dp.aoa_rad.to_degrees(), dp.tof_s * 1e9);
        assert!((aoa_deg - 10.0).abs() < 1.0, "seed {seed}: {aoa_deg}°");
        assert!((tof_ns + 5.0).abs() < 2.0, "seed {seed}: {tof_ns} ns");
        assert_eq!(dp.packets, 10);
        assert_eq!(dp.clusters[0].log_likelihood, dp.log_likelihood);
        assert!(dp.per_packet.iter().all(Option::is_some));
        let is_refl = |c: &&Cluster| (c.aoa_rad.to_degrees() + 30.0).abs() < 1.0;
        let refl = dp
            .clusters
            .iter()
            .find(is_refl)
            .expect("reflection cluster");
        assert!(refl.packets == 10 && refl.log_likelihood < dp.log_likelihood);
        // Without the ToF term the tighter reflection would win: the test can fail.
        let no_tof = direct_path(&group, &config_with(|c| c.w_tof = 0.0)).expect("no_tof");
        assert!(
            (no_tof.aoa_rad.to_degrees() + 30.0).abs() < 1.0,
            "seed {seed}"
        );
    }
}

#[test]
fn rare_earliest_cluster_is_not_chosen() {
    let mut group: Group = (0..10)
        .map(|i| vec![pk(10.0 + 0.1 * f64::from(i), 20.0, 0.1)])
        .collect();
    group[3].push(pk(40.0, -30.0, 0.01));
    for fraction in [0.3, 0.0] {
        let config = config_with(|c| c.min_cluster_fraction = fraction);
        let dp = direct_path(&group, &config).expect("direct path");
        assert!((dp.aoa_rad.to_degrees() - 10.45).abs() < 1e-9 && dp.packets == 10);
        let lonely = dp.clusters.iter().find(|c| c.packets == 1).expect("lonely");
        assert_eq!(lonely.eligible, fraction == 0.0);
        assert!((lonely.tof_s + 30e-9).abs() < 1e-15);
    }
}

#[test]
fn per_packet_entries_come_from_their_packet() {
    // Packet i's direct peak has ToF i ns; packets 2 and 5 miss it; packet 7 has two members
    // (the lower-ToF one is kept). The 70° peaks are a later reflection cluster.
    let direct = |i: u32| pk(10.0 + 0.2 * f64::from(i), f64::from(i), 0.1);
    let refl = pk(70.0, 150.0, 0.1);
    let group: Group = (0..8)
        .map(|i| match i {
            2 | 5 => vec![refl],
            7 => vec![pk(12.0, 7.5, 0.1), pk(11.0, 7.0, 0.3), refl],
            _ => vec![refl, direct(i)],
        })
        .collect();
    let dp = direct_path(&group, &SpotfiConfig::default()).expect("direct path");
    assert_eq!((dp.per_packet.len(), dp.packets), (8, 6));
    for (i, entry) in (0..).zip(&dp.per_packet) {
        let expected = match i {
            2 | 5 => None,
            7 => Some(pk(11.0, 7.0, 0.3)),
            _ => Some(direct(i)),
        };
        assert_eq!(*entry, expected, "packet {i}");
    }
}

#[test]
fn rejects_bad_input_and_config() {
    let cfg = SpotfiConfig::default();
    assert_eq!(direct_path(&[], &cfg), Err(SpotfiError::EmptyGroup));
    let err = SpotfiError::NoPeaks { packets: 2 };
    assert_eq!(direct_path(&[vec![], vec![]], &cfg), Err(err));
    let good = vec![vec![pk(0.0, 0.0, 0.1)]; 3];
    let nan = f64::NAN;
    for bad in [
        pk(nan, 0.0, 0.1),
        pk(0.0, f64::INFINITY, 0.1),
        pk(0.0, 0.0, nan),
    ] {
        let mut group = good.clone();
        group[2].push(bad);
        let err = SpotfiError::NonFinitePeak { packet: 2, peak: 1 };
        assert_eq!(direct_path(&group, &cfg), Err(err));
    }
    let name_of = |config: SpotfiConfig| match direct_path(&good, &config) {
        Err(SpotfiError::InvalidConfig(p)) if p.0.len() == 1 => p.0[0].key.clone(),
        other => panic!("expected one InvalidConfig problem, got {other:?}"),
    };
    for bad in [0.0, -1e-9, nan] {
        let tof_tol = config_with(|c| c.tof_tolerance_s = bad);
        assert_eq!(name_of(tof_tol), "tof_tolerance_s");
        let aoa_tol = config_with(|c| c.aoa_tolerance_rad = bad);
        assert_eq!(name_of(aoa_tol), "aoa_tolerance_rad");
    }
    let fraction = config_with(|c| c.min_cluster_fraction = 1.5);
    assert_eq!(name_of(fraction), "min_cluster_fraction");
    // Each packet sees a different path: no cluster reaches 30 % of 4 packets.
    let scattered: Group = (0..4)
        .map(|i| vec![pk(-60.0 + 40.0 * f64::from(i), 0.0, 0.1)])
        .collect();
    let err = SpotfiError::NoEligibleCluster {
        best: 1,
        packets: 4,
    };
    assert_eq!(direct_path(&scattered, &cfg), Err(err));
}

#[test]
fn config_defaults_and_unknown_fields() {
    let parsed: SpotfiConfig = toml::from_str("w_tof = 2.0").expect("parse");
    assert_eq!(parsed, config_with(|c| c.w_tof = 2.0));
    assert!(toml::from_str::<SpotfiConfig>("w_typo = 2.0").is_err());
}
