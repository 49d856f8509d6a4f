//! The CSI side of `wins live` for a Nexmon rig: nexmon_csi sends one UDP packet per receive core
//! of each frame (to port 5500; `csi_listen` names where they arrive). Each source gets a
//! connection number on its first datagram ([`CsiEvent::Connected`]), its packets are assembled
//! into frames ([`FrameAssembler`]: handed out once every core of the rig has come, or when the
//! next frame starts) and each frame goes to the session as one record, its clock the host time
//! its first packet arrived (a Nexmon packet carries no clock of its own).
//!
//! Nobody else on the network moves the poses: datagrams from a peer outside the allowed ones
//! (when any are named), or from more sources than [`CsiServerLimits::max_connections`], are
//! refused and counted ([`CsiEvent::Refused`]); a datagram that is not a Nexmon CSI packet is
//! counted ([`CsiEvent::NotCsi`]).

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::thread::{self, JoinHandle};

use super::csi_server::{CsiEvent, CsiServerLimits};
use super::udp;
use super::{HostClock, LiveInput};
use crate::csi::logged::Logged;
use crate::csi::nexmon::frames::FrameAssembler;
use crate::csi::nexmon::{NexmonPacket, parse_payload};

/// A listening Nexmon receiver; dropping it does not stop it: set the stop flag.
#[derive(Debug)]
pub struct NexmonListener {
    /// The address it listens on (the port chosen by the system when 0 was asked).
    pub local_addr: SocketAddr,
    /// The receive loop's thread.
    pub thread: JoinHandle<()>,
}

impl NexmonListener {
    /// Binds `addr` (a failure is returned at once) and receives until `stop` is set, sending
    /// frames of `cores` packets to `tx`.
    pub fn spawn(
        addr: SocketAddr,
        tx: SyncSender<LiveInput>,
        clock: HostClock,
        stop: Arc<AtomicBool>,
        limits: CsiServerLimits,
        cores: usize,
    ) -> io::Result<Self> {
        let socket = udp::bind(addr)?;
        let local_addr = socket.local_addr()?;
        let thread = thread::Builder::new()
            .name("nexmon-udp".into())
            .spawn(move || {
                let mut sources = Sources::new(limits, cores);
                let mut buf = vec![0u8; udp::MAX_DATAGRAM];
                while !stop.load(Ordering::Relaxed) {
                    let Some((n, peer)) = udp::receive(&socket, &mut buf) else {
                        continue;
                    };
                    for e in sources.datagram(&buf[..n], peer, clock.now_ns()) {
                        if tx.send(LiveInput::Csi(e)).is_err() {
                            return;
                        }
                    }
                }
            })?;
        Ok(Self { local_addr, thread })
    }
}

/// Every source's connection number and frame assembler (the listener's state, without the
/// socket: [`Sources::datagram`] is what the thread does with each datagram).
#[derive(Debug)]
pub struct Sources {
    limits: CsiServerLimits,
    cores: usize,
    by_peer: HashMap<SocketAddr, (u64, FrameAssembler)>,
}

impl Sources {
    /// No source yet; frames of `cores` packets.
    pub fn new(limits: CsiServerLimits, cores: usize) -> Self {
        Self {
            limits,
            cores,
            by_peer: HashMap::new(),
        }
    }

    /// The events one datagram from `peer`, arrived at `arrival_ns`, makes.
    pub fn datagram(&mut self, bytes: &[u8], peer: SocketAddr, arrival_ns: i64) -> Vec<CsiEvent> {
        let mut out = Vec::new();
        let allowed =
            self.limits.allowed_peers.is_empty() || self.limits.allowed_peers.contains(&peer.ip());
        if !allowed {
            out.push(CsiEvent::Refused {
                peer,
                reason: "not one of live.csi_peers".into(),
            });
            return out;
        }
        if !self.by_peer.contains_key(&peer) {
            if self.by_peer.len() >= self.limits.max_connections {
                out.push(CsiEvent::Refused {
                    peer,
                    reason: format!("more than {} sources", self.limits.max_connections),
                });
                return out;
            }
            let conn = self.by_peer.len() as u64;
            self.by_peer
                .insert(peer, (conn, FrameAssembler::new(self.cores)));
            out.push(CsiEvent::Connected { conn, peer });
        }
        let Some((conn, assembler)) = self.by_peer.get_mut(&peer) else {
            return out;
        };
        let conn = *conn;
        let Some(mut packet) = parse_payload(bytes) else {
            out.push(CsiEvent::NotCsi {
                conn,
                bytes: bytes.len() as u64,
            });
            return out;
        };
        stamp(&mut packet, arrival_ns);
        for frame in assembler.push(packet) {
            out.push(record(conn, frame));
        }
        out
    }
}

/// The packet's capture time: the host's, as a pcap of it would hold.
fn stamp(p: &mut NexmonPacket, arrival_ns: i64) {
    let us = arrival_ns.max(0) / 1000;
    p.ts_sec = (us / 1_000_000) as u32;
    p.ts_frac = (us % 1_000_000) as u32;
    p.time_ns = arrival_ns;
    p.caplen = 0;
    p.wirelen = 0;
}

/// A frame as one record; its time is its first packet's arrival.
fn record(conn: u64, frame: Vec<NexmonPacket>) -> CsiEvent {
    let transmitter = frame.first().map(|p| p.transmitter);
    let arrival_ns = frame.first().map_or(0, |p| p.time_ns);
    CsiEvent::Record {
        conn,
        record: Box::new(Logged::Nexmon(frame)),
        transmitter,
        arrival_ns,
    }
}

#[cfg(test)]
mod tests {
    use std::net::UdpSocket;
    use std::sync::mpsc;
    use std::time::Duration;

    use super::*;
    use crate::csi::nexmon::MAGIC_NEW;
    use crate::csi::nexmon::write::encode_payload;

    fn core_packet(core: u16, seq: u16) -> Vec<u8> {
        let p = NexmonPacket {
            index: 0,
            offset: 0,
            ts_sec: 0,
            ts_frac: 0,
            time_ns: 0,
            caplen: 0,
            wirelen: 0,
            magic: u32::from(MAGIC_NEW),
            rssi_dbm: Some(-50),
            frame_control: Some(0x08),
            transmitter: [2, 0, 0, 0, 0, 1],
            seq: seq << 4,
            csiconf: core << 8,
            chanspec: 0xd040,
            chip: 0x006a,
            words: vec![0x0004_0041; 64],
        };
        let mut bytes = Vec::new();
        encode_payload(&p, &mut bytes);
        bytes
    }

    #[test]
    fn datagrams_on_the_socket_become_whole_frames_and_strays_are_counted() {
        let (tx, rx) = mpsc::sync_channel(64);
        let stop = Arc::new(AtomicBool::new(false));
        let listener = NexmonListener::spawn(
            "127.0.0.1:0".parse().unwrap(),
            tx,
            HostClock::new(),
            Arc::clone(&stop),
            CsiServerLimits::default(),
            3,
        )
        .unwrap();
        let router = UdpSocket::bind("127.0.0.1:0").unwrap();
        for core in 0..3 {
            router
                .send_to(&core_packet(core, 9), listener.local_addr)
                .unwrap();
        }
        router.send_to(b"garbage", listener.local_addr).unwrap();
        let mut events = Vec::new();
        while events.len() < 3 {
            match rx.recv_timeout(Duration::from_secs(5)) {
                Ok(LiveInput::Csi(e)) => events.push(e),
                Ok(_) => {}
                Err(e) => panic!("{e}: {events:?}"),
            }
        }
        stop.store(true, Ordering::Relaxed);
        listener.thread.join().unwrap();
        assert!(matches!(events[0], CsiEvent::Connected { conn: 0, .. }));
        let CsiEvent::Record {
            record,
            transmitter,
            ..
        } = &events[1]
        else {
            panic!("{:?}", events[1])
        };
        let Logged::Nexmon(frame) = record.as_ref() else {
            panic!("{record:?}")
        };
        let cores: Vec<u8> = frame.iter().map(NexmonPacket::core).collect();
        assert_eq!(cores, [0, 1, 2]);
        assert_eq!(*transmitter, Some([2, 0, 0, 0, 0, 1]));
        assert!(matches!(events[2], CsiEvent::NotCsi { conn: 0, bytes: 7 }));
    }

    #[test]
    fn a_peer_not_allowed_and_a_source_too_many_are_refused() {
        let limits = CsiServerLimits {
            allowed_peers: vec!["127.0.0.1".parse().unwrap()],
            max_connections: 1,
            ..CsiServerLimits::default()
        };
        let mut sources = Sources::new(limits, 3);
        let foreign = sources.datagram(&core_packet(0, 1), "10.0.0.9:5500".parse().unwrap(), 0);
        assert!(matches!(foreign[..], [CsiEvent::Refused { .. }]));
        let first = sources.datagram(&core_packet(0, 1), "127.0.0.1:5500".parse().unwrap(), 0);
        assert!(matches!(first[..], [CsiEvent::Connected { .. }]));
        let second = sources.datagram(&core_packet(0, 1), "127.0.0.1:5501".parse().unwrap(), 0);
        assert!(matches!(second[..], [CsiEvent::Refused { .. }]));
        // A new frame closes the open one, whatever cores it lacked.
        let next = sources.datagram(&core_packet(0, 2), "127.0.0.1:5500".parse().unwrap(), 0);
        assert!(matches!(next[..], [CsiEvent::Record { .. }]));
    }
}
