//! Inputs in (module doc of [`super`]): the flight controller's events and the NICs' records,
//! their times related to the flight controller's clock, each record's AP told, all handed to the
//! merger, with what is left out counted.

use super::{LiveSession, Nic, SILENCE_NOTICE_NS};
use crate::csi::intel5300::MacAddress;
use crate::live::clock::ClockTrack;
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
            FcEvent::Imu {
                mut sample,
                arrival_ns,
            } => {
                self.stats.imu_received += 1;
                // The sample's time on the flight controller's timeline, or none while it is
                // held (an outlier, or the start of a re-lock). A sample out of order (a
                // reordered datagram) goes to the merger, which places it or counts it late.
                let pushed = self.fc.push(sample.t.as_nanos(), arrival_ns);
                self.stats.fc_clock_outliers += pushed.outliers;
                self.stats.imu_clock_locking += pushed.dropped_unlocked + pushed.locked_on;
                let Some(t) = pushed.t_ns.map(Timestamp) else {
                    return;
                };
                if pushed.relocked {
                    self.stats.fc_clock_relocks += 1;
                }
                self.say_imu_gap(t, pushed.relocked);
                sample.t = t;
                self.imu_last = Some(self.imu_last.map_or(t, |last| last.max(t)));
                self.push_merged(Merged::Imu(sample));
            }
            FcEvent::Baro {
                t,
                altitude_m,
                arrival_ns: _,
            } => {
                self.stats.baro_received += 1;
                // On the timeline of the flight controller's clock as its IMU last placed it
                // (the barometer does not move the clock's line).
                let t = Timestamp(t.as_nanos().saturating_add(self.fc.epoch_offset_ns()));
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
                        clock: ClockTrack::new(self.track),
                        ..Nic::default()
                    },
                );
            }
            CsiEvent::Disconnected { conn, clean, .. } => {
                self.stats.csi_disconnects += 1;
                self.stats.csi_closed += u64::from(clean);
                self.nics.remove(&conn);
                self.ap_streams.retain(|_, c| *c != conn);
            }
            CsiEvent::Refused { .. } => self.stats.csi_refused_connections += 1,
            CsiEvent::NotCsi { bytes, .. } => {
                self.stats.csi_skips += 1;
                self.stats.csi_skipped_bytes += bytes;
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
                // The AP's stream is the first open connection that brought its records.
                let owner = *self.ap_streams.entry(ap).or_insert(conn);
                if owner != conn {
                    if self.nics.get(&owner).is_some_and(|n| n.connected) {
                        self.stats.csi_second_stream += 1;
                        return;
                    }
                    self.ap_streams.insert(ap, conn);
                }
                let Some(t) = self.csi_time(conn, record.nic_time_ns(), arrival_ns) else {
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
    /// arrival (module doc); `None` (counted) before the flight controller's clock is known,
    /// while the connection's clock locks or re-locks, for an outlier, or when the record
    /// lands further than `max_clock_jump_s` from the present.
    fn csi_time(&mut self, conn: u64, nic_ns: i64, arrival_ns: i64) -> Option<Timestamp> {
        let Some(fc_now) = self.fc.to_timeline(arrival_ns) else {
            self.stats.csi_before_fc_clock += 1;
            return None;
        };
        let track = self.track;
        let nic = self.nics.entry(conn).or_insert_with(|| Nic {
            clock: ClockTrack::new(track),
            ..Nic::default()
        });
        let pushed = nic.clock.push(nic_ns, arrival_ns);
        self.stats.nic_clock_outliers += pushed.outliers;
        self.stats.csi_clock_warmup += pushed.dropped_unlocked + pushed.locked_on;
        let nic_t = pushed.t_ns?;
        if pushed.relocked {
            self.stats.nic_clock_relocks += 1;
            let notice = format!(
                "t {:.1} s: nic{conn}'s clock jumped; re-locked on its records",
                fc_now as f64 * 1e-9
            );
            self.stats.notices.push(notice);
        }
        let t = nic
            .clock
            .to_host(nic_t)
            .and_then(|h| self.fc.to_timeline(h))?;
        if (t - fc_now).abs() > self.max_jump_ns {
            self.stats.csi_far_from_present += 1;
            return None;
        }
        Some(Timestamp((t - self.csi_extra_ns).div_euclid(1000) * 1000))
    }

    /// Says in words, once, that the IMU stopped long enough to stop the poses (a restart of the
    /// flight controller's clock, or a silence), when the sample at `t` ends it.
    fn say_imu_gap(&mut self, t: Timestamp, relocked: bool) {
        let Some(last) = self.imu_last else {
            return;
        };
        let gap_ns = t.as_nanos() - last.as_nanos();
        if !relocked && gap_ns < SILENCE_NOTICE_NS {
            return;
        }
        let what = if relocked {
            "the flight controller's clock restarted (re-locked)"
        } else {
            "the IMU came back"
        };
        let notice = format!(
            "t {:.1} s: {what} after {:.1} s without IMU: no pose across the gap; the \
             estimator's hole recovery takes over",
            t.as_secs_f64(),
            gap_ns as f64 * 1e-9
        );
        self.stats.notices.push(notice);
    }

    fn push_merged(&mut self, input: Merged) {
        if !self.merger.push(input) {
            self.stats.late += 1;
        }
    }
}
