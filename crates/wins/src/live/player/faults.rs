//! Faults a player puts into the streams it sends (`wins replay --fault`), to try `wins live`
//! on what a field flight brings: a misdated message, a silent or rebooting flight controller,
//! a corrupt stretch of a CSI stream. Each is given as `KIND@AT:VALUE`, `AT` in s of the
//! dataset from its first input:
//!
//! | fault | what is sent |
//! |---|---|
//! | `imu-shift@AT:S` | the first IMU sample at or after `AT` with its time `S` s off (once) |
//! | `imu-silence@AT:S` | no IMU nor barometer for `S` s from `AT` |
//! | `fc-reboot@AT:S` | the flight controller reboots at `AT`: silent for `S` s, then its clock reads from 0 at `AT` |
//! | `csi-shift@AT:S` | the first CSI record at or after `AT` with its NIC time `S` s off (once) |
//! | `csi-garbage@AT:N` | `N` bytes of seeded random garbage in the CSI stream before the first record at or after `AT` |
//! | `imu-nan@AT:S` | the IMU samples of `S` s from `AT` with NaN readings (a failing sensor driver) |
//! | `imu-saturate@AT:S` | the IMU samples of `S` s from `AT` reading 39 g and 45 rad/s on every axis (beyond a 16 g, 2000 °/s IMU's range) |
//! | `mav-corrupt@AT:N` | each of the `N` IMU messages from `AT` first sent corrupted, in a datagram of its own: [`CORRUPT_PREFIX`] bytes of garbage, then the message with one payload bit flipped (its CRC fails); then sent intact |

use std::str::FromStr;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::imu::ImuSample;
use nalgebra::Vector3;

/// Nanoseconds per second.
const NS_PER_S: f64 = 1e9;
/// Seed of the garbage's bytes.
const GARBAGE_SEED: u64 = 0x5EED;
/// Most garbage one fault sends, bytes.
const MAX_GARBAGE: usize = 1 << 24;
/// Garbage bytes before each corrupted MAVLink message (`mav-corrupt`).
pub const CORRUPT_PREFIX: usize = 16;
/// Most messages one `mav-corrupt` fault corrupts.
const MAX_CORRUPT: usize = 1 << 20;
/// A saturated accelerometer's reading, m/s² (39 g).
const SATURATED_ACCEL_M_S2: f64 = 39.0 * 9.806_65;
/// A saturated gyroscope's reading, rad/s.
const SATURATED_GYRO_RAD_S: f64 = 45.0;

/// One fault (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlayFault {
    /// One IMU sample misdated.
    ImuShift {
        /// When, s of the dataset.
        at_s: f64,
        /// By how much, s.
        shift_s: f64,
    },
    /// The IMU (and barometer) silent.
    ImuSilence {
        /// From, s of the dataset.
        at_s: f64,
        /// For, s.
        for_s: f64,
    },
    /// The flight controller reboots: silent, then its clock restarts.
    FcReboot {
        /// When, s of the dataset (its clock reads 0 then).
        at_s: f64,
        /// Silent for, s.
        for_s: f64,
    },
    /// One CSI record's NIC time misdated.
    CsiShift {
        /// When, s of the dataset.
        at_s: f64,
        /// By how much, s.
        shift_s: f64,
    },
    /// The IMU's readings NaN.
    ImuNan {
        /// From, s of the dataset.
        at_s: f64,
        /// For, s.
        for_s: f64,
    },
    /// The IMU's readings beyond its range.
    ImuSaturate {
        /// From, s of the dataset.
        at_s: f64,
        /// For, s.
        for_s: f64,
    },
    /// IMU messages first sent corrupted.
    MavCorrupt {
        /// From, s of the dataset.
        at_s: f64,
        /// How many messages.
        messages: usize,
    },
    /// Random bytes in the CSI stream.
    CsiGarbage {
        /// When, s of the dataset.
        at_s: f64,
        /// How many bytes.
        bytes: usize,
    },
}

impl FromStr for PlayFault {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || format!("{s:?}: a fault is KIND@AT:VALUE (`wins replay --help`)");
        let (kind, rest) = s.split_once('@').ok_or_else(bad)?;
        let (at, value) = rest.split_once(':').ok_or_else(bad)?;
        let at_s: f64 = at.parse().map_err(|_| bad())?;
        let value_s: f64 = value.parse().map_err(|_| bad())?;
        if !(at_s.is_finite() && at_s >= 0.0 && value_s.is_finite()) {
            return Err(bad());
        }
        let positive = |v: f64| (v > 0.0).then_some(v).ok_or_else(bad);
        match kind {
            "imu-shift" => Ok(Self::ImuShift {
                at_s,
                shift_s: value_s,
            }),
            "imu-silence" => Ok(Self::ImuSilence {
                at_s,
                for_s: positive(value_s)?,
            }),
            "fc-reboot" => Ok(Self::FcReboot {
                at_s,
                for_s: positive(value_s)?,
            }),
            "imu-nan" => Ok(Self::ImuNan {
                at_s,
                for_s: positive(value_s)?,
            }),
            "imu-saturate" => Ok(Self::ImuSaturate {
                at_s,
                for_s: positive(value_s)?,
            }),
            "csi-shift" => Ok(Self::CsiShift {
                at_s,
                shift_s: value_s,
            }),
            "csi-garbage" => {
                let bytes = value.parse::<usize>().map_err(|_| bad())?;
                if bytes == 0 || bytes > MAX_GARBAGE {
                    return Err(format!("{s:?}: 1 to {MAX_GARBAGE} bytes of garbage"));
                }
                Ok(Self::CsiGarbage { at_s, bytes })
            }
            "mav-corrupt" => {
                let messages = value.parse::<usize>().map_err(|_| bad())?;
                if messages == 0 || messages > MAX_CORRUPT {
                    return Err(format!("{s:?}: 1 to {MAX_CORRUPT} messages"));
                }
                Ok(Self::MavCorrupt { at_s, messages })
            }
            _ => Err(format!(
                "{s:?}: the kinds are imu-shift, imu-silence, fc-reboot, imu-nan, imu-saturate, \
                 mav-corrupt, csi-shift, csi-garbage"
            )),
        }
    }
}

/// The faults of a play, applied as the inputs go out (each once where it says once).
#[derive(Clone, Debug, Default)]
pub(super) struct Faults {
    faults: Vec<(PlayFault, bool)>,
    /// IMU messages corrupted so far, per fault.
    corrupted: Vec<usize>,
}

impl Faults {
    pub(super) fn new(faults: &[PlayFault]) -> Self {
        Self {
            faults: faults.iter().map(|&f| (f, false)).collect(),
            corrupted: vec![0; faults.len()],
        }
    }

    /// Whether the IMU message at `rel_s` s into the dataset is first sent corrupted; if so,
    /// `frame` (its encoded bytes) becomes the corrupted datagram.
    pub(super) fn corrupt(&mut self, rel_s: f64, frame: &mut Vec<u8>) -> bool {
        for ((fault, _), n) in self.faults.iter().zip(&mut self.corrupted) {
            if let PlayFault::MavCorrupt { at_s, messages } = *fault
                && rel_s >= at_s
                && *n < messages
            {
                *n += 1;
                // A payload bit (the payload starts after the 10-byte MAVLink 2 header).
                if let Some(b) = frame.get_mut(12) {
                    *b ^= 0x10;
                }
                let mut rng = ChaCha8Rng::seed_from_u64(GARBAGE_SEED + *n as u64);
                let garbage = (0..CORRUPT_PREFIX).map(|_| rng.random::<u8>() & 0x7F);
                frame.splice(0..0, garbage);
                return true;
            }
        }
        false
    }

    /// The time to send for the IMU sample (`imu`) or barometer reading at `t_ns` (`rel_s` s
    /// into the dataset), or `None` when it is not sent.
    pub(super) fn fc_time(&mut self, t_ns: i64, rel_s: f64, imu: bool) -> Option<i64> {
        let mut t = t_ns;
        for (fault, done) in &mut self.faults {
            match *fault {
                PlayFault::ImuSilence { at_s, for_s } if (at_s..at_s + for_s).contains(&rel_s) => {
                    return None;
                }
                PlayFault::FcReboot { at_s, for_s } if rel_s >= at_s => {
                    if rel_s < at_s + for_s {
                        return None;
                    }
                    // The clock read 0 at `at_s`: it is behind the dataset's by the time then.
                    let behind_ns = t_ns - ((rel_s - at_s) * NS_PER_S).round() as i64;
                    t = t.saturating_sub(behind_ns);
                }
                PlayFault::ImuShift { at_s, shift_s } if imu && rel_s >= at_s && !*done => {
                    *done = true;
                    t = t.saturating_add((shift_s * NS_PER_S).round() as i64);
                }
                _ => {}
            }
        }
        Some(t)
    }

    /// The readings to send for the IMU sample `s` at `rel_s` s into the dataset.
    pub(super) fn imu_readings(&self, s: &mut ImuSample, rel_s: f64) {
        for (fault, _) in &self.faults {
            match *fault {
                PlayFault::ImuNan { at_s, for_s } if (at_s..at_s + for_s).contains(&rel_s) => {
                    s.accel_m_s2 = Vector3::repeat(f64::NAN);
                    s.gyro_rad_s = Vector3::repeat(f64::NAN);
                }
                PlayFault::ImuSaturate { at_s, for_s } if (at_s..at_s + for_s).contains(&rel_s) => {
                    s.accel_m_s2 = Vector3::repeat(SATURATED_ACCEL_M_S2);
                    s.gyro_rad_s = Vector3::repeat(SATURATED_GYRO_RAD_S);
                }
                _ => {}
            }
        }
    }

    /// The NIC time to send (µs, wrapping) for a record with `timestamp_low` at `rel_s`, and
    /// the garbage to send before it.
    pub(super) fn csi(&mut self, timestamp_low: u32, rel_s: f64, garbage: &mut Vec<u8>) -> u32 {
        let mut low = timestamp_low;
        for (fault, done) in &mut self.faults {
            match *fault {
                PlayFault::CsiShift { at_s, shift_s } if rel_s >= at_s && !*done => {
                    *done = true;
                    let shift_us = (shift_s * 1e6).round() as i64;
                    // The 32-bit counter wraps: the shift modulo 2³² µs.
                    low = low.wrapping_add(shift_us.rem_euclid(1 << 32) as u32);
                }
                PlayFault::CsiGarbage { at_s, bytes } if rel_s >= at_s && !*done => {
                    *done = true;
                    let mut rng = ChaCha8Rng::seed_from_u64(GARBAGE_SEED);
                    garbage.extend((0..bytes).map(|_| rng.random::<u8>()));
                }
                _ => {}
            }
        }
        low
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_parse_and_apply() {
        assert_eq!(
            "fc-reboot@22:2".parse(),
            Ok(PlayFault::FcReboot {
                at_s: 22.0,
                for_s: 2.0
            })
        );
        for bad in [
            "fc-reboot@22",
            "x@1:1",
            "imu-silence@1:0",
            "csi-garbage@1:1.5",
        ] {
            assert!(bad.parse::<PlayFault>().is_err(), "{bad}");
        }
        let s = 1_000_000_000;
        let mut f = Faults::new(&[
            "imu-shift@1:4.5".parse().unwrap(),
            "fc-reboot@10:2".parse().unwrap(),
        ]);
        assert_eq!(f.fc_time(100 * s, 0.5, true), Some(100 * s));
        // A barometer reading is not the IMU sample shifted.
        assert_eq!(f.fc_time(101 * s, 1.0, false), Some(101 * s));
        assert_eq!(f.fc_time(101 * s, 1.0, true), Some(105 * s + s / 2));
        assert_eq!(f.fc_time(102 * s, 2.0, true), Some(102 * s));
        assert_eq!(f.fc_time(111 * s, 11.0, true), None);
        assert_eq!(f.fc_time(113 * s, 13.0, false), Some(3 * s));
        let f = Faults::new(&[
            "imu-nan@1:0.5".parse().unwrap(),
            "imu-saturate@2:0.5".parse().unwrap(),
        ]);
        let clean = ImuSample {
            t: crate::time::Timestamp(0),
            gyro_rad_s: Vector3::new(0.1, 0.0, 0.0),
            accel_m_s2: Vector3::new(0.0, 0.0, 9.8),
        };
        let mut x = clean;
        f.imu_readings(&mut x, 0.9);
        assert_eq!(x, clean);
        f.imu_readings(&mut x, 1.2);
        assert!(x.accel_m_s2.x.is_nan() && x.gyro_rad_s.z.is_nan());
        let mut x = clean;
        f.imu_readings(&mut x, 2.4);
        assert!(x.accel_m_s2.norm() > 600.0 && x.gyro_rad_s.norm() > 70.0);
        let mut x = clean;
        f.imu_readings(&mut x, 2.5);
        assert_eq!(x, clean);
        let mut f = Faults::new(&[
            "csi-shift@1:-1000".parse().unwrap(),
            "csi-garbage@2:100".parse().unwrap(),
        ]);
        let mut garbage = vec![];
        assert_eq!(f.csi(5, 0.0, &mut garbage), 5);
        assert_eq!(
            f.csi(5, 1.0, &mut garbage),
            5u32.wrapping_sub(1_000_000_000)
        );
        assert_eq!(f.csi(5, 2.0, &mut garbage), 5);
        assert_eq!(garbage.len(), 100);
        assert_eq!(f.csi(5, 3.0, &mut garbage), 5);
        assert_eq!(garbage.len(), 100);
    }
}
