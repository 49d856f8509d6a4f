//! Inputs from several links put back in time order before they reach the pipeline.
//!
//! The IMU comes over MAVLink, the CSI over TCP, each late by its own link's delay; the pipeline
//! takes them in time order. The merger holds what arrived and releases, in the order
//! `wins run` merges a dataset (time, then packet before barometer before IMU, then AP; so that a
//! recording of the released inputs replays the same), everything up to a watermark the session
//! moves forward. An input older than what was already released is late: dropped and counted.

use std::collections::BTreeMap;

use crate::csi::logged::Logged;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// One input on the flight controller's clock.
#[derive(Clone, Debug, PartialEq)]
pub enum Merged {
    /// A CSI record of AP `ap` at `t`.
    Csi {
        /// The rig's AP index.
        ap: usize,
        /// Its time on the flight controller's clock (whole microseconds).
        t: Timestamp,
        /// The record as received (its clock still the NIC's).
        record: Box<Logged>,
    },
    /// A barometric altitude.
    Baro {
        /// Time.
        t: Timestamp,
        /// Altitude above the barometer's datum, m.
        altitude_m: f64,
    },
    /// An IMU sample.
    Imu(ImuSample),
}

impl Merged {
    /// Its time.
    pub fn t(&self) -> Timestamp {
        match self {
            Self::Csi { t, .. } | Self::Baro { t, .. } => *t,
            Self::Imu(s) => s.t,
        }
    }

    /// The merge key: time, then kind (packet 0, barometer 1, IMU 2, as `wins run` orders a
    /// dataset), then AP.
    fn key(&self) -> (Timestamp, u8, usize) {
        match self {
            Self::Csi { t, ap, .. } => (*t, 0, *ap),
            Self::Baro { t, .. } => (*t, 1, 0),
            Self::Imu(s) => (s.t, 2, 0),
        }
    }
}

/// The reorder buffer (module doc).
#[derive(Debug, Default)]
pub struct Merger {
    held: BTreeMap<(Timestamp, u8, usize, u64), Merged>,
    seq: u64,
    released_up_to: Option<(Timestamp, u8, usize)>,
    late: u64,
}

impl Merger {
    /// An empty merger.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes an input; `false` (and counted) when it is older than what was already released.
    pub fn push(&mut self, input: Merged) -> bool {
        let key = input.key();
        if self.released_up_to.is_some_and(|r| key < r) {
            self.late += 1;
            return false;
        }
        self.seq += 1;
        self.held.insert((key.0, key.1, key.2, self.seq), input);
        true
    }

    /// Every held input at or before `watermark`, in merge order.
    pub fn release(&mut self, watermark: Timestamp) -> Vec<Merged> {
        let mut out = Vec::new();
        while let Some(entry) = self.held.first_entry() {
            if entry.key().0 > watermark {
                break;
            }
            let input = entry.remove();
            self.released_up_to = Some(input.key());
            out.push(input);
        }
        out
    }

    /// Everything still held, in merge order (at the end of the session).
    pub fn drain(&mut self) -> Vec<Merged> {
        self.release(Timestamp(i64::MAX))
    }

    /// Inputs held now.
    pub fn held(&self) -> usize {
        self.held.len()
    }

    /// Inputs dropped as late so far.
    pub fn late(&self) -> u64 {
        self.late
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    fn imu(t_ms: i64) -> Merged {
        Merged::Imu(ImuSample {
            t: Timestamp(t_ms * 1_000_000),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::zeros(),
        })
    }

    fn baro(t_ms: i64) -> Merged {
        Merged::Baro {
            t: Timestamp(t_ms * 1_000_000),
            altitude_m: 1.0,
        }
    }

    #[test]
    fn releases_in_time_then_kind_order_up_to_the_watermark_and_drops_late_inputs() {
        let mut m = Merger::new();
        for input in [imu(10), imu(5), baro(5), imu(20), baro(15)] {
            assert!(m.push(input));
        }
        let out = m.release(Timestamp(10 * 1_000_000));
        let keys: Vec<(i64, u8)> = out
            .iter()
            .map(|i| (i.t().as_nanos() / 1_000_000, i.key().1))
            .collect();
        assert_eq!(keys, vec![(5, 1), (5, 2), (10, 2)]);
        assert_eq!(m.held(), 2);
        // Older than what left: late.
        assert!(!m.push(imu(7)));
        // At the released time but ordered after it (an IMU after a barometer at 5 ms went):
        // late too; a barometer reading at 10 ms sorts before the IMU sample released there.
        assert!(!m.push(baro(10)));
        assert!(m.push(imu(12)));
        assert_eq!(m.late(), 2);
        let rest: Vec<i64> = m
            .drain()
            .iter()
            .map(|i| i.t().as_nanos() / 1_000_000)
            .collect();
        assert_eq!(rest, vec![12, 15, 20]);
        assert_eq!(m.held(), 0);
    }
}
