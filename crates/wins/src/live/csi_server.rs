//! The CSI side of `wins live`: a TCP server where the CSI Tool's `log_to_server` connects (one
//! connection per NIC; the stream has the `.dat` framing, decoded by [`StreamDecoder`]).
//!
//! Each connection gets a thread that reads what arrives, decodes it and hands every record,
//! with its transmitter (from the 0xC1 frame record before it, when the logger writes them) and
//! the host time it arrived, to the session's channel. Garbage on the socket is skipped and
//! counted by the decoder (its memory stays bounded, [`StreamDecoder::MAX_PENDING`]); a
//! connection that drops is reported and the server keeps listening, so a logger that
//! reconnects is taken back.
//!
//! Limits ([`CsiServerLimits`]), so that nobody on the network can starve the NICs: a few
//! connections at most are open at once and a connection from a peer outside the allowed ones
//! (when any are named) is refused at once (both reported as [`CsiEvent::Refused`]); a
//! connection that sends nothing for a few seconds is closed, so a logger's half-open old connection gives way
//! to its reconnection. Each connection's buffered bytes are bounded by the decoder.

use std::io::{self, Read};
use std::net::{IpAddr, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::{self, JoinHandle};
use std::time::Duration;

use super::{HostClock, LiveInput};
use crate::csi::intel5300::{Event, MacAddress, Skip, StreamDecoder};
use crate::csi::logged::Logged;

/// How often blocked reads and the accept loop look at the stop flag.
const POLL: Duration = Duration::from_millis(50);
/// Read size per call.
const CHUNK: usize = 1 << 16;
/// Who may connect, how many, and how long a silent connection stays.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiServerLimits {
    /// The peers allowed to connect; empty: any.
    pub allowed_peers: Vec<IpAddr>,
    /// Most connections open at once (default 8: a rig has a few NICs).
    pub max_connections: usize,
    /// A connection silent this long is closed (default 5 s; a logger sends tens of records a
    /// second).
    pub idle_close: Duration,
}

impl Default for CsiServerLimits {
    fn default() -> Self {
        Self {
            allowed_peers: Vec::new(),
            max_connections: 8,
            idle_close: Duration::from_secs(5),
        }
    }
}

/// What a CSI connection reports.
#[derive(Clone, Debug, PartialEq)]
pub enum CsiEvent {
    /// A logger connected.
    Connected {
        /// The connection's number (from 0, in the order they came).
        conn: u64,
        /// Its address.
        peer: SocketAddr,
    },
    /// A CSI record.
    Record {
        /// The connection it came on.
        conn: u64,
        /// The record, its clock the NIC's (a 5300's unwrapped by this connection's decoder).
        record: Box<Logged>,
        /// The transmitter named by the frame record before it, if any.
        transmitter: Option<MacAddress>,
        /// Host time it arrived, ns ([`HostClock`]).
        arrival_ns: i64,
    },
    /// Bytes the decoder skipped (garbage, non-CSI records, a cut record).
    Skipped {
        /// The connection.
        conn: u64,
        /// What and why.
        skip: Skip,
    },
    /// A datagram on the Nexmon port that is not a Nexmon CSI packet (counted with the skips).
    NotCsi {
        /// The source's connection number.
        conn: u64,
        /// Its bytes.
        bytes: u64,
    },
    /// A connection refused at once.
    Refused {
        /// Its address.
        peer: SocketAddr,
        /// Why.
        reason: String,
    },
    /// The connection ended.
    Disconnected {
        /// The connection.
        conn: u64,
        /// Why (`"closed by the peer"`, or the I/O error).
        reason: String,
        /// The peer closed it after a whole record (a replay that finished, a logger that
        /// stopped, but also one that crashed: TCP cannot tell them apart), rather than an
        /// error, an idle timeout, or a close that cut a record.
        clean: bool,
    },
}

/// A listening CSI server; dropping it does not stop it: set the stop flag.
#[derive(Debug)]
pub struct CsiServer {
    /// The address it listens on (the port chosen by the system when 0 was asked).
    pub local_addr: SocketAddr,
    /// The accept loop's thread.
    pub thread: JoinHandle<()>,
}

impl CsiServer {
    /// Binds `addr` (a failure is returned at once: a busy port is an error before any work) and
    /// serves connections until `stop` is set, sending their events to `tx`.
    pub fn spawn(
        addr: SocketAddr,
        tx: SyncSender<LiveInput>,
        clock: HostClock,
        stop: Arc<AtomicBool>,
        limits: CsiServerLimits,
    ) -> io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        listener.set_nonblocking(true)?;
        let local_addr = listener.local_addr()?;
        let thread = thread::Builder::new()
            .name("csi-accept".into())
            .spawn(move || accept_loop(&listener, &tx, clock, &stop, &limits))?;
        Ok(Self { local_addr, thread })
    }
}

fn accept_loop(
    listener: &TcpListener,
    tx: &SyncSender<LiveInput>,
    clock: HostClock,
    stop: &Arc<AtomicBool>,
    limits: &CsiServerLimits,
) {
    let mut next_conn = 0u64;
    let mut workers: Vec<JoinHandle<()>> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, peer)) => {
                workers.retain(|h| !h.is_finished());
                let refusal = if !limits.allowed_peers.is_empty()
                    && !limits.allowed_peers.contains(&peer.ip())
                {
                    Some(format!("{} is not among live.csi_peers", peer.ip()))
                } else if workers.len() >= limits.max_connections {
                    Some(format!(
                        "{} connections are open already",
                        limits.max_connections
                    ))
                } else {
                    None
                };
                if let Some(reason) = refusal {
                    drop(stream);
                    if tx
                        .send(LiveInput::Csi(CsiEvent::Refused { peer, reason }))
                        .is_err()
                    {
                        return;
                    }
                    continue;
                }
                let conn = next_conn;
                next_conn += 1;
                if tx
                    .send(LiveInput::Csi(CsiEvent::Connected { conn, peer }))
                    .is_err()
                {
                    return;
                }
                let (worker_tx, worker_stop) = (tx.clone(), Arc::clone(stop));
                let idle = limits.idle_close;
                let spawned = thread::Builder::new()
                    .name(format!("csi-{conn}"))
                    .spawn(move || serve(conn, stream, &worker_tx, clock, &worker_stop, idle));
                match spawned {
                    Ok(h) => workers.push(h),
                    Err(e) => {
                        let _ = tx.send(LiveInput::Csi(CsiEvent::Disconnected {
                            conn,
                            reason: format!("no thread for the connection: {e}"),
                            clean: false,
                        }));
                    }
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => thread::sleep(POLL),
            Err(_) => thread::sleep(POLL),
        }
    }
    for h in workers {
        let _ = h.join();
    }
}

/// Reads one connection to its end, or until `stop`.
fn serve(
    conn: u64,
    mut stream: TcpStream,
    tx: &SyncSender<LiveInput>,
    clock: HostClock,
    stop: &AtomicBool,
    idle_close: Duration,
) {
    let mut decoder = StreamDecoder::new();
    let mut buf = vec![0u8; CHUNK];
    let mut last_bytes = std::time::Instant::now();
    let mut peer_closed = false;
    let reason = match stream
        .set_nonblocking(false)
        .and_then(|()| stream.set_read_timeout(Some(POLL)))
    {
        Err(e) => e.to_string(),
        Ok(()) => loop {
            if stop.load(Ordering::Relaxed) {
                break "stopped".to_string();
            }
            if last_bytes.elapsed() >= idle_close {
                break format!("idle for {:.1} s: closed", idle_close.as_secs_f64());
            }
            match stream.read(&mut buf) {
                Ok(0) => {
                    peer_closed = true;
                    break "closed by the peer".to_string();
                }
                Ok(n) => {
                    last_bytes = std::time::Instant::now();
                    let arrival_ns = clock.now_ns();
                    decoder.push(buf.get(..n).unwrap_or_default());
                    if drain(conn, &mut decoder, tx, arrival_ns).is_none() {
                        return;
                    }
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock
                            | io::ErrorKind::TimedOut
                            | io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => break e.to_string(),
            }
        },
    };
    decoder.finish();
    if let Some(cut) = drain(conn, &mut decoder, tx, clock.now_ns()) {
        let clean = peer_closed && cut == 0;
        let _ = tx.send(LiveInput::Csi(CsiEvent::Disconnected {
            conn,
            reason,
            clean,
        }));
    }
}

/// Sends every decoded event; the skips among them (`None` when the session has gone).
fn drain(
    conn: u64,
    decoder: &mut StreamDecoder,
    tx: &SyncSender<LiveInput>,
    arrival_ns: i64,
) -> Option<usize> {
    let mut skips = 0;
    while let Some(event) = decoder.next_event() {
        let event = match event {
            Event::Csi(record) => CsiEvent::Record {
                conn,
                record: Box::new(Logged::Intel5300(*record)),
                transmitter: decoder.transmitter(),
                arrival_ns,
            },
            Event::Skipped(skip) => {
                skips += 1;
                CsiEvent::Skipped { conn, skip }
            }
        };
        if tx.send(LiveInput::Csi(event)).is_err() {
            return None;
        }
    }
    Some(skips)
}

#[cfg(test)]
mod tests {
    use std::sync::mpsc::{self, Receiver};

    use super::*;

    fn server(limits: CsiServerLimits) -> (CsiServer, Receiver<LiveInput>, Arc<AtomicBool>) {
        let (tx, rx) = mpsc::sync_channel(64);
        let stop = Arc::new(AtomicBool::new(false));
        let addr = "127.0.0.1:0".parse().expect("an address");
        let s = CsiServer::spawn(addr, tx, HostClock::new(), Arc::clone(&stop), limits)
            .expect("listening");
        (s, rx, stop)
    }

    fn next(rx: &Receiver<LiveInput>) -> CsiEvent {
        match rx.recv_timeout(Duration::from_secs(5)) {
            Ok(LiveInput::Csi(e)) => e,
            other => panic!("expected a CSI event, got {other:?}"),
        }
    }

    #[test]
    fn peers_outside_the_list_and_beyond_the_cap_are_refused_and_silence_closes() {
        let (s, rx, stop) = server(CsiServerLimits {
            allowed_peers: vec!["10.1.2.3".parse().expect("an IP")],
            ..CsiServerLimits::default()
        });
        let _c = TcpStream::connect(s.local_addr).expect("connected");
        assert!(
            matches!(next(&rx), CsiEvent::Refused { reason, .. } if reason.contains("csi_peers"))
        );
        stop.store(true, Ordering::Relaxed);

        let (s, rx, stop) = server(CsiServerLimits {
            max_connections: 2,
            idle_close: Duration::from_millis(400),
            ..CsiServerLimits::default()
        });
        let _a = TcpStream::connect(s.local_addr).expect("a");
        assert!(matches!(next(&rx), CsiEvent::Connected { conn: 0, .. }));
        let _b = TcpStream::connect(s.local_addr).expect("b");
        assert!(matches!(next(&rx), CsiEvent::Connected { conn: 1, .. }));
        let _c = TcpStream::connect(s.local_addr).expect("c");
        assert!(
            matches!(next(&rx), CsiEvent::Refused { reason, .. } if reason.contains("2 connections"))
        );
        // Both silent: closed, and their places free again.
        for _ in 0..2 {
            assert!(
                matches!(next(&rx), CsiEvent::Disconnected { reason, .. } if reason.contains("idle"))
            );
        }
        thread::sleep(Duration::from_millis(100));
        let _d = TcpStream::connect(s.local_addr).expect("d");
        assert!(matches!(next(&rx), CsiEvent::Connected { conn: 2, .. }));
        stop.store(true, Ordering::Relaxed);
    }

    #[test]
    fn a_close_after_a_whole_record_is_clean_and_one_that_cuts_a_record_is_not() {
        use std::io::Write;

        use num_complex::Complex;

        use crate::csi::intel5300::{BfeeHeader, CsiRecord, encode_record};
        use crate::time::Timestamp;

        let header = BfeeHeader {
            nrx: 3,
            ntx: 1,
            ..Default::default()
        };
        let csi = vec![Complex::new(7i8, -3); header.num_entries()];
        let record = CsiRecord::new(header, &csi, Timestamp(0)).expect("a record");
        let mut bytes = Vec::new();
        encode_record(&record, &mut bytes);
        let (s, rx, stop) = server(CsiServerLimits::default());
        for (sent, clean) in [(bytes.len(), true), (bytes.len() / 2, false)] {
            let mut peer = TcpStream::connect(s.local_addr).expect("connected");
            assert!(matches!(next(&rx), CsiEvent::Connected { .. }));
            peer.write_all(&bytes[..sent]).expect("sent");
            drop(peer);
            loop {
                match next(&rx) {
                    CsiEvent::Disconnected { clean: c, .. } => {
                        assert_eq!(c, clean, "{sent} of {} bytes", bytes.len());
                        break;
                    }
                    CsiEvent::Record { .. }
                    | CsiEvent::Skipped { .. }
                    | CsiEvent::NotCsi { .. } => {}
                    other => panic!("{other:?}"),
                }
            }
        }
        stop.store(true, Ordering::Relaxed);
    }
}
