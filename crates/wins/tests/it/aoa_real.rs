//! Per-packet AoA on real Intel 5300 captures: on a static capture the estimated direct path's
//! phase step between antennas 0 and 1 must be as stable as the raw CSI's (its IQR over packets
//! at most the raw one's plus 3°), whatever the captures' chain offsets and however wide the
//! array. The lgtm captures (`../shared/data/intel5300/lgtm`, 0.1 m spacing at 5.32 GHz: wider
//! than λ/2) are used as they are, without a calibration; every `.dat` in that folder is checked,
//! so captures added there are checked too. The settings are `configs/intel5300-real.toml`'s (the
//! test checks that the file says so).

use std::f64::consts::{PI, TAU};
use std::path::Path;

use num_complex::Complex64;
use wins::aoa::{AoaConfig, AoaEstimator, raw_csi};
use wins::csi::intel5300::{CsiRecord, read_log};
use wins::pipeline::aoa_log::{AoaMode, estimate_log, match_chain_curvature};
use wins::rig::ArrayGeometry;
use wins::rig::array::{CHANNEL_64_HZ, SPEED_OF_LIGHT_M_S};

use super::data::shared_data;

/// The lgtm rig's antenna spacing, m.
const LGTM_SPACING_M: f64 = 0.1;
/// `[aoa.music.paths] max_below_largest_db` of `configs/intel5300-real.toml`, dB.
const REAL_DYNAMIC_RANGE_DB: f64 = 20.0;
/// How much less stable than the raw CSI the estimate may be, degrees.
const MARGIN_DEG: f64 = 3.0;

/// Interquartile range of angles about their circular mean, degrees.
fn circular_iqr_deg(angles: &[f64]) -> f64 {
    let mean = angles
        .iter()
        .map(|a| Complex64::from_polar(1.0, *a))
        .sum::<Complex64>()
        .arg();
    let mut d: Vec<f64> = angles
        .iter()
        .map(|a| (a - mean + PI).rem_euclid(TAU) - PI)
        .collect();
    d.sort_by(f64::total_cmp);
    let q = |p: f64| d[((d.len() - 1) as f64 * p).round() as usize];
    (q(0.75) - q(0.25)).to_degrees()
}

/// Raw and estimated spreads of one capture, degrees, and the packets with an angle.
fn spreads(records: &[CsiRecord]) -> (f64, f64, usize) {
    let geometry = ArrayGeometry {
        num_antennas: 3,
        spacing_m: LGTM_SPACING_M,
    };
    let raw: Vec<f64> = records
        .iter()
        .filter_map(|r| raw_csi(r, 0, 3).ok())
        .map(|csi| {
            (0..30)
                .map(|k| csi[30 + k] * csi[k].conj())
                .sum::<Complex64>()
                .arg()
        })
        .collect();
    let mut config = AoaConfig::default();
    config.music.paths.max_below_largest_db = REAL_DYNAMIC_RANGE_DB;
    let mut estimator = AoaEstimator::new(&config, geometry, CHANNEL_64_HZ, None).unwrap();
    assert!(estimator.ambiguity().is_some(), "a 0.1 m array aliases");
    match_chain_curvature(records, &mut estimator, false).unwrap();
    let (rows, _) = estimate_log(records, &estimator, AoaMode::Music).unwrap();
    let kappa = TAU * LGTM_SPACING_M * CHANNEL_64_HZ / SPEED_OF_LIGHT_M_S;
    let estimated: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.aoa_deg)
        .map(|deg| kappa * deg.to_radians().sin())
        .collect();
    (
        circular_iqr_deg(&raw),
        circular_iqr_deg(&estimated),
        estimated.len(),
    )
}

#[test]
fn per_packet_phase_is_as_stable_as_the_raw_csi_on_static_captures() {
    let preset = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/intel5300-real.toml"),
    )
    .unwrap();
    assert!(
        preset.contains(&format!(
            "max_below_largest_db = {REAL_DYNAMIC_RANGE_DB:.1}"
        )),
        "{preset}"
    );
    let Some(shared) = shared_data() else { return };
    let dir = shared.join("intel5300/lgtm");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "dat"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 8,
        "{} captures in {}",
        files.len(),
        dir.display()
    );
    let mut failures = Vec::new();
    for file in &files {
        let records: Vec<CsiRecord> = read_log(file)
            .unwrap()
            .records
            .into_iter()
            .filter(|r| r.header.nrx == 3)
            .collect();
        let (raw, estimated, with_angle) = spreads(&records);
        let name = file.file_name().map(Path::new).unwrap().display();
        println!("{name}: raw {raw:.1}°, estimated {estimated:.1}° over {with_angle} packets");
        assert!(
            with_angle * 10 >= records.len() * 9,
            "{name}: {with_angle} angles"
        );
        if estimated > raw + MARGIN_DEG {
            failures.push(format!(
                "{name}: {estimated:.1}° > {raw:.1}° + {MARGIN_DEG}°"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
