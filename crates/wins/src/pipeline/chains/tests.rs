use super::second_pass::with_step;
use super::*;
use crate::config::ChainOffsetsConfig;
use crate::csi::sanitize::wrap;

#[test]
fn settings_out_of_range_are_named() {
    assert!(ChainOffsetsConfig::default().problems("c").is_empty());
    let bad = ChainOffsetsConfig {
        curvature_packets: 0,
        decide_after_s: -1.0,
        decide_after_uncalibrated_s: f64::NAN,
        decide_alone_after_s: 1e9,
        uncalibrated_hypotheses: 100,
        curvature_refresh_packets: 0,
        second_pass_max_s: f64::INFINITY,
        second_pass_sin_bias_sigma: -0.1,
        ..ChainOffsetsConfig::default()
    };
    let text = bad.problems("pipeline.chains").to_string();
    for key in [
        "curvature_packets",
        "decide_after_s",
        "decide_after_uncalibrated_s",
        "decide_alone_after_s",
        "uncalibrated_hypotheses",
        "curvature_refresh_packets",
        "second_pass_max_s",
        "second_pass_sin_bias_sigma",
    ] {
        assert!(
            text.contains(&format!("pipeline.chains.{key}")),
            "{key}: {text}"
        );
    }
}

#[test]
fn a_uniform_step_moves_chain_m_by_m_steps_and_no_step_changes_nothing() {
    let base = ChainCalibration {
        phase_offsets_rad: vec![3.5, -0.25, 1.0],
        ..ChainCalibration::identity(3)
    };
    assert_eq!(with_step(&base, 0.0), base);
    let moved = with_step(&base, 0.5);
    for (m, (a, b)) in moved
        .phase_offsets_rad
        .iter()
        .zip(&base.phase_offsets_rad)
        .enumerate()
    {
        assert!((wrap(a - b) - wrap(0.5 * m as f64)).abs() < 1e-12);
    }
}
