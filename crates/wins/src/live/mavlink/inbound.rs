//! What the flight controller sends us, decoded into our types: IMU samples and barometer
//! readings ([`InboundDecoder::decode`]).
//!
//! ## Sources
//!
//! | message | time | IMU | pressure |
//! |---|---|---|---|
//! | `HIGHRES_IMU` | `time_usec`, µs | `xacc..` m/s², `xgyro..` rad/s, taken only when the six accel and gyro bits of `fields_updated` are all set | `abs_pressure`, hPa, taken when its bit is set |
//! | `SCALED_IMU` | `time_boot_ms`, ms | mG and mrad/s | — |
//! | `RAW_IMU` | `time_usec`, µs | raw counts × the scales of [`RawImuScale`]; refused without them | — |
//! | `SCALED_PRESSURE` | `time_boot_ms`, ms | — | `press_abs`, hPa |
//!
//! Other messages (including `SCALED_IMU2/3` and `SCALED_PRESSURE2/3`, the second and third
//! sensors) are counted as `other`.
//!
//! ## Frames and clocks
//!
//! The flight controller's body frame is FRD (x forward, y right, z down). Its accelerometer
//! measures the specific force: at rest and level it reads z ≈ −9.81 m/s², i.e. +g along the
//! upward direction, which is exactly what [`ImuSample::accel_m_s2`] holds. So the accelerometer
//! and gyro vectors are passed through **unchanged**, and the estimator's body frame `b` *is* the
//! flight controller's FRD frame (the rig's antenna extrinsic must then be given in FRD too).
//!
//! Times stay on the flight controller's clock, in ns (µs × 1000, ms × 10⁶); relating it to the
//! host's clock is the driver's job ([`crate::live::clock::ClockSync`]).
//!
//! Nothing here panics on bad input: a non-finite or absurd value refuses the reading, counted
//! with its reason in [`InboundStats`].

use ::mavlink::MavHeader;
use ::mavlink::dialects::common::{
    HIGHRES_IMU_DATA, HighresImuUpdatedFlags, MavMessage, RAW_IMU_DATA, SCALED_IMU_DATA,
    SCALED_PRESSURE_DATA,
};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::imu::ImuSample;
use crate::time::Timestamp;

/// Standard gravity, m/s² (the `G` of the flight controller's mG).
pub const STANDARD_GRAVITY_M_S2: f64 = 9.80665;
/// Sea-level pressure of the standard atmosphere, Pa.
pub const STANDARD_SEA_LEVEL_PA: f64 = 101_325.0;
/// Sea-level temperature of the standard atmosphere, K.
const STANDARD_SEA_LEVEL_K: f64 = 288.15;
/// Temperature lapse rate of the standard troposphere, K/m.
const LAPSE_RATE_K_M: f64 = 0.0065;
/// Exponent `R·L / (g₀·M)` of the standard troposphere (R = 8.314 462 J/(mol·K), M = 0.028 964 4
/// kg/mol).
const BAROMETRIC_EXPONENT: f64 = 0.190_263;
/// Pascals per hectopascal (millibar).
const PA_PER_HPA: f64 = 100.0;
/// Nanoseconds per microsecond and per millisecond.
const NS_PER_US: i64 = 1_000;
const NS_PER_MS: i64 = 1_000_000;

/// Pressure altitude of the standard atmosphere (troposphere, below 11 km), m:
///
/// ```text
/// h = (T₀ / L) · (1 − (p / p₀)^(R·L / (g₀·M)))
///   = 44 330.8 m · (1 − (p / p₀)^0.190263)
/// ```
///
/// with T₀ = 288.15 K, L = 0.0065 K/m and `p₀` the sea-level (or reference) pressure. Only
/// altitude *differences* matter to the estimator (it fits a barometer offset), so `p₀` may be the
/// standard 101 325 Pa.
pub fn pressure_altitude_m(pressure_pa: f64, sea_level_pa: f64) -> f64 {
    STANDARD_SEA_LEVEL_K / LAPSE_RATE_K_M
        * (1.0 - (pressure_pa / sea_level_pa).powf(BAROMETRIC_EXPONENT))
}

/// Scales of `RAW_IMU`'s counts (they depend on the sensor and its range setting).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawImuScale {
    /// Specific force per accelerometer count, m/s².
    pub accel_m_s2_per_count: f64,
    /// Angular rate per gyro count, rad/s.
    pub gyro_rad_s_per_count: f64,
}

/// Settings of [`InboundDecoder`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InboundConfig {
    /// Scales for `RAW_IMU`; `None` (default) refuses `RAW_IMU`, whose counts mean nothing
    /// without them.
    pub raw_imu_scale: Option<RawImuScale>,
    /// Reference pressure of the altitude, Pa (default: standard sea level, 101 325 Pa).
    pub sea_level_pa: f64,
    /// The accelerometer's full scale per axis, m/s²: a sample at or beyond it (saturated or
    /// corrupt) is refused, as `wins run` drops it. Default 400 (about 40 g); `wins live` sets the
    /// rig's `imu.accel_range_m_s2`, so that its recording replays to the same poses.
    pub max_accel_m_s2: f64,
    /// The gyroscope's full scale per axis, rad/s, likewise (default 50; live: the rig's
    /// `imu.gyro_range_rad_s`).
    pub max_gyro_rad_s: f64,
    /// Believable pressures, Pa (default 10 kPa to 120 kPa: 16 km up to well below sea level).
    pub pressure_range_pa: (f64, f64),
    /// The flight controller's MAVLink system id: [`InboundDecoder::decode_from`] takes messages
    /// from it only (default 1).
    pub fc_system_id: u8,
    /// The flight controller's component id (default 1, `MAV_COMP_ID_AUTOPILOT1`; 0: any).
    pub fc_component_id: u8,
}

impl Default for InboundConfig {
    fn default() -> Self {
        Self {
            raw_imu_scale: None,
            sea_level_pa: STANDARD_SEA_LEVEL_PA,
            max_accel_m_s2: 400.0,
            max_gyro_rad_s: 50.0,
            pressure_range_pa: (10_000.0, 120_000.0),
            fc_system_id: 1,
            fc_component_id: 1,
        }
    }
}

/// A barometer reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroSample {
    /// Time on the flight controller's clock.
    pub t: Timestamp,
    /// Absolute pressure, Pa.
    pub pressure_pa: f64,
    /// Pressure altitude ([`pressure_altitude_m`]), m.
    pub altitude_m: f64,
}

/// What one message gave: `HIGHRES_IMU` can carry both an IMU sample and a pressure; most messages
/// give neither (see [`InboundStats`] for why).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inbound {
    /// An IMU sample (body = the flight controller's FRD frame).
    pub imu: Option<ImuSample>,
    /// A barometer reading.
    pub baro: Option<BaroSample>,
}

/// Why readings were refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RefusedCounts {
    /// A NaN or infinite value.
    pub non_finite: u64,
    /// A value beyond the configured limits, or a time that does not fit.
    pub out_of_range: u64,
    /// A `RAW_IMU` with no [`RawImuScale`] configured.
    pub raw_imu_without_scale: u64,
    /// A `HIGHRES_IMU` whose `fields_updated` has some but not all of the accel and gyro bits, or
    /// neither those nor the pressure bit.
    pub incomplete: u64,
}

impl RefusedCounts {
    /// All refusals.
    pub fn total(&self) -> u64 {
        self.non_finite + self.out_of_range + self.raw_imu_without_scale + self.incomplete
    }
}

/// Counters of what the decoder saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct InboundStats {
    /// IMU samples produced.
    pub imu: u64,
    /// Barometer readings produced.
    pub baro: u64,
    /// Readings refused, by reason.
    pub refused: RefusedCounts,
    /// Messages of other kinds.
    pub other: u64,
    /// Messages from another system or component than the flight controller's, left out.
    pub other_sender: u64,
}

/// Decodes the flight controller's messages and counts what it did with them.
#[derive(Clone, Debug, Default)]
pub struct InboundDecoder {
    config: InboundConfig,
    stats: InboundStats,
}

/// Why one reading was refused.
enum Refusal {
    NonFinite,
    OutOfRange,
}

impl InboundDecoder {
    /// A decoder with these settings.
    pub fn new(config: InboundConfig) -> Self {
        Self {
            config,
            stats: InboundStats::default(),
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> &InboundStats {
        &self.stats
    }

    /// Decodes one message if it comes from the configured flight controller
    /// ([`InboundConfig::fc_system_id`], [`InboundConfig::fc_component_id`]); anything else is
    /// counted ([`InboundStats::other_sender`]) and gives nothing, so that no other sender on the
    /// network can move the poses.
    pub fn decode_from(&mut self, header: &MavHeader, message: &MavMessage) -> Inbound {
        let c = &self.config;
        let system_ok = header.system_id == u32::from(c.fc_system_id);
        let component_ok = c.fc_component_id == 0 || header.component_id == c.fc_component_id;
        if system_ok && component_ok {
            self.decode(message)
        } else {
            self.stats.other_sender += 1;
            Inbound::default()
        }
    }

    /// Decodes one message, whoever sent it.
    pub fn decode(&mut self, message: &MavMessage) -> Inbound {
        match message {
            MavMessage::HIGHRES_IMU(m) => self.highres_imu(m),
            MavMessage::SCALED_IMU(m) => self.scaled_imu(m),
            MavMessage::RAW_IMU(m) => self.raw_imu(m),
            MavMessage::SCALED_PRESSURE(m) => self.scaled_pressure(m),
            _ => {
                self.stats.other += 1;
                Inbound::default()
            }
        }
    }

    fn highres_imu(&mut self, m: &HIGHRES_IMU_DATA) -> Inbound {
        let accel_gyro = HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_XACC
            | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_YACC
            | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ZACC
            | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_XGYRO
            | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_YGYRO
            | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ZGYRO;
        let pressure_bit = HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ABS_PRESSURE;
        let flags = m.fields_updated;
        let t = micros_to_timestamp(m.time_usec);
        let mut out = Inbound::default();
        if flags.contains(accel_gyro) {
            let accel = Vector3::new(m.xacc, m.yacc, m.zacc).map(f64::from);
            let gyro = Vector3::new(m.xgyro, m.ygyro, m.zgyro).map(f64::from);
            out.imu = self.imu_sample(t, accel, gyro);
        } else if flags.intersects(accel_gyro) || !flags.contains(pressure_bit) {
            self.stats.refused.incomplete += 1;
        }
        if flags.contains(pressure_bit) {
            out.baro = self.baro_sample(t, f64::from(m.abs_pressure) * PA_PER_HPA);
        }
        out
    }

    fn scaled_imu(&mut self, m: &SCALED_IMU_DATA) -> Inbound {
        let accel_per_mg = STANDARD_GRAVITY_M_S2 / 1000.0;
        let accel = Vector3::new(m.xacc, m.yacc, m.zacc).map(|v| f64::from(v) * accel_per_mg);
        let gyro = Vector3::new(m.xgyro, m.ygyro, m.zgyro).map(|v| f64::from(v) / 1000.0);
        let t = Some(Timestamp(i64::from(m.time_boot_ms) * NS_PER_MS));
        Inbound {
            imu: self.imu_sample(t, accel, gyro),
            baro: None,
        }
    }

    fn raw_imu(&mut self, m: &RAW_IMU_DATA) -> Inbound {
        let Some(scale) = self.config.raw_imu_scale else {
            self.stats.refused.raw_imu_without_scale += 1;
            return Inbound::default();
        };
        let accel =
            Vector3::new(m.xacc, m.yacc, m.zacc).map(|v| f64::from(v) * scale.accel_m_s2_per_count);
        let gyro = Vector3::new(m.xgyro, m.ygyro, m.zgyro)
            .map(|v| f64::from(v) * scale.gyro_rad_s_per_count);
        Inbound {
            imu: self.imu_sample(micros_to_timestamp(m.time_usec), accel, gyro),
            baro: None,
        }
    }

    fn scaled_pressure(&mut self, m: &SCALED_PRESSURE_DATA) -> Inbound {
        let t = Some(Timestamp(i64::from(m.time_boot_ms) * NS_PER_MS));
        Inbound {
            imu: None,
            baro: self.baro_sample(t, f64::from(m.press_abs) * PA_PER_HPA),
        }
    }

    /// The IMU sample, or `None` counted with its reason.
    fn imu_sample(
        &mut self,
        t: Option<Timestamp>,
        accel_m_s2: Vector3<f64>,
        gyro_rad_s: Vector3<f64>,
    ) -> Option<ImuSample> {
        let check = || {
            let t = t.ok_or(Refusal::OutOfRange)?;
            if !accel_m_s2
                .iter()
                .chain(gyro_rad_s.iter())
                .all(|v| v.is_finite())
            {
                return Err(Refusal::NonFinite);
            }
            if accel_m_s2.amax() >= self.config.max_accel_m_s2
                || gyro_rad_s.amax() >= self.config.max_gyro_rad_s
            {
                return Err(Refusal::OutOfRange);
            }
            Ok(ImuSample {
                t,
                gyro_rad_s,
                accel_m_s2,
            })
        };
        let result = check();
        match result {
            Ok(sample) => {
                self.stats.imu += 1;
                Some(sample)
            }
            Err(refusal) => {
                self.count(refusal);
                None
            }
        }
    }

    /// The barometer reading, or `None` counted with its reason.
    fn baro_sample(&mut self, t: Option<Timestamp>, pressure_pa: f64) -> Option<BaroSample> {
        let (low, high) = self.config.pressure_range_pa;
        let check = || {
            let t = t.ok_or(Refusal::OutOfRange)?;
            if !pressure_pa.is_finite() {
                return Err(Refusal::NonFinite);
            }
            if !(low..=high).contains(&pressure_pa) {
                return Err(Refusal::OutOfRange);
            }
            let altitude_m = pressure_altitude_m(pressure_pa, self.config.sea_level_pa);
            if !altitude_m.is_finite() {
                return Err(Refusal::NonFinite);
            }
            Ok(BaroSample {
                t,
                pressure_pa,
                altitude_m,
            })
        };
        let result = check();
        match result {
            Ok(sample) => {
                self.stats.baro += 1;
                Some(sample)
            }
            Err(refusal) => {
                self.count(refusal);
                None
            }
        }
    }

    fn count(&mut self, refusal: Refusal) {
        match refusal {
            Refusal::NonFinite => self.stats.refused.non_finite += 1,
            Refusal::OutOfRange => self.stats.refused.out_of_range += 1,
        }
    }
}

/// µs on the flight controller's clock to a [`Timestamp`]; `None` when it does not fit.
fn micros_to_timestamp(us: u64) -> Option<Timestamp> {
    let ns = i64::try_from(us).ok()?.checked_mul(NS_PER_US)?;
    Some(Timestamp(ns)).filter(|t| t.is_in_range())
}

#[cfg(test)]
mod tests;
