//! The `[live]` settings of the configuration tree (used by [`crate::live`]): where `wins live` listens, what it sends back, and how long it waits
//! for late inputs (docs/CONFIG.md `[live]`; the shipped example is `configs/live.toml`).

use serde::{Deserialize, Serialize};

use crate::check::Problems;

/// How a CSI record is told to come from one AP of the rig.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ApBy {
    /// By the transmitter address of the 0xC1 frame record the logger writes ahead of it,
    /// matched against the rig's `[[aps]] mac`; a record without one, or from an address no AP
    /// has, is counted and left out.
    #[default]
    Transmitter,
    /// Every record is the rig's only AP (a NIC that hears one AP, or a logger without frame
    /// records); refused for a rig with more than one AP.
    Single,
}

/// What `wins live` sends to the flight controller at every frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseMessage {
    /// MAVLink `ODOMETRY` (#331): position, attitude, velocity, covariance, reset counter.
    #[default]
    Odometry,
    /// MAVLink `VISION_POSITION_ESTIMATE` (#102), for firmware without `ODOMETRY` support.
    VisionPositionEstimate,
}

/// Settings of `wins live` (module doc). Every one is also a command-line option.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LiveConfig {
    /// The rig: a dataset manifest (`dataset.toml` format, docs/DATASET.md) describing the IMU,
    /// the array and its mounting, the channel and the APs (with their `mac`); its logs and IMU
    /// file are not read. Relative to the working directory; empty: given on the command line.
    pub rig: String,
    /// Where the CSI Tool's `log_to_server` connects (TCP; its conventional port is 8090), or,
    /// for a rig whose `[array] card` is `nexmon`, where nexmon_csi's UDP packets arrive (its
    /// port is 5500: `0.0.0.0:5500`), or, for `feitcsi`, the UDP address FeitCSI's records come
    /// back to. The default listens on the loopback only (a logger on the same computer);
    /// `0.0.0.0:PORT` opens it to every network the computer is on, which is said at start.
    pub csi_listen: String,
    /// The IP addresses allowed to connect to `csi_listen` (the NICs' loggers); empty: any.
    /// Others are refused and counted (`csi_refused_connections`).
    pub csi_peers: Vec<String>,
    /// For a rig whose card is `feitcsi`: FeitCSI's command socket (`feitcsi --udp-socket`
    /// listens on UDP port 8008), which `wins live` starts the measurement on and takes the
    /// records from; datagrams from any other host are refused and counted.
    pub feitcsi_server: String,
    /// For a rig whose card is `feitcsi`: the options the measurement starts with, as on
    /// FeitCSI's command line (`-f MHz -w 20|40|80|160 -r NOHT|HT|VHT|HESU`); empty: the rig's
    /// channel, HT (`-f 5180 -w 20 -r HT` for channel 36 at 20 MHz; at 40 MHz the primary
    /// channel 10 MHz below the centre).
    pub feitcsi_options: String,
    /// The flight controller's MAVLink link: `udpin:HOST:PORT` (listen and answer the vehicle),
    /// `udpout:HOST:PORT`, `tcp:HOST:PORT`, `tcpin:HOST:PORT` or `serial:DEVICE:BAUD`. The
    /// default listens on the loopback only (a router such as mavlink-router on the same
    /// computer).
    pub mavlink: String,
    /// A file holding the MAVLink 2 signing key shared with the flight controller (32 raw bytes,
    /// PX4's 40-byte key file, or 64 hex digits; docs/LIVE.md "Security"); empty: no signing.
    /// With a key every message sent is signed and every message received must be signed with
    /// it: unsigned, wrongly signed and replayed ones are refused and counted
    /// (`stats.json`'s `mavlink_signing`). Relative to the working directory.
    pub mavlink_key: String,
    /// How a CSI record's AP is told.
    pub ap_by: ApBy,
    /// The message sent at every frame.
    pub message: PoseMessage,
    /// MAVLink system id of the vehicle (usually 1): the poses are sent with it, and inputs are
    /// taken only from it.
    pub system_id: u8,
    /// MAVLink component id the poses are sent with (197: `MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY`).
    pub component_id: u8,
    /// MAVLink component id of the flight controller whose IMU and barometer are taken (1:
    /// `MAV_COMP_ID_AUTOPILOT1`; 0: any component of the vehicle). Messages from any other
    /// system or component are counted (`other_sender`) and left out.
    pub fc_component_id: u8,
    /// How long an input may arrive after its own time and still be used, ms: inputs are merged
    /// in time order, and a stream is waited for this long before the others pass it. The poses
    /// leave this much behind the flight (set the flight controller's vision delay to it plus
    /// the link's latency).
    pub max_latency_ms: f64,
    /// How much longer the CSI link's least delay is than the flight controller link's, ms:
    /// subtracted from every CSI record's time. The clocks are related through the arrivals,
    /// which place each clock late by its link's least delay; only the difference matters, and
    /// no arrival can show it (measure it once for a set-up, or leave 0 when both links are
    /// local and fast: their least delays are then within a fraction of a millisecond).
    pub csi_extra_latency_ms: f64,
    /// How far behind its clock's line a sample's time may lie and still be a late arrival
    /// (which the merger places or counts late) rather than a jump of that clock (an outlier
    /// or the start of a re-lock, `crate::live::clock::ClockTrack`); and a CSI record whose time
    /// lands further than this from the flight controller's present is dropped and counted, s.
    pub max_clock_jump_s: f64,
    /// Seconds between status lines on stderr (0: none).
    pub status_interval_s: f64,
    /// Stop by itself after this many seconds without any input, once inputs came (0: run until
    /// interrupted).
    pub idle_exit_s: f64,
    /// Use the barometer (`HIGHRES_IMU`'s pressure, or `SCALED_PRESSURE`) when the flight
    /// controller sends it (its first second tells) and `pipeline.use_barometer` is on.
    pub barometer: bool,
    /// `RAW_IMU` accelerometer scale, m/s² per count (0: `RAW_IMU` is refused, it has no units).
    pub raw_accel_m_s2_per_count: f64,
    /// `RAW_IMU` gyroscope scale, rad/s per count (0: refused likewise).
    pub raw_gyro_rad_s_per_count: f64,
    /// Write every input as a dataset folder (`recording/` in the output) that `wins run` replays.
    pub record: bool,
}

impl Default for LiveConfig {
    fn default() -> Self {
        Self {
            rig: String::new(),
            csi_listen: "127.0.0.1:8090".into(),
            csi_peers: Vec::new(),
            feitcsi_server: "127.0.0.1:8008".into(),
            feitcsi_options: String::new(),
            mavlink: "udpin:127.0.0.1:14540".into(),
            mavlink_key: String::new(),
            ap_by: ApBy::Transmitter,
            message: PoseMessage::Odometry,
            system_id: 1,
            component_id: 197,
            fc_component_id: 1,
            max_latency_ms: 20.0,
            csi_extra_latency_ms: 0.0,
            max_clock_jump_s: 5.0,
            status_interval_s: 1.0,
            idle_exit_s: 0.0,
            barometer: true,
            raw_accel_m_s2_per_count: 0.0,
            raw_gyro_rad_s_per_count: 0.0,
            record: true,
        }
    }
}

impl LiveConfig {
    /// The inputs that listen on every interface (`0.0.0.0`, `::`): anyone who reaches the
    /// computer's networks can connect to them. Named as `live.KEY = "VALUE"`; empty when both
    /// listen on one address (the loopback by default) or connect out.
    pub fn open_to_every_network(&self) -> Vec<String> {
        let mut open = Vec::new();
        if host_is_unspecified(self.csi_listen.rsplit_once(':').map_or("", |(h, _)| h)) {
            open.push(format!("live.csi_listen = {:?}", self.csi_listen));
        }
        let mavlink_host = match self.mavlink.split_once(':') {
            Some(("udpin" | "tcpin", rest)) => rest.rsplit_once(':').map_or("", |(h, _)| h),
            _ => "",
        };
        if host_is_unspecified(mavlink_host) {
            open.push(format!("live.mavlink = {:?}", self.mavlink));
        }
        open
    }

    /// Every setting out of its range, keys prefixed with `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.in_range(prefix, "max_latency_ms", self.max_latency_ms, 0.0, 2000.0);
        p.in_range(
            prefix,
            "csi_extra_latency_ms",
            self.csi_extra_latency_ms,
            -1000.0,
            1000.0,
        );
        p.in_range(
            prefix,
            "max_clock_jump_s",
            self.max_clock_jump_s,
            0.01,
            3600.0,
        );
        p.in_range(
            prefix,
            "status_interval_s",
            self.status_interval_s,
            0.0,
            3600.0,
        );
        p.in_range(prefix, "idle_exit_s", self.idle_exit_s, 0.0, 86_400.0);
        p.in_range(
            prefix,
            "raw_accel_m_s2_per_count",
            self.raw_accel_m_s2_per_count,
            0.0,
            1.0,
        );
        p.in_range(
            prefix,
            "raw_gyro_rad_s_per_count",
            self.raw_gyro_rad_s_per_count,
            0.0,
            1.0,
        );
        for peer in &self.csi_peers {
            p.require(
                peer.parse::<std::net::IpAddr>().is_ok(),
                prefix,
                "csi_peers",
                format!("{peer:?} is not an IP address"),
            );
        }
        p.require(
            self.csi_listen.parse::<std::net::SocketAddr>().is_ok(),
            prefix,
            "csi_listen",
            format!(
                "{:?} is not HOST:PORT (an IP address and a port)",
                self.csi_listen
            ),
        );
        p.require(
            self.feitcsi_server.parse::<std::net::SocketAddr>().is_ok(),
            prefix,
            "feitcsi_server",
            format!(
                "{:?} is not HOST:PORT (an IP address and a port)",
                self.feitcsi_server
            ),
        );
        p
    }
}

/// Whether `host` is the address of every interface.
fn host_is_unspecified(host: &str) -> bool {
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host.parse::<std::net::IpAddr>()
        .is_ok_and(|ip| ip.is_unspecified())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_listen_on_the_loopback_and_every_interface_is_named() {
        assert!(LiveConfig::default().open_to_every_network().is_empty());
        let open = LiveConfig {
            csi_listen: "0.0.0.0:8090".into(),
            mavlink: "udpin:[::]:14540".into(),
            ..LiveConfig::default()
        };
        assert_eq!(
            open.open_to_every_network(),
            vec![
                "live.csi_listen = \"0.0.0.0:8090\"".to_string(),
                "live.mavlink = \"udpin:[::]:14540\"".to_string()
            ]
        );
        // Connecting out, or a serial port, listens nowhere.
        for mavlink in [
            "udpout:0.0.0.0:14540",
            "tcp:0.0.0.0:5760",
            "serial:/dev/ttyACM0:921600",
        ] {
            let c = LiveConfig {
                mavlink: mavlink.into(),
                ..LiveConfig::default()
            };
            assert!(c.open_to_every_network().is_empty(), "{mavlink}");
        }
        let one = LiveConfig {
            csi_listen: "192.168.1.20:8090".into(),
            ..LiveConfig::default()
        };
        assert!(one.open_to_every_network().is_empty());
    }
}
