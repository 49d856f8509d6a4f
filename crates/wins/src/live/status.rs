//! The status line of `wins live` and the latency statistics behind it.

use serde::Serialize;

use super::mavlink::link::LinkCounts;
use super::mavlink::signing::SigningCounts;
use super::session::{ClockReport, LiveStats};
use crate::pipeline::EstimateState;

/// A status line's content (the binary prints it).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LiveStatus {
    /// The flight controller's time now, s (`None` before its first IMU sample).
    pub fc_time_s: Option<f64>,
    /// IMU samples per second since the last status.
    pub imu_hz: f64,
    /// CSI records used per second since the last status, per AP (name, rate).
    pub packets_hz: Vec<(String, f64)>,
    /// Poses sent per second since the last status.
    pub poses_hz: f64,
    /// What the estimate is doing.
    pub estimate: EstimateState,
    /// The clocks.
    pub clocks: ClockReport,
    /// Median and 99th percentile of the poses' age when sent (host time of sending minus the
    /// pose's time), ms, since the last status.
    pub latency_ms: Option<(f64, f64)>,
    /// Every count so far.
    pub stats: LiveStats,
    /// The MAVLink link's signed traffic so far (with a signing key).
    pub mavlink_signing: Option<SigningCounts>,
    /// What arrived on the MAVLink link so far.
    pub mavlink_link: LinkCounts,
    /// The notices since the last status (faults that stopped the poses, in words), printed
    /// each on its own line above the status line.
    pub new_notices: Vec<String>,
}

impl std::fmt::Display for LiveStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for notice in &self.new_notices {
            writeln!(f, "{notice}")?;
        }
        match self.fc_time_s {
            Some(t) => write!(f, "t {t:.1} s")?,
            None => write!(f, "waiting for the flight controller's IMU")?,
        }
        write!(f, " | IMU {:.0} Hz |", self.imu_hz)?;
        for (name, hz) in &self.packets_hz {
            write!(f, " {name} {hz:.0} pkt/s")?;
        }
        if let Some(o) = self.clocks.fc_offset_ns {
            write!(f, " | fc clock {:+.3} s", o as f64 * 1e-9)?;
        }
        for (conn, offset, drift) in &self.clocks.nic {
            if let (Some(o), Some(d)) = (offset, drift) {
                write!(f, " nic{conn} {:+.3} s {d:+.0} ppm", *o as f64 * 1e-9)?;
            }
        }
        match self.estimate {
            EstimateState::Starting => write!(f, " | starting")?,
            EstimateState::Deciding {
                converged: 0,
                hypotheses,
            } => write!(f, " | not converged ({hypotheses} chain-offset hypotheses)")?,
            EstimateState::Deciding {
                converged,
                hypotheses,
            } => write!(
                f,
                " | converged, deciding the chain offsets ({converged} of {hypotheses} \
                 hypotheses converged; poses held)"
            )?,
            EstimateState::Tracking { converged: true } => write!(f, " | converged")?,
            EstimateState::Tracking { converged: false } => write!(f, " | not converged")?,
        }
        write!(f, ", {:.0} poses/s", self.poses_hz)?;
        if let Some((p50, p99)) = self.latency_ms {
            write!(f, " | latency {p50:.1}/{p99:.1} ms (p50/p99)")?;
        }
        let s = &self.stats;
        let dropped = s.csi_disconnects.saturating_sub(s.csi_closed);
        let events = s.late
            + s.csi_skips
            + s.csi_no_transmitter
            + s.csi_unknown_transmitter
            + s.nic_clock_outliers
            + s.nic_clock_relocks
            + s.fc_clock_outliers
            + s.fc_clock_relocks
            + s.fc_refused
            + dropped;
        if events > 0 {
            write!(
                f,
                " | late {} garbage {} unknown AP {} clock outliers fc {} nic {} re-locks fc {} nic {} \
                 dropped links {}",
                s.late,
                s.csi_skips,
                s.csi_no_transmitter + s.csi_unknown_transmitter,
                s.fc_clock_outliers,
                s.nic_clock_outliers,
                s.fc_clock_relocks,
                s.nic_clock_relocks,
                dropped
            )?;
        }
        if s.csi_closed > 0 {
            write!(f, " | CSI links closed by the peer {}", s.csi_closed)?;
        }
        let l = &self.mavlink_link;
        if l.any_fault() {
            write!(
                f,
                " | MAVLink garbage {} B bad CRC {} links lost {}",
                l.frames.garbage_bytes, l.frames.bad_crc, l.connections_lost
            )?;
        }
        if let Some(c) = self.mavlink_signing.filter(|c| c.refused() > 0) {
            write!(
                f,
                " | MAVLink refused: unsigned {} bad signature {} replayed {} stale {}",
                c.unsigned, c.bad_signature, c.replayed, c.stale
            )?;
        }
        Ok(())
    }
}

/// Ages of the poses sent over a whole run, in 0.1 ms bins up to 10 s (the memory does not
/// grow with the run).
#[derive(Debug)]
pub(crate) struct Histogram {
    bins: Vec<u64>,
    count: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Self {
            bins: vec![0; 100_001],
            count: 0,
        }
    }
}

impl Histogram {
    const BIN_MS: f64 = 0.1;

    pub(crate) fn push(&mut self, ms: f64) {
        let last = self.bins.len() - 1;
        let i = ((ms.max(0.0) / Self::BIN_MS).round() as usize).min(last);
        if let Some(b) = self.bins.get_mut(i) {
            *b += 1;
            self.count += 1;
        }
    }

    /// Median and 99th percentile, ms (to the bin).
    pub(crate) fn percentiles(&self) -> Option<(f64, f64)> {
        if self.count == 0 {
            return None;
        }
        let at = |q: f64| {
            let rank = ((self.count - 1) as f64 * q).round() as u64;
            let mut seen = 0;
            for (i, n) in self.bins.iter().enumerate() {
                seen += n;
                if seen > rank {
                    return i as f64 * Self::BIN_MS;
                }
            }
            (self.bins.len() - 1) as f64 * Self::BIN_MS
        };
        Some((at(0.5), at(0.99)))
    }
}

/// Median and 99th percentile.
pub(crate) fn percentiles(values: &mut [f64]) -> Option<(f64, f64)> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    Some((at(0.5), at(0.99)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refused_mavlink_messages_are_said_only_when_there_are_some() {
        let mut status = LiveStatus {
            mavlink_signing: Some(SigningCounts {
                accepted: 100,
                signed_out: 50,
                ..SigningCounts::default()
            }),
            ..LiveStatus::default()
        };
        assert!(!status.to_string().contains("MAVLink refused"));
        status.mavlink_signing = Some(SigningCounts {
            unsigned: 3,
            bad_signature: 2,
            replayed: 1,
            ..SigningCounts::default()
        });
        let line = status.to_string();
        assert!(
            line.ends_with(" | MAVLink refused: unsigned 3 bad signature 2 replayed 1 stale 0"),
            "{line}"
        );
    }

    #[test]
    fn a_converged_hypothesis_is_said_while_the_chain_offsets_are_decided() {
        let mut status = LiveStatus::default();
        assert!(status.to_string().contains("| starting,"));
        status.estimate = EstimateState::Deciding {
            converged: 0,
            hypotheses: 4,
        };
        assert!(
            status
                .to_string()
                .contains("| not converged (4 chain-offset")
        );
        status.estimate = EstimateState::Deciding {
            converged: 2,
            hypotheses: 4,
        };
        let line = status.to_string();
        assert!(
            line.contains("| converged, deciding the chain offsets (2 of 4"),
            "{line}"
        );
        status.estimate = EstimateState::Tracking { converged: false };
        assert!(status.to_string().contains("| not converged,"));
        status.estimate = EstimateState::Tracking { converged: true };
        assert!(status.to_string().contains("| converged,"));
    }

    #[test]
    fn a_csi_link_closed_after_a_whole_record_is_not_a_dropped_link() {
        let mut status = LiveStatus::default();
        status.stats.csi_disconnects = 1;
        status.stats.csi_closed = 1;
        let line = status.to_string();
        assert!(!line.contains("dropped links"), "{line}");
        assert!(
            line.ends_with(" | CSI links closed by the peer 1"),
            "{line}"
        );
        status.stats.csi_disconnects = 3;
        let line = status.to_string();
        assert!(line.contains("dropped links 2"), "{line}");
    }

    #[test]
    fn link_faults_are_said_and_unknown_messages_are_not() {
        let mut status = LiveStatus::default();
        status.mavlink_link.frames.unknown_messages = 40;
        assert!(!status.to_string().contains("MAVLink garbage"));
        status.mavlink_link.frames.garbage_bytes = 300;
        status.mavlink_link.frames.bad_crc = 2;
        status.mavlink_link.connections_lost = 1;
        let line = status.to_string();
        assert!(
            line.ends_with(" | MAVLink garbage 300 B bad CRC 2 links lost 1"),
            "{line}"
        );
    }
}
