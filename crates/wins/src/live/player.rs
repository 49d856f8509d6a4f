//! `wins replay --realtime`: a dataset played as a drone would send it, to test `wins live` on
//! one machine or to try a flight controller's side in simulation.
//!
//! The dataset's inputs go out in its merge order at the pace of their times (scaled by
//! `speed`): the IMU as MAVLink `HIGHRES_IMU` (`time_usec` the IMU clock, standing in for the
//! flight controller's) and the barometer as `HIGHRES_IMU` with only the pressure (the standard
//! atmosphere's pressure at the altitude, the inverse of
//! [`pressure_altitude_m`]) over UDP to the MAVLink address; the CSI as a CSI Tool
//! `log_to_server` stream over TCP, each CSI record with its NIC timestamp as logged and, ahead
//! of it, a 0xC1 frame record naming the AP's `mac` as its transmitter. A CSI connection that
//! fails is opened again with a growing backoff (0.1 s doubling to 2 s) while the records of
//! that time are counted as not sent. What comes back on the MAVLink socket (the poses) is
//! counted and, when asked, written raw to a capture file that pymavlink reads.
//!
//! Faults can be put into the streams ([`faults`]: a misdated message, a silent or rebooting
//! flight controller, garbage in a CSI stream).
//!
//! `start_at` (a Unix time) makes several players (this one and a pymavlink script playing the
//! flight controller, say) start the same dataset time at the same instant.

pub mod faults;

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use ::mavlink::MavHeader;
use ::mavlink::dialects::common::{HIGHRES_IMU_DATA, HighresImuUpdatedFlags, MavMessage};

use super::mavlink::inbound::{STANDARD_SEA_LEVEL_PA, pressure_altitude_m};
use crate::csi::Received;
use crate::csi::intel5300::{MacAddress, encode_frame_record, encode_record};
use crate::dataset::stream::{DatasetEvent, DatasetStream};
use crate::dataset::{DatasetError, parse_mac};
use crate::imu::ImuSample;
use faults::Faults;
pub use faults::PlayFault;

/// Which inputs a player sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Streams {
    /// The CSI over TCP.
    pub csi: bool,
    /// The IMU and barometer over MAVLink.
    pub imu: bool,
}

/// What to play, where, how fast.
#[derive(Clone, Debug)]
pub struct PlayOptions {
    /// The dataset folder.
    pub dataset: PathBuf,
    /// Where `wins live` listens for CSI.
    pub csi_connect: SocketAddr,
    /// Where `wins live` listens for MAVLink (its `udpin` address).
    pub mavlink_to: SocketAddr,
    /// Play speed (1: real time).
    pub speed: f64,
    /// The Unix time at which the dataset's first input is played (`None`: now).
    pub start_at: Option<f64>,
    /// Which inputs to send.
    pub streams: Streams,
    /// Write every MAVLink datagram received back to this file, raw.
    pub capture: Option<PathBuf>,
    /// Faults put into the streams ([`faults`]).
    pub faults: Vec<PlayFault>,
    /// The MAVLink system id the messages are sent from (the flight controller's is 1; another
    /// plays a second vehicle or a stranger on the network).
    pub system_id: u8,
}

/// Why a play failed.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    /// The dataset cannot be read.
    #[error(transparent)]
    Dataset(#[from] Box<DatasetError>),
    /// A setting cannot be used.
    #[error("{0}")]
    Setup(String),
    /// A socket or file failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The cause.
        source: io::Error,
    },
}

/// What a play did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PlaySummary {
    /// IMU samples sent.
    pub imu_sent: u64,
    /// Barometer readings sent.
    pub baro_sent: u64,
    /// CSI records sent.
    pub csi_sent: u64,
    /// CSI records not sent (no connection at their time).
    pub csi_not_sent: u64,
    /// CSI connections opened (the first, then each reconnection).
    pub csi_connects: u64,
    /// MAVLink datagrams received back.
    pub mavlink_received: u64,
    /// The dataset's span played, s.
    pub played_s: f64,
    /// How late the inputs went out at worst, behind their time, s.
    pub max_lag_s: f64,
}

/// The standard atmosphere's pressure at `altitude_m` (the inverse of
/// [`pressure_altitude_m`]), Pa.
pub fn pressure_at_altitude_pa(altitude_m: f64, sea_level_pa: f64) -> f64 {
    // h = 44 330.8 (1 − (p/p₀)^0.190263)  ⇒  p = p₀ (1 − h / 44 330.8)^(1/0.190263)
    let h0 = pressure_altitude_m(0.0, 1.0);
    let exponent = (1.0 - pressure_altitude_m(0.5, 1.0) / h0).ln() / 0.5f64.ln();
    sea_level_pa * (1.0 - altitude_m / h0).powf(1.0 / exponent)
}

/// The CSI connection, opened again with a backoff after a failure.
struct CsiLink {
    to: SocketAddr,
    stream: Option<TcpStream>,
    retry_at: Instant,
    backoff: Duration,
    connects: u64,
}

impl CsiLink {
    fn new(to: SocketAddr) -> Self {
        Self {
            to,
            stream: None,
            retry_at: Instant::now(),
            backoff: Duration::from_millis(100),
            connects: 0,
        }
    }

    /// Sends `bytes`; `false` when there is no connection now.
    fn send(&mut self, bytes: &[u8]) -> bool {
        if self.stream.is_none() && Instant::now() >= self.retry_at {
            match TcpStream::connect_timeout(&self.to, Duration::from_millis(500)) {
                Ok(s) => {
                    let _ = s.set_nodelay(true);
                    self.stream = Some(s);
                    self.connects += 1;
                    self.backoff = Duration::from_millis(100);
                }
                Err(_) => {
                    self.retry_at = Instant::now() + self.backoff;
                    self.backoff = (self.backoff * 2).min(Duration::from_secs(2));
                }
            }
        }
        let Some(stream) = &mut self.stream else {
            return false;
        };
        if stream.write_all(bytes).is_err() {
            self.stream = None;
            self.retry_at = Instant::now() + self.backoff;
            return false;
        }
        true
    }
}

/// Plays the dataset (module doc) until its end or `stop`.
pub fn play(options: &PlayOptions, stop: &AtomicBool) -> Result<PlaySummary, PlayError> {
    if !(options.speed.is_finite() && options.speed > 0.0 && options.speed <= 1000.0) {
        return Err(PlayError::Setup(format!(
            "the speed must be in (0, 1000]; it is {}",
            options.speed
        )));
    }
    let stream = DatasetStream::open(&options.dataset).map_err(Box::new)?;
    let macs = ap_macs(&stream, options.streams.csi)?;
    let mut events = stream
        .events(stream.manifest.baro.is_some())
        .map_err(Box::new)?;
    let io_err = |what: &str| {
        let what = what.to_string();
        move |source| PlayError::Io { what, source }
    };
    let socket = UdpSocket::bind("0.0.0.0:0").map_err(io_err("binding a UDP socket"))?;
    let received = Arc::new(AtomicU64::new(0));
    let listener = spawn_listener(&socket, options.capture.as_deref(), &received)?;
    let mut csi = CsiLink::new(options.csi_connect);
    let mut summary = PlaySummary::default();
    let (t0, start) = (stream.imu_span.0, start_instant(options.start_at));
    let mut header = MavHeader {
        system_id: options.system_id.into(),
        component_id: 1,
        sequence: 0,
    };
    let mut buf = Vec::with_capacity(512);
    let mut last_t = t0;
    let mut faults = Faults::new(&options.faults);
    while let Some(event) = events.next_event().map_err(Box::new)? {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let t = match &event {
            DatasetEvent::Csi { packet, .. } => packet.t,
            DatasetEvent::Baro(b) => b.t,
            DatasetEvent::Imu(s) => s.t,
        };
        last_t = t;
        let due = start + Duration::from_secs_f64((t.secs_since(t0) / options.speed).max(0.0));
        let now = Instant::now();
        if due > now {
            thread::sleep(due - now);
        } else {
            summary.max_lag_s = summary.max_lag_s.max((now - due).as_secs_f64());
        }
        buf.clear();
        let rel_s = t.secs_since(t0);
        match event {
            DatasetEvent::Csi { ap, packet } if options.streams.csi => {
                // The CSI Tool's TCP stream carries Intel 5300 records only.
                let Received::Intel5300(mut record) = packet.record else {
                    summary.csi_not_sent += 1;
                    continue;
                };
                let low = record.header.timestamp_low;
                record.header.timestamp_low = faults.csi(low, rel_s, &mut buf);
                if let Some(Some(mac)) = macs.get(ap) {
                    encode_frame_record(mac, &mut buf);
                }
                encode_record(&record, &mut buf);
                if csi.send(&buf) {
                    summary.csi_sent += 1;
                } else {
                    summary.csi_not_sent += 1;
                }
            }
            DatasetEvent::Imu(mut s) if options.streams.imu => {
                let Some(t_ns) = faults.fc_time(s.t.as_nanos(), rel_s, true) else {
                    continue;
                };
                s.t = crate::time::Timestamp(t_ns);
                faults.imu_readings(&mut s, rel_s);
                let message = highres_imu(&s);
                encode_mavlink(header, &message, &mut buf)?;
                if faults.corrupt(rel_s, &mut buf) {
                    let _ = socket.send_to(&buf, options.mavlink_to);
                }
                send_mavlink(&socket, options.mavlink_to, &mut header, &message, &mut buf)?;
                summary.imu_sent += 1;
            }
            DatasetEvent::Baro(b) if options.streams.imu => {
                let Some(t_ns) = faults.fc_time(b.t.as_nanos(), rel_s, false) else {
                    continue;
                };
                let message = highres_pressure(t_ns, b.altitude_m);
                send_mavlink(&socket, options.mavlink_to, &mut header, &message, &mut buf)?;
                summary.baro_sent += 1;
            }
            _ => {}
        }
    }
    // Let the last answers come back.
    thread::sleep(Duration::from_millis(300));
    summary.csi_connects = csi.connects;
    summary.played_s = last_t.secs_since(t0);
    summary.mavlink_received = received.load(Ordering::Relaxed);
    drop(listener);
    Ok(summary)
}

/// The instant the dataset's first input is due.
fn start_instant(start_at: Option<f64>) -> Instant {
    let now = Instant::now();
    let Some(at) = start_at else {
        return now;
    };
    let unix_now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    let wait = at - unix_now;
    if wait > 0.0 && wait.is_finite() {
        now + Duration::from_secs_f64(wait.min(3600.0))
    } else {
        now
    }
}

/// Every AP's transmitter address (needed for its frame records when the CSI is played).
fn ap_macs(stream: &DatasetStream, csi: bool) -> Result<Vec<Option<MacAddress>>, PlayError> {
    let aps = &stream.manifest.aps;
    let macs: Vec<Option<MacAddress>> = aps
        .iter()
        .map(|a| a.mac.as_deref().and_then(parse_mac))
        .collect();
    for (a, m) in aps.iter().zip(&macs) {
        if a.mac.is_some() && m.is_none() {
            return Err(PlayError::Setup(format!(
                "AP {:?}: mac {:?} is not six hexadecimal bytes separated by colons",
                a.name, a.mac
            )));
        }
    }
    if csi && aps.len() > 1 && macs.iter().any(Option::is_none) {
        return Err(PlayError::Setup(
            "the dataset has several APs but not every one has a mac in dataset.toml: \
             wins live could not tell their packets apart"
                .into(),
        ));
    }
    Ok(macs)
}

/// A thread counting (and capturing) what comes back on `socket`; it ends with the process.
fn spawn_listener(
    socket: &UdpSocket,
    capture: Option<&Path>,
    received: &Arc<AtomicU64>,
) -> Result<thread::JoinHandle<()>, PlayError> {
    let io_err = |what: String| move |source| PlayError::Io { what, source };
    let socket = socket
        .try_clone()
        .map_err(io_err("cloning the UDP socket".into()))?;
    let mut capture = match capture {
        Some(path) => Some(BufWriter::new(
            File::create(path).map_err(io_err(format!("creating {}", path.display())))?,
        )),
        None => None,
    };
    let received = Arc::clone(received);
    thread::Builder::new()
        .name("replay-mavlink-in".into())
        .spawn(move || {
            let mut buf = vec![0u8; 65_536];
            loop {
                let Ok((n, _)) = socket.recv_from(&mut buf) else {
                    continue;
                };
                received.fetch_add(1, Ordering::Relaxed);
                if let (Some(w), Some(bytes)) = (&mut capture, buf.get(..n)) {
                    let _ = w.write_all(bytes).and_then(|()| w.flush());
                }
            }
        })
        .map_err(io_err("starting the MAVLink listener".into()))
}

/// `message` as MAVLink 2 with `header`, into `buf`.
fn encode_mavlink(
    header: MavHeader,
    message: &MavMessage,
    buf: &mut Vec<u8>,
) -> Result<(), PlayError> {
    buf.clear();
    ::mavlink::write_v2_msg(buf, header, message).map_err(|e| PlayError::Io {
        what: "encoding a MAVLink message".into(),
        source: io::Error::other(e.to_string()),
    })?;
    Ok(())
}

fn send_mavlink(
    socket: &UdpSocket,
    to: SocketAddr,
    header: &mut MavHeader,
    message: &MavMessage,
    buf: &mut Vec<u8>,
) -> Result<(), PlayError> {
    encode_mavlink(*header, message, buf)?;
    header.sequence = header.sequence.wrapping_add(1);
    // A datagram nobody listens to yet (wins live not started) is lost, as on a real link.
    let _ = socket.send_to(buf, to);
    Ok(())
}

/// `HIGHRES_IMU` with the accelerometer and gyroscope of `s`.
pub fn highres_imu(s: &ImuSample) -> MavMessage {
    let flags = HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_XACC
        | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_YACC
        | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ZACC
        | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_XGYRO
        | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_YGYRO
        | HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ZGYRO;
    MavMessage::HIGHRES_IMU(HIGHRES_IMU_DATA {
        time_usec: micros(s.t.as_nanos()),
        xacc: s.accel_m_s2.x as f32,
        yacc: s.accel_m_s2.y as f32,
        zacc: s.accel_m_s2.z as f32,
        xgyro: s.gyro_rad_s.x as f32,
        ygyro: s.gyro_rad_s.y as f32,
        zgyro: s.gyro_rad_s.z as f32,
        fields_updated: flags,
        ..Default::default()
    })
}

/// `HIGHRES_IMU` with only the absolute pressure of `altitude_m`.
pub fn highres_pressure(t_ns: i64, altitude_m: f64) -> MavMessage {
    MavMessage::HIGHRES_IMU(HIGHRES_IMU_DATA {
        time_usec: micros(t_ns),
        abs_pressure: (pressure_at_altitude_pa(altitude_m, STANDARD_SEA_LEVEL_PA) / 100.0) as f32,
        fields_updated: HighresImuUpdatedFlags::HIGHRES_IMU_UPDATED_ABS_PRESSURE,
        ..Default::default()
    })
}

fn micros(t_ns: i64) -> u64 {
    u64::try_from(t_ns.div_euclid(1000)).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pressure_of_an_altitude_gives_that_altitude_back() {
        for h in [-100.0, 0.0, 12.5, 500.0, 3000.0] {
            let p = pressure_at_altitude_pa(h, STANDARD_SEA_LEVEL_PA);
            let back = pressure_altitude_m(p, STANDARD_SEA_LEVEL_PA);
            assert!((back - h).abs() < 1e-6, "{h} m -> {p} Pa -> {back} m");
        }
        // The standard atmosphere at 1000 m: 89 875 Pa.
        let p = pressure_at_altitude_pa(1000.0, STANDARD_SEA_LEVEL_PA);
        assert!((p - 89_875.0).abs() < 5.0, "{p}");
    }
}
