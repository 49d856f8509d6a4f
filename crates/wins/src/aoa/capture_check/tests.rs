use std::f64::consts::{FRAC_PI_2, PI, TAU};

use super::measure::spread;
use crate::csi::intel5300::{Identified, identify_bytes};

/// `n` angles about `mean` with a deterministic scatter of ±`half_width`.
fn around(mean: f64, half_width: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| mean + half_width * ((i as f64 * 0.618).fract() * 2.0 - 1.0))
        .collect()
}

#[test]
fn a_steady_phase_has_its_mean_and_a_small_spread_across_the_wrap() {
    let s = spread(&around(PI - 0.01, 0.02, 500)).expect("spread");
    assert!((s.mean_rad.abs() - PI).abs() < 0.02, "{s:?}");
    assert!(s.iqr_rad < 0.03, "{s:?}");
    assert_eq!(s.stepped, 0.0);
    assert_eq!(s.first_step, None);
}

#[test]
fn steps_of_a_quarter_and_a_half_turn_are_told_apart() {
    let mut quarter = around(0.5, 0.02, 300);
    quarter.extend(around(0.5 + FRAC_PI_2, 0.02, 100));
    quarter.extend(around(0.5 - PI, 0.02, 50));
    let s = spread(&quarter).expect("spread");
    assert!((s.mean_rad - 0.5).abs() < 0.02, "{s:?}");
    assert!((s.stepped - 150.0 / 450.0).abs() < 1e-9, "{s:?}");
    assert!(s.quarter_steps && s.first_step == Some(300), "{s:?}");
    assert!(s.iqr_rad < 0.03, "{s:?}");

    let mut half = around(-1.0, 0.02, 200);
    half.extend(around(-1.0 + PI, 0.02, 40));
    let s = spread(&half).expect("spread");
    assert!(
        !s.quarter_steps && (s.stepped - 40.0 / 240.0).abs() < 1e-9,
        "{s:?}"
    );
}

#[test]
fn a_phase_that_wanders_has_a_wide_spread() {
    let wandering: Vec<f64> = (0..400).map(|i| i as f64 / 400.0 * TAU).collect();
    let s = spread(&wandering).expect("spread");
    assert!(s.iqr_rad > 0.6, "{s:?}");
    assert!(spread(&[]).is_none());
}

#[test]
fn foreign_formats_are_named_by_their_first_bytes() {
    let named = |bytes: &[u8], word: &str| match identify_bytes(bytes) {
        Some(Identified::Foreign(what)) => assert!(what.contains(word), "{what}"),
        other => panic!("{other:?} for {word}"),
    };
    named(&[0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0], "pcap");
    named(&[0x0a, 0x0d, 0x0d, 0x0a, 0, 0], "pcapng");
    named(&[0x1f, 0x8b, 8, 0], "gzip");
    named(b"index,timestamp_low,bfee_count\n0,1,2\n", "text");
    // Random bytes are nothing in particular.
    let noise: Vec<u8> = (0..4096u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    assert_eq!(identify_bytes(&noise), None);
    assert_eq!(identify_bytes(&[]), None);
}
