//! A live session's clocks as the rest of `wins live` reads them: the relations of the flight
//! controller's and the NICs' clocks to the host's (module doc of [`super`], "Clocks").

use super::{ClockReport, LiveSession};
use crate::time::Timestamp;

impl LiveSession {
    /// The clocks now.
    pub fn clocks(&self) -> ClockReport {
        let mut nic: Vec<(u64, Option<i64>, Option<f64>)> = self
            .nics
            .iter()
            .map(|(c, n)| (*c, n.clock.offset_ns(), n.clock.drift_ppm()))
            .collect();
        nic.sort_by_key(|n| n.0);
        ClockReport {
            fc_offset_ns: self.fc.offset_ns(),
            fc_drift_ppm: self.fc.drift_ppm(),
            nic,
        }
    }

    /// The newest IMU time.
    pub fn imu_last(&self) -> Option<Timestamp> {
        self.imu_last
    }

    /// The flight controller's clock (its timeline) at host time `host_ns`, once known.
    pub fn fc_time(&self, host_ns: i64) -> Option<Timestamp> {
        self.fc.to_timeline(host_ns).map(Timestamp)
    }

    /// Host time of flight controller time `t` (on its timeline), once known.
    pub fn host_time(&self, t: Timestamp) -> Option<i64> {
        self.fc.to_host(t.as_nanos())
    }

    /// The session's times (the flight controller's timeline) minus its clock's reading now,
    /// ns: 0 until it restarts; subtracted from a pose's time in the messages sent.
    pub fn fc_epoch_offset_ns(&self) -> i64 {
        self.fc.epoch_offset_ns()
    }
}
