//! The checks of a scenario: every field, the flight's size in memory, the APs, and that the
//! flight stays in the room, is flyable and keeps clear of the APs.

use nalgebra::Vector3;

use super::Scenario;
use crate::check::num;
use crate::sim::ConfigError;
use crate::sim::flight::MIN_CLIMB_M;
use crate::sim::motion::sample;

/// Sampling step of the checks that the flight stays in the room and flyable.
const VALIDATION_STEP_S: f64 = 0.05;
/// Closest the array may come to a wall, floor or ceiling, m.
const WALL_MARGIN_M: f64 = 0.1;
/// Closest the array may come to an AP, m (the far-field model needs a few wavelengths).
const MIN_AP_DISTANCE_M: f64 = 0.3;

/// Most IMU samples one simulation holds (the simulator keeps the whole flight in memory, about
/// 300 bytes per sample with its truth): 1 h at 400 Hz.
pub const MAX_SIM_IMU_SAMPLES: f64 = 1_440_000.0;
/// Most packet slots, every AP's together, one simulation holds (about 1 kB each with the CSI and
/// its truth): 1 h at 200 packets/s.
pub const MAX_SIM_PACKETS: f64 = 720_000.0;

impl Scenario {
    /// Checks every field, then that the flight stays in the room, is flyable (|a| < g) and keeps
    /// clear of the APs.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.duration_s.is_finite() && self.duration_s > 0.0 && self.duration_s <= 3600.0) {
            return Err(ConfigError::new(
                "duration_s",
                format!("{} is not in (0, 3600] s", self.duration_s),
            ));
        }
        if !(self.gravity_m_s2.is_finite() && (1.0..=30.0).contains(&self.gravity_m_s2)) {
            return Err(ConfigError::new(
                "gravity_m_s2",
                format!("{} is not in [1, 30]", self.gravity_m_s2),
            ));
        }
        if let Some(phases) = &self.phases {
            phases.validate("phases", self.duration_s)?;
        }
        self.trajectory.validate("trajectory")?;
        self.yaw.validate("yaw")?;
        self.imu.validate("imu")?;
        let g = &self.array.geometry;
        if let Err(e) = g.validate(self.radio.center_freq_hz) {
            return Err(ConfigError::new("array.geometry", e.to_string()));
        }
        let e = &self.array.body_from_array;
        if e.translation_m
            .iter()
            .chain(&e.rotation_rpy_deg)
            .any(|v| !v.is_finite())
        {
            return Err(ConfigError::new("array.body_from_array", "not all finite"));
        }
        self.radio.validate("radio", g.num_antennas)?;
        self.room.validate("room")?;
        if let Some(o) = &self.obstacle {
            o.validate("obstacle")?;
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            o.validate(&format!("obstacles[{i}]"))?;
        }
        if let Some(b) = &self.baro {
            b.validate("baro")?;
        }
        self.validate_aps()?;
        self.validate_size()?;
        self.validate_flight()
    }

    /// The flight's IMU samples and packet slots within what the simulator may hold.
    fn validate_size(&self) -> Result<(), ConfigError> {
        let imu = self.duration_s * self.imu.rate_hz;
        if imu > MAX_SIM_IMU_SAMPLES {
            return Err(ConfigError::new(
                "imu.rate_hz",
                format!(
                    "duration_s {} at imu.rate_hz {} gives {} IMU samples; at most {} (the \
                     simulator holds the whole flight in memory): shorten the flight or lower \
                     the rate",
                    num(self.duration_s),
                    num(self.imu.rate_hz),
                    num(imu.ceil()),
                    num(MAX_SIM_IMU_SAMPLES)
                ),
            ));
        }
        let packets: f64 = self
            .aps
            .iter()
            .map(|ap| self.duration_s * ap.packet_rate_hz.unwrap_or(self.radio.packet_rate_hz))
            .sum();
        if packets > MAX_SIM_PACKETS {
            return Err(ConfigError::new(
                "radio.packet_rate_hz",
                format!(
                    "duration_s {} at the APs' packet rates gives {} packet slots; at most {} \
                     (the simulator holds the whole flight in memory): shorten the flight, \
                     lower the rates or use fewer APs",
                    num(self.duration_s),
                    num(packets.ceil()),
                    num(MAX_SIM_PACKETS)
                ),
            ));
        }
        Ok(())
    }

    fn validate_aps(&self) -> Result<(), ConfigError> {
        if self.aps.is_empty() {
            return Err(ConfigError::new("aps", "no access point"));
        }
        for (i, ap) in self.aps.iter().enumerate() {
            let field = format!("aps[{i}]");
            let name_ok = !ap.name.is_empty()
                && ap.name.len() <= 64
                && ap
                    .name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
            if !name_ok {
                return Err(ConfigError::new(
                    format!("{field}.name"),
                    format!("{:?}: use 1–64 letters, digits, '-' or '_'", ap.name),
                ));
            }
            if self.aps[..i].iter().any(|o| o.name == ap.name) {
                return Err(ConfigError::new(
                    format!("{field}.name"),
                    format!("{:?} twice", ap.name),
                ));
            }
            let p = Vector3::from(ap.position_m);
            if !self.room.contains(&p) {
                return Err(ConfigError::new(
                    format!("{field}.position_m"),
                    format!(
                        "{:?} is not inside the room {:?}",
                        ap.position_m, self.room.size_m
                    ),
                ));
            }
            if let Some(v) = ap
                .tx_power_dbm
                .filter(|v| !(v.is_finite() && v.abs() <= 100.0))
            {
                return Err(ConfigError::new(
                    format!("{field}.tx_power_dbm"),
                    format!("{v}"),
                ));
            }
            if let Some(v) = ap
                .packet_rate_hz
                .filter(|v| !(v.is_finite() && (0.1..=2000.0).contains(v)))
            {
                return Err(ConfigError::new(
                    format!("{field}.packet_rate_hz"),
                    format!("{v} is not in [0.1, 2000] Hz"),
                ));
            }
        }
        Ok(())
    }

    fn validate_flight(&self) -> Result<(), ConfigError> {
        let traj = self.build_flight();
        if let (Some(phases), Some(ground_m)) = (&self.phases, traj.ground_height_m()) {
            let start_m = traj
                .at(phases.rest_s + phases.takeoff_s)
                .translation
                .p_b_in_w
                .z;
            let end_m = traj
                .at(self.duration_s - phases.final_rest_s - phases.landing_s)
                .translation
                .p_b_in_w
                .z;
            if start_m.min(end_m) < ground_m + MIN_CLIMB_M {
                return Err(ConfigError::new(
                    "phases.ground_height_m",
                    format!(
                        "the mission starts at {start_m:.2} m and ends at {end_m:.2} m, not \
                         {MIN_CLIMB_M} m above the ground ({ground_m} m)"
                    ),
                ));
            }
        }
        let body_from_array = self.body_from_array();
        let steps = (self.duration_s / VALIDATION_STEP_S).ceil() as usize;
        for i in 0..=steps {
            let t_s = (i as f64 * VALIDATION_STEP_S).min(self.duration_s);
            let s = sample(&traj, &self.yaw, self.gravity_m_s2, t_s);
            if s.a_b_in_w.norm() >= 0.9 * self.gravity_m_s2 {
                return Err(ConfigError::new(
                    "trajectory",
                    format!(
                        "acceleration {:.2} m/s² at t = {t_s:.2} s is too close to g for a quadrotor",
                        s.a_b_in_w.norm()
                    ),
                ));
            }
            let p_array = s.p_b_in_w + s.world_from_body * body_from_array.translation.vector;
            let size = Vector3::from(self.room.size_m);
            let inside = (0..3)
                .all(|k| p_array[k] >= WALL_MARGIN_M && p_array[k] <= size[k] - WALL_MARGIN_M);
            if !inside {
                return Err(ConfigError::new(
                    "trajectory",
                    format!(
                        "the array at t = {t_s:.2} s is at {:?}, within {WALL_MARGIN_M} m of the room's boundary or outside it",
                        p_array.as_slice()
                    ),
                ));
            }
            for ap in &self.aps {
                let d = (Vector3::from(ap.position_m) - p_array).norm();
                if d < MIN_AP_DISTANCE_M {
                    return Err(ConfigError::new(
                        "trajectory",
                        format!(
                            "the array passes {d:.2} m from AP {:?} at t = {t_s:.2} s",
                            ap.name
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}
