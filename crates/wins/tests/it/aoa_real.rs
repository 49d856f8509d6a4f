//! Per-packet AoA on real Intel 5300 captures, with the shipped settings: the estimated direct
//! path's phase step between antennas 0 and 1 must be as stable over a capture as the raw CSI's
//! (its IQR over packets at most the raw one's plus 3°), whatever the captures' chain offsets and
//! however wide the array. Every `.dat` under `../shared/data/intel5300` is checked, so captures
//! added there are checked too; a capture `wins csi check` calls unusable for AoA (a dead antenna,
//! chains stepping by 90° from packet to packet) must be called so by it instead:
//! - the lgtm captures (`lgtm/`, static, 0.1 m spacing at 5.32 GHz: wider than λ/2, so every
//!   angle has aliases) as they are, without a calibration;
//! - the others, whose rigs are not documented, as a half-wavelength array on their channel (or
//!   channel 64): there every phase step is one angle, so the phase step the estimate implies is
//!   the one it chose.

use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use num_complex::Complex64;
use wins::aoa::capture_check::{CheckOptions, Verdict, check_capture};
use wins::aoa::{AoaConfig, AoaEstimator, raw_csi};
use wins::csi::intel5300::{CsiRecord, read_log};
use wins::pipeline::aoa_log::{AoaMode, estimate_log, match_chain_curvature};
use wins::rig::ArrayGeometry;
use wins::rig::array::{CHANNEL_64_HZ, SPEED_OF_LIGHT_M_S};

use super::data::shared_data;

/// The lgtm rig's antenna spacing, m.
const LGTM_SPACING_M: f64 = 0.1;
/// How much less stable than the raw CSI the estimate may be, degrees.
const MARGIN_DEG: f64 = 3.0;
/// Fewest 3-antenna packets a capture needs for its spread to mean something.
const MIN_PACKETS: usize = 20;

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

/// Raw and estimated spreads of one capture with the shipped settings, degrees, and the packets
/// with an angle: the steps `wins aoa` takes (the chains' curvature matched, then MUSIC per
/// packet).
fn spreads(records: &[CsiRecord], spacing_m: f64) -> (f64, f64, usize) {
    let geometry = ArrayGeometry {
        num_antennas: 3,
        spacing_m,
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
    let config = AoaConfig::default();
    let mut estimator = AoaEstimator::new(&config, geometry, CHANNEL_64_HZ, None).unwrap();
    match_chain_curvature(records, &mut estimator, false).unwrap();
    let (rows, _) = estimate_log(records, &estimator, AoaMode::Music).unwrap();
    let kappa = TAU * spacing_m * CHANNEL_64_HZ / SPEED_OF_LIGHT_M_S;
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

/// Every `.dat` under `dir`, recursively, sorted.
fn captures(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(captures(&path));
        } else if path.extension().is_some_and(|e| e == "dat") {
            files.push(path);
        }
    }
    files.sort();
    files
}

#[test]
fn per_packet_phase_is_as_stable_as_the_raw_csi_on_real_captures() {
    let Some(shared) = shared_data() else { return };
    let files = captures(&shared.join("intel5300"));
    let lgtm = files
        .iter()
        .filter(|f| f.parent().is_some_and(|p| p.ends_with("lgtm")))
        .count();
    assert!(lgtm >= 8, "{lgtm} lgtm captures of {}", files.len());
    let half_wavelength_m = SPEED_OF_LIGHT_M_S / CHANNEL_64_HZ / 2.0;
    let mut failures = Vec::new();
    let mut checked = 0;
    let mut unusable = 0;
    for file in &files {
        let records: Vec<CsiRecord> = read_log(file)
            .unwrap()
            .records
            .into_iter()
            .filter(|r| r.header.nrx == 3)
            .collect();
        let name = file.file_name().map(Path::new).unwrap().display();
        if records.len() < MIN_PACKETS {
            println!("{name}: {} 3-antenna packets, not checked", records.len());
            continue;
        }
        let spacing_m = if file.parent().is_some_and(|p| p.ends_with("lgtm")) {
            LGTM_SPACING_M
        } else {
            half_wavelength_m
        };
        let (raw, estimated, with_angle) = spreads(&records, spacing_m);
        let verdict = check_capture(file, &CheckOptions::default())
            .unwrap()
            .verdict();
        println!(
            "{name}: raw {raw:.1}°, estimated {estimated:.1}° over {with_angle} packets; \
             check: {verdict}"
        );
        checked += 1;
        if verdict == Verdict::Bad {
            unusable += 1;
            continue;
        }
        assert!(
            with_angle * 10 >= records.len() * 9,
            "{name}: {with_angle} angles of {} packets",
            records.len()
        );
        if estimated > raw + MARGIN_DEG {
            failures.push(format!(
                "{name}: {estimated:.1}° > {raw:.1}° + {MARGIN_DEG}°"
            ));
        }
    }
    assert!(
        checked - unusable >= 8,
        "{unusable} of {checked} captures unusable"
    );
    assert!(failures.is_empty(), "{failures:#?}");
}
