//! The CSI side of `wins live` for an Intel AX200/AX210 rig with FeitCSI. FeitCSI started with
//! `--udp-socket` listens for commands on UDP port 8008: a datagram holding a command line (its
//! first word the program's name, then the options, as on FeitCSI's own command line) starts a
//! measurement, and from then on every CSI record goes back to the sender in a datagram of its
//! own, the bytes a FeitCSI file holds for it; a datagram `stop` ends the measurement.
//!
//! The listener binds `csi_listen`, sends the start command to the FeitCSI server
//! (`live.feitcsi_server`, with `live.feitcsi_options`) and sends it again every
//! [`START_RETRY`] until a record comes back (FeitCSI may be started after `wins live`); when the
//! session stops it sends `stop`. Each record is handed on with the card's own clock (its 32-bit
//! microsecond counter, which the session relates to the host's; a wrap, every 71.6 min, reads
//! as a clock jump and is re-locked) and its transmitter address, which tells its AP.
//!
//! Nobody else on the network moves the poses: a datagram from any host but the FeitCSI server,
//! or from one outside `csi_peers` when any are named, is refused and counted
//! ([`CsiEvent::Refused`]); one from the server that is not one whole FeitCSI record is counted
//! ([`CsiEvent::NotCsi`]).

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use super::csi_server::{CsiEvent, CsiServerLimits};
use super::udp;
use super::{HostClock, LiveInput};
use crate::config::live::LiveConfig;
use crate::csi::feitcsi::parse_datagram;
use crate::csi::logged::Logged;
use crate::csi::subcarriers::Bandwidth;
use crate::dataset::manifest::ChannelEntry;

/// The start command is sent again this often until a record comes back.
pub const START_RETRY: Duration = Duration::from_secs(1);
/// The first word of the start command: FeitCSI parses the datagram as a command line, whose
/// first word is the program's name.
const PROGRAM: &str = "feitcsi";

/// FeitCSI's options for the channel centred at `center_freq_hz` with `bandwidth`, HT frames:
/// `-f` takes the primary channel, 10 MHz below the centre of a 40 MHz one (HT40+).
pub fn options_for_channel(center_freq_hz: f64, bandwidth: Bandwidth) -> String {
    let center_mhz = (center_freq_hz / 1e6).round() as i64;
    match bandwidth {
        Bandwidth::Ht20 => format!("-f {center_mhz} -w 20 -r HT"),
        Bandwidth::Ht40 => format!("-f {} -w 40 -r HT", center_mhz - 10),
    }
}

/// FeitCSI's command socket and the options its measurement starts with, from the `[live]`
/// settings (`feitcsi_server`, `feitcsi_options`) and, when no options are given, the rig's
/// `channel` ([`options_for_channel`]).
pub fn feitcsi_start(
    live: &LiveConfig,
    channel: &ChannelEntry,
) -> Result<(SocketAddr, String), String> {
    let server: SocketAddr = live
        .feitcsi_server
        .parse()
        .map_err(|_| format!("live.feitcsi_server {:?}", live.feitcsi_server))?;
    let options = match live.feitcsi_options.trim() {
        "" => options_for_channel(channel.center_freq_hz, channel.bandwidth),
        given => given.to_string(),
    };
    Ok((server, options))
}

/// The command line that starts FeitCSI's measurement with `options`.
pub fn start_command(options: &str) -> String {
    format!("{PROGRAM} {}", options.trim())
}

/// A FeitCSI client; dropping it does not stop it: set the stop flag (it then sends `stop`).
#[derive(Debug)]
pub struct FeitListener {
    /// The address it receives on (the port chosen by the system when 0 was asked).
    pub local_addr: SocketAddr,
    /// The receive loop's thread.
    pub thread: JoinHandle<()>,
}

impl FeitListener {
    /// Binds `addr` (a failure is returned at once), starts FeitCSI at `server` with `options`
    /// and receives until `stop` is set, sending its records to `tx`.
    pub fn spawn(
        addr: SocketAddr,
        server: SocketAddr,
        options: &str,
        tx: SyncSender<LiveInput>,
        clock: HostClock,
        stop: Arc<AtomicBool>,
        limits: CsiServerLimits,
    ) -> io::Result<Self> {
        let socket = udp::bind(addr)?;
        let local_addr = socket.local_addr()?;
        let command = start_command(options);
        let thread = thread::Builder::new()
            .name("feitcsi-udp".into())
            .spawn(move || {
                let mut server_side = FeitServer::new(server, limits);
                let mut buf = vec![0u8; udp::MAX_DATAGRAM];
                let mut last_start: Option<Instant> = None;
                while !stop.load(Ordering::Relaxed) {
                    if !server_side.answered()
                        && last_start.is_none_or(|t| t.elapsed() >= START_RETRY)
                    {
                        // A send that fails (no route yet) is tried again at the next retry.
                        let _ = socket.send_to(command.as_bytes(), server);
                        last_start = Some(Instant::now());
                    }
                    // (The server's port not yet open is reported on the socket: waited out.)
                    let Some((n, peer)) = udp::receive(&socket, &mut buf) else {
                        continue;
                    };
                    for e in server_side.datagram(&buf[..n], peer, clock.now_ns()) {
                        if tx.send(LiveInput::Csi(e)).is_err() {
                            let _ = socket.send_to(b"stop", server);
                            return;
                        }
                    }
                }
                let _ = socket.send_to(b"stop", server);
            })?;
        Ok(Self { local_addr, thread })
    }
}

/// What the listener knows of the FeitCSI server (its state, without the socket:
/// [`FeitServer::datagram`] is what the thread does with each datagram).
#[derive(Debug)]
pub struct FeitServer {
    server: SocketAddr,
    limits: CsiServerLimits,
    /// Whether the server has sent anything (it is then connection 0).
    connected: bool,
}

impl FeitServer {
    /// The server at `server`, nothing heard from it yet.
    pub fn new(server: SocketAddr, limits: CsiServerLimits) -> Self {
        Self {
            server,
            limits,
            connected: false,
        }
    }

    /// Whether the server has answered the start command.
    pub fn answered(&self) -> bool {
        self.connected
    }

    /// The events one datagram from `peer`, arrived at `arrival_ns`, makes.
    pub fn datagram(&mut self, bytes: &[u8], peer: SocketAddr, arrival_ns: i64) -> Vec<CsiEvent> {
        let mut out = Vec::new();
        let allowed =
            self.limits.allowed_peers.is_empty() || self.limits.allowed_peers.contains(&peer.ip());
        if peer != self.server || !allowed {
            let reason = match allowed {
                true => format!("not the FeitCSI server ({})", self.server),
                false => "not one of live.csi_peers".into(),
            };
            out.push(CsiEvent::Refused { peer, reason });
            return out;
        }
        if !self.connected {
            self.connected = true;
            out.push(CsiEvent::Connected { conn: 0, peer });
        }
        match parse_datagram(bytes) {
            Ok(r) => out.push(CsiEvent::Record {
                conn: 0,
                transmitter: Some(r.header.source_mac),
                record: Box::new(Logged::FeitCsi(r)),
                arrival_ns,
            }),
            Err(_) => out.push(CsiEvent::NotCsi {
                conn: 0,
                bytes: bytes.len() as u64,
            }),
        }
        out
    }
}

#[cfg(test)]
mod tests;
