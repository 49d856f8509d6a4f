//! Running a scenario: the body motion, the IMU, and every AP's packets, in memory.

use nalgebra::{Isometry3, Vector3};

use super::ConfigError;
use super::baro::BaroTruth;
use super::csi::{CsiSynth, PacketTruth};
use super::imu::{ImuBiases, ImuSimulator};
use super::motion::{BodyState, sample, specific_force_in_b};
use super::packets::{self, PacketSlot};
use super::rng;
use super::room::{Path, paths_into};
use super::scenario::{ApConfig, Scenario};
use super::vibration::VibrationGenerator;
use crate::aoa::restart_step_rad;
use crate::csi::intel5300::CsiRecord;
use crate::csi::logged::Logged;
use crate::csi::sanitize::wrap;
use crate::dataset::BaroSample;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// One packet slot of one AP and, if it was received, its record and truth.
#[derive(Clone, Debug)]
pub struct SimPacket {
    /// Arrival time on the IMU clock.
    pub t: Timestamp,
    /// The record the NIC logged; `None` when the packet was lost.
    pub record: Option<Logged>,
    /// The geometry and impairments behind it (also for lost packets, whose CSI fields are then
    /// those it would have had).
    pub truth: PacketTruth,
}

/// Everything simulated for one AP.
#[derive(Clone, Debug)]
pub struct ApOutput {
    /// The AP as configured.
    pub config: ApConfig,
    /// Every packet slot, lost ones included, in time order.
    pub packets: Vec<SimPacket>,
}

impl ApOutput {
    /// Received packets.
    pub fn received_records(&self) -> impl Iterator<Item = (&SimPacket, &Logged)> {
        self.packets
            .iter()
            .filter_map(|p| p.record.as_ref().map(|r| (p, r)))
    }

    /// Received packets of an Intel 5300 rig (none on another card's).
    pub fn received(&self) -> impl Iterator<Item = (&SimPacket, &CsiRecord)> {
        self.received_records()
            .filter_map(|(p, r)| r.intel5300().map(|r| (p, r)))
    }
}

/// A simulated flight in memory.
#[derive(Clone, Debug)]
pub struct SimOutput {
    /// The body state at every IMU sample time.
    pub states: Vec<(Timestamp, BodyState)>,
    /// IMU samples (same times as `states`).
    pub imu: Vec<ImuSample>,
    /// True IMU biases carried by each sample.
    pub imu_biases: Vec<ImuBiases>,
    /// Per-chain phase offsets of the NIC, rad.
    pub chain_phase_offsets_rad: Vec<f64>,
    /// Per AP, in scenario order.
    pub aps: Vec<ApOutput>,
    /// Barometer readings (empty without a barometer).
    pub baro: Vec<BaroSample>,
    /// What lies behind each barometer reading.
    pub baro_truth: Vec<BaroTruth>,
}

/// Simulates `scenario` (validated first). `progress` receives the fraction done, in [0, 1].
pub fn simulate(
    scenario: &Scenario,
    progress: &mut dyn FnMut(f64),
) -> Result<SimOutput, ConfigError> {
    scenario.validate()?;
    let seed = scenario.seed;
    let trajectory = scenario.build_flight();
    let obstacles = scenario.all_obstacles();
    let gravity = scenario.gravity_m_s2;
    let motion_at = |t: Timestamp| sample(&trajectory, &scenario.yaw, gravity, t.as_secs_f64());

    // IMU: its own stream, so nothing else shifts its noise.
    let period_ns = scenario.imu.period_ns();
    let n_imu = (scenario.duration_ns() / period_ns + 1) as usize;
    let mut imu_sim = ImuSimulator::new(&scenario.imu, rng::stream(seed, rng::IMU_STREAM));
    let mut states = Vec::with_capacity(n_imu);
    let mut imu = Vec::with_capacity(n_imu);
    let mut imu_biases = Vec::with_capacity(n_imu);
    // The rotors spin from the take-off's start to the landing's end and shake the IMU from
    // their own stream; without a vibration nothing is drawn or added, and the IMU samples are
    // the noisy sensor's alone.
    let mut vibration = scenario
        .imu
        .vibration_model()
        .map(|v| VibrationGenerator::new(&v, period_ns, rng::stream(seed, rng::VIBRATION_STREAM)));
    let rotors = rotors_interval_s(scenario);
    for k in 0..n_imu {
        let t = Timestamp(k as i64 * period_ns);
        let s = motion_at(t);
        imu_biases.push(imu_sim.biases());
        let mut sample = imu_sim.measure(t, &s, gravity);
        let t_s = t.as_secs_f64();
        if let Some(v) = vibration.as_mut()
            && t_s >= rotors.0
            && t_s <= rotors.1
        {
            let shake = v.next(specific_force_in_b(&s, gravity).norm() / gravity);
            sample.accel_m_s2 += shake.accel_m_s2;
            sample.gyro_rad_s += shake.gyro_rad_s;
        }
        imu.push(sample);
        states.push((t, s));
    }
    let total_packets: f64 = scenario
        .aps
        .iter()
        .map(|ap| ap.packet_rate_hz.unwrap_or(scenario.radio.packet_rate_hz))
        .sum::<f64>()
        * scenario.duration_s;
    let mut done_packets = 0.0;
    let report_every = (total_packets / 100.0).max(1.0);
    let mut next_report = 0.0;
    progress(0.0);

    let chain_phase_offsets_rad = chain_phase_offsets(scenario);
    // One card's receiver response for every AP, from its own stream.
    let response = scenario
        .radio
        .receiver_response
        .factors(&mut rng::stream(seed, rng::RECEIVER_STREAM));
    let body_from_array = scenario.body_from_array();
    let mut aps = Vec::with_capacity(scenario.aps.len());
    let mut paths: Vec<Path> = Vec::with_capacity(32);
    for (l, ap) in scenario.aps.iter().enumerate() {
        let radio = &scenario.radio;
        let synth = CsiSynth::new(
            radio,
            scenario.array.geometry,
            &chain_phase_offsets_rad,
            ap.tx_power_dbm.unwrap_or(radio.tx_power_dbm),
        )
        .with_response(response)
        .with_transmitter(ap_mac(l));
        let mut timing_rng = rng::stream(seed, &rng::packet_stream_name(&ap.name));
        let mut csi_rng = rng::stream(seed, &rng::csi_stream_name(&ap.name));
        let slots = packets::schedule(
            ap.packet_rate_hz.unwrap_or(radio.packet_rate_hz),
            radio.timing_jitter_s,
            radio.loss_probability,
            scenario.duration_ns(),
            &mut timing_rng,
        );
        let p_ap_in_w = Vector3::from(ap.position_m);
        let mut out = Vec::with_capacity(slots.len());
        let mut bfee_count: u16 = 0;
        for PacketSlot { t, lost } in slots {
            let s = motion_at(t);
            let world_from_array = world_from_array(&s, &body_from_array);
            let p_array_in_w = world_from_array.translation.vector;
            paths_into(
                &scenario.room,
                &obstacles,
                &p_ap_in_w,
                &p_array_in_w,
                &mut paths,
            );
            // Lost packets still draw their noise, so loss does not shift later packets' draws.
            let (record, truth) = synth.packet(
                &paths,
                &p_array_in_w,
                &p_ap_in_w,
                &world_from_array.rotation,
                t,
                bfee_count,
                &mut csi_rng,
            );
            let record = if lost {
                None
            } else {
                bfee_count = bfee_count.wrapping_add(1);
                Some(record)
            };
            out.push(SimPacket { t, record, truth });
            done_packets += 1.0;
            if done_packets >= next_report {
                progress((done_packets / total_packets).min(1.0));
                next_report += report_every;
            }
        }
        aps.push(ApOutput {
            config: ap.clone(),
            packets: out,
        });
    }
    let (baro, baro_truth) = match &scenario.baro {
        Some(config) => config.simulate(
            scenario.duration_ns(),
            |t| trajectory.at(t.as_secs_f64()).translation.p_b_in_w.z,
            &mut rng::stream(seed, rng::BARO_STREAM),
        ),
        None => (Vec::new(), Vec::new()),
    };
    progress(1.0);
    Ok(SimOutput {
        baro,
        baro_truth,
        states,
        imu,
        imu_biases,
        chain_phase_offsets_rad,
        aps,
    })
}

/// The address AP `index` (its place in the scenario) sends from: locally administered, in the
/// manifest and in the frames of formats that keep the transmitter.
pub fn ap_mac(index: usize) -> [u8; 6] {
    [0x02, 0x00, 0x00, 0x00, 0x00, (index + 1) as u8]
}

/// When the rotors spin, s: from the take-off's start to the landing's end; the whole flight
/// without `[phases]`.
pub fn rotors_interval_s(scenario: &Scenario) -> (f64, f64) {
    scenario.phases.as_ref().map_or((0.0, f64::INFINITY), |p| {
        (p.rest_s, scenario.duration_s - p.final_rest_s)
    })
}

/// Pose of the array in the world at body state `s`.
pub fn world_from_array(s: &BodyState, body_from_array: &Isometry3<f64>) -> Isometry3<f64> {
    let world_from_body = Isometry3::from_parts(s.p_b_in_w.into(), s.world_from_body);
    world_from_body * body_from_array
}

/// The configured per-chain offsets, or ones drawn from the scenario seed; after a NIC restart
/// ([`super::RadioConfig::nic_restart`]) each moved by a multiple of the restart step drawn from
/// its own stream (the offsets before it are the lab calibration's).
fn chain_phase_offsets(scenario: &Scenario) -> Vec<f64> {
    use rand::RngExt;
    let configured = &scenario.radio.chain_phase_offsets_deg;
    let mut offsets: Vec<f64> = if configured.is_empty() {
        let mut r = rng::stream(scenario.seed, rng::CHAIN_OFFSET_STREAM);
        (0..scenario.array.geometry.num_antennas)
            .map(|_| (r.random::<f64>() - 0.5) * std::f64::consts::TAU)
            .collect()
    } else {
        configured.iter().map(|d| d.to_radians()).collect()
    };
    if scenario.radio.nic_restart {
        let step = restart_step_rad(scenario.radio.center_freq_hz);
        let states = (std::f64::consts::TAU / step).round() as u32;
        let mut r = rng::stream(scenario.seed, rng::NIC_RESTART_STREAM);
        for offset in &mut offsets {
            *offset = wrap(*offset + f64::from(r.random_range(0..states)) * step);
        }
    }
    offsets
}
