//! The NIC calibration a simulated rig ships with: the receive-chain phase offsets measured the way
//! a lab measures them, not copied from the truth: a short calibration flight in a motion-capture
//! room, each packet paired with its reference angle ([`crate::aoa::calibrate_with`]). A moving
//! capture averages the reflections out; static captures at known angles were 2–18° off in
//! phase depending on where they stood. Same seed, so the same chain offsets as the flight; a
//! different path, so not the flight's own packets.

use nalgebra::Vector3;

use super::scenario::Scenario;
use super::trajectory::TrajectoryConfig;
use super::yaw::{YawConfig, YawMode};
use super::{ConfigError, simulate};
use crate::aoa::{AoaConfig, CalibrateError, calibrate_packets_with, calibrate_with};
use crate::csi::format::CaptureFormat;
use crate::csi::packet::CsiPacket;
use crate::rig::ChainCalibration;

/// File name of the calibration in a simulated dataset.
pub const CALIBRATION_FILE: &str = "calibration.toml";
/// Length of the calibration flight, s.
const CAPTURE_S: f64 = 20.0;
/// The flight stays in a box centred this far from the AP toward the room's centre, m.
const BOX_CENTRE_FROM_AP_M: f64 = 3.0;
/// Half the box's horizontal side, m.
const BOX_HALF_SIDE_M: f64 = 1.2;
/// Height band of the box, m.
const BOX_HEIGHT_M: (f64, f64) = (1.0, 2.2);
/// Speed bound of the calibration flight, m/s.
const MAX_SPEED_M_S: f64 = 1.0;
/// The array's heading swings about the line to the AP by ± this, degrees.
const YAW_SWING_DEG: f64 = 25.0;
/// Clearance from the walls, m.
const WALL_CLEARANCE_M: f64 = 0.5;

/// Why the lab calibration could not be made.
#[derive(Debug, thiserror::Error)]
pub enum LabCalibrationError {
    /// The scenario has no AP to calibrate against.
    #[error("the scenario has no AP")]
    NoAp,
    /// The capture's scenario is not valid (e.g. the room is too small for the set-up).
    #[error("calibration capture: {0}")]
    Scenario(#[from] ConfigError),
    /// The offsets could not be estimated.
    #[error("calibration capture: {0}")]
    Calibrate(#[from] CalibrateError),
}

/// The calibration flight's scenario: the flight's room, radio, array and seed, its first AP,
/// a smooth random flight in a box in front of the AP, heading toward the AP with a swing.
pub fn capture_scenario(scenario: &Scenario) -> Result<Scenario, LabCalibrationError> {
    let ap = scenario.aps.first().ok_or(LabCalibrationError::NoAp)?;
    let c = Vector3::from(ap.position_m);
    let size = Vector3::from(scenario.room.size_m);
    let mut toward_centre = size * 0.5 - c;
    toward_centre.z = 0.0;
    let u = toward_centre.try_normalize(1e-9).unwrap_or_else(Vector3::x);
    let centre = c + u * BOX_CENTRE_FROM_AP_M;
    let clamp = |v: f64, hi: f64| {
        v.clamp(
            WALL_CLEARANCE_M,
            (hi - WALL_CLEARANCE_M).max(WALL_CLEARANCE_M),
        )
    };
    let lo = [
        clamp(centre.x - BOX_HALF_SIDE_M, size.x),
        clamp(centre.y - BOX_HALF_SIDE_M, size.y),
        clamp(BOX_HEIGHT_M.0, size.z),
    ];
    let hi = [
        clamp(centre.x + BOX_HALF_SIDE_M, size.x),
        clamp(centre.y + BOX_HALF_SIDE_M, size.y),
        clamp(BOX_HEIGHT_M.1, size.z),
    ];
    let mut capture = scenario.clone();
    capture.name = format!("{}-calibration", scenario.name);
    capture.duration_s = CAPTURE_S;
    capture.aps = vec![ap.clone()];
    // The rig is carried around the AP in the lab, airborne throughout; no flight controller.
    capture.phases = None;
    capture.baro = None;
    // Calibrated before the NIC restarted: the offsets the restart then moves.
    capture.radio.nic_restart = false;
    capture.trajectory = TrajectoryConfig::RandomSmooth {
        bounds_min_m: lo,
        bounds_max_m: hi,
        max_speed_m_s: MAX_SPEED_M_S,
        num_harmonics: 4,
        min_period_s: 6.0,
        max_period_s: 20.0,
    };
    capture.yaw = YawConfig {
        mode: YawMode::TowardPoint {
            point_m: ap.position_m,
        },
        offset_deg: 0.0,
        oscillation_amplitude_deg: YAW_SWING_DEG,
        oscillation_period_s: 7.0,
    };
    Ok(capture)
}

/// Simulates the calibration flight and calibrates on it with each packet's reference angle
/// (what the lab's motion capture gives; [`crate::aoa::calibrate_with`]).
pub fn lab_calibration(scenario: &Scenario) -> Result<ChainCalibration, LabCalibrationError> {
    let capture = capture_scenario(scenario)?;
    let out = simulate(&capture, &mut |_| {})?;
    let (geometry, carrier_hz) = (scenario.array.geometry, scenario.radio.center_freq_hz);
    let config = AoaConfig::default();
    let (mut calibration, _) = if scenario.radio.card == CaptureFormat::Intel5300 {
        let pairs = out
            .aps
            .iter()
            .flat_map(|ap| ap.received().map(|(p, r)| (r, p.truth.aoa_rad)));
        calibrate_with(pairs, geometry, carrier_hz, &config)?
    } else {
        // Every record the simulator writes has CSI and a tone table: none is left out.
        let packets: Vec<(CsiPacket, f64)> = out
            .aps
            .iter()
            .flat_map(|ap| ap.received_records())
            .filter_map(|(p, r)| r.card_packet()?.ok().map(|c| (c, p.truth.aoa_rad)))
            .collect();
        let pairs = packets.iter().map(|(c, aoa)| (c, *aoa));
        calibrate_packets_with(pairs, geometry, carrier_hz, &config)?
    };
    calibration.source = format!(
        "simulated calibration flight with motion-capture angles: {CAPTURE_S} s in front of AP \
         {} (aoa::calibrate_with)",
        ap_name(scenario)
    );
    Ok(calibration)
}

fn ap_name(scenario: &Scenario) -> &str {
    scenario.aps.first().map_or("", |a| a.name.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    /// The measured offsets are close to the simulator's true ones (not copies of them).
    #[test]
    fn the_lab_calibration_is_near_the_true_offsets() {
        let mut scenario = Scenario::built_in("paper-circle").unwrap().airborne();
        scenario.duration_s = 1.0;
        let truth = simulate(&scenario, &mut |_| {})
            .unwrap()
            .chain_phase_offsets_rad;
        let cal = lab_calibration(&scenario).unwrap();
        assert!(cal.packets > 100, "{}", cal.packets);
        for m in 1..3 {
            let d = (cal.phase_offsets_rad[m] - cal.phase_offsets_rad[0]) - (truth[m] - truth[0]);
            let err = ((d + PI).rem_euclid(TAU) - PI).abs().to_degrees();
            println!("lab calibration, chain {m}: {err:.2}° off the truth");
            assert!(err < 2.0 && err > 1e-6, "chain {m}: {err}°");
        }
    }

    /// After a NIC restart the flight's offsets differ from the lab's (made before it) by
    /// multiples of the restart step on each chain: π at 5 GHz, π/2 at 2.4 GHz; over seeds every
    /// multiple occurs.
    #[test]
    fn a_restart_moves_each_chain_by_multiples_of_the_step() {
        for (freq_hz, step) in [(5.32e9, PI), (2.437e9, PI / 2.0)] {
            let mut seen = std::collections::BTreeSet::new();
            for seed in 1..=12 {
                let mut scenario = Scenario::built_in("paper-circle").unwrap().airborne();
                scenario.duration_s = 0.2;
                scenario.seed = seed;
                scenario.radio.center_freq_hz = freq_hz;
                let before = simulate(&scenario, &mut |_| {})
                    .unwrap()
                    .chain_phase_offsets_rad;
                scenario.radio.nic_restart = true;
                let after = simulate(&scenario, &mut |_| {})
                    .unwrap()
                    .chain_phase_offsets_rad;
                let capture = capture_scenario(&scenario).unwrap();
                assert!(
                    !capture.radio.nic_restart,
                    "the lab calibrates before the restart"
                );
                for (a, b) in after.iter().zip(&before) {
                    let k = (a - b).rem_euclid(TAU) / step;
                    assert!((k - k.round()).abs() < 1e-9, "{a} vs {b}");
                    seen.insert((k.round() as i64).rem_euclid((TAU / step).round() as i64));
                }
            }
            assert_eq!(
                seen.len() as f64,
                (TAU / step).round(),
                "{freq_hz}: {seen:?}"
            );
        }
    }
}
