//! Inputs in (module doc of [`super`]): the flight controller's events and the NICs' records,
//! their times related to the flight controller's clock, each record's AP told, all handed to the
//! merger, with what is left out counted.

use super::{CLOCK_WARMUP_RECORDS, LiveSession, Nic};
use crate::csi::intel5300::MacAddress;
use crate::live::merge::Merged;
use crate::live::{ApBy, CsiEvent, FcEvent, LiveInput};
use crate::time::Timestamp;

impl LiveSession {
    /// Takes one input (nothing reaches the pipeline before [`advance`](Self::advance)).
    pub fn handle(&mut self, input: LiveInput) {
        match input {
            LiveInput::Fc(event) => self.handle_fc(event),
            LiveInput::Csi(event) => self.handle_csi(event),
        }
    }

    fn handle_fc(&mut self, event: FcEvent) {
        match event {
            FcEvent::Imu { sample, arrival_ns } => {
                self.stats.imu_received += 1;
                let t = sample.t;
                // A sample out of order (a reordered datagram) goes to the merger, which
                // places it or counts it late; a jump beyond `max_clock_jump_s` either way is the
                // flight controller's clock restarting, which the estimator cannot follow.
                if self
                    .imu_last
                    .is_some_and(|last| (t.as_nanos() - last.as_nanos()).abs() > self.max_jump_ns)
                {
                    self.stats.imu_time_jumps += 1;
                    return;
                }
                self.fc.push(t.as_nanos(), arrival_ns);
                self.imu_last = Some(self.imu_last.map_or(t, |last| last.max(t)));
                self.push_merged(Merged::Imu(sample));
            }
            FcEvent::Baro {
                t,
                altitude_m,
                arrival_ns: _,
            } => {
                self.stats.baro_received += 1;
                if self.use_baro {
                    self.push_merged(Merged::Baro { t, altitude_m });
                }
            }
            FcEvent::Refused(_) => self.stats.fc_refused += 1,
            FcEvent::LinkError(_) => self.stats.fc_link_errors += 1,
        }
    }

    fn handle_csi(&mut self, event: CsiEvent) {
        match event {
            CsiEvent::Connected { conn, .. } => {
                self.stats.csi_connections += 1;
                self.nics.insert(
                    conn,
                    Nic {
                        connected: true,
                        ..Nic::default()
                    },
                );
            }
            CsiEvent::Disconnected { conn, .. } => {
                self.stats.csi_disconnects += 1;
                self.nics.remove(&conn);
            }
            CsiEvent::Skipped { skip, .. } => {
                if matches!(
                    skip.reason,
                    crate::csi::intel5300::SkipReason::NonCsi {
                        code: crate::csi::intel5300::CODE_FRAME
                    }
                ) {
                    self.stats.csi_frame_records += 1;
                } else {
                    self.stats.csi_skips += 1;
                    self.stats.csi_skipped_bytes += skip.len;
                }
            }
            CsiEvent::Record {
                conn,
                record,
                transmitter,
                arrival_ns,
            } => {
                self.stats.csi_records += 1;
                let Some(ap) = self.ap_of(transmitter) else {
                    return;
                };
                let Some(t) = self.csi_time(conn, record.timestamp.as_nanos(), arrival_ns) else {
                    return;
                };
                if let Some(nic) = self.nics.get_mut(&conn) {
                    nic.last_t = Some(nic.last_t.map_or(t, |l| l.max(t)));
                }
                self.push_merged(Merged::Csi { ap, t, record });
            }
        }
    }

    /// The AP of a record from `transmitter`, or `None` (counted).
    fn ap_of(&mut self, transmitter: Option<MacAddress>) -> Option<usize> {
        match self.ap_by {
            ApBy::Single => Some(0),
            ApBy::Transmitter => {
                let Some(tx) = transmitter else {
                    self.stats.csi_no_transmitter += 1;
                    return None;
                };
                let ap = self.macs.iter().position(|m| *m == Some(tx));
                if ap.is_none() {
                    self.stats.csi_unknown_transmitter += 1;
                }
                ap
            }
        }
    }

    /// A record's time on the flight controller's clock, whole µs, from its NIC time and
    /// arrival (module doc); `None` (counted) before the flight controller's clock is known or
    /// while the connection's clock relation warms up.
    fn csi_time(&mut self, conn: u64, nic_ns: i64, arrival_ns: i64) -> Option<Timestamp> {
        let Some(fc_now) = self.fc.to_remote(arrival_ns) else {
            self.stats.csi_before_fc_clock += 1;
            return None;
        };
        let nic = self.nics.entry(conn).or_default();
        nic.clock.push(nic_ns, arrival_ns);
        if nic.clock.samples() <= CLOCK_WARMUP_RECORDS {
            self.stats.csi_clock_warmup += 1;
            return None;
        }
        let mut t = nic
            .clock
            .to_host(nic_ns)
            .and_then(|h| self.fc.to_remote(h))?;
        if (t - fc_now).abs() > self.max_jump_ns {
            self.stats.nic_clock_jumps += 1;
            nic.clock.reset();
            nic.clock.push(nic_ns, arrival_ns);
            t = nic
                .clock
                .to_host(nic_ns)
                .and_then(|h| self.fc.to_remote(h))?;
        }
        Some(Timestamp((t - self.csi_extra_ns).div_euclid(1000) * 1000))
    }

    fn push_merged(&mut self, input: Merged) {
        if !self.merger.push(input) {
            self.stats.late += 1;
        }
    }
}
