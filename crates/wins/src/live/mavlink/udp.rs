//! `udpin:HOST:PORT` and `udpout:HOST:PORT`: UDP links that answer the flight controller,
//! never whoever spoke last.
//!
//! `udpin`: a flight controller (or a router forwarding it) sends to our port; we answer the
//! address its datagrams come from. The mavlink crate's own UDP server answers the last
//! datagram's sender, whoever it is: one HEARTBEAT from another host on the network then diverts
//! the poses. Here the answering address is learned only from a datagram that holds a CRC-valid
//! message of the vehicle's system id, and messages of other systems are passed on (the decoder
//! refuses and counts them) without moving it. `udpout`: we send to the given address from an
//! ephemeral port, connected to it, so datagrams from anywhere else never reach us.
//!
//! Each datagram is framed on its own ([`super::framer`]): its garbage bytes, bad CRCs and unknown
//! messages are counted ([`UdpLink::frame_counts`]), and a datagram with no CRC-valid frame at
//! all is counted whole ([`UdpLink::garbage_datagrams`]) and dropped.
//!
//! With a signing key ([`super::signing`]) only messages whose signature holds are passed on, and
//! only they can set the answering address; the others are counted by the signer. Replies are
//! signed.

use std::collections::VecDeque;
use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use ::mavlink::dialects::common::MavMessage;
use ::mavlink::{MavHeader, MavlinkVersion};

use super::framer::{FrameCounts, Framer};
use super::signing::{Signer, receive};

/// Largest UDP payload.
const DATAGRAM: usize = 65_536;

/// A UDP link (module doc).
#[derive(Debug)]
pub struct UdpLink {
    socket: UdpSocket,
    /// The vehicle's system id: only its datagrams set [`Self::peer`] (`udpin`).
    vehicle_system_id: u32,
    /// Where replies go: the last address the vehicle's messages came from (`udpin`), or the
    /// address given (`udpout`).
    peer: Mutex<Option<SocketAddr>>,
    /// `udpout`: the peer is the address given and never moves.
    fixed_peer: bool,
    /// Messages of the last datagram not yet handed out.
    pending: Mutex<VecDeque<(MavHeader, MavMessage)>>,
    /// The receive buffer and the framer, kept (one datagram at a time).
    receiving: Mutex<(Vec<u8>, Framer)>,
    /// The framer's counts, readable while a receive blocks.
    counts: Mutex<FrameCounts>,
    sequence: AtomicU8,
    garbage: AtomicU64,
    /// Signs the replies and checks what arrives, with a key.
    signer: Option<Arc<Signer>>,
}

impl UdpLink {
    /// `udpin`: binds `addr`; replies will go to the vehicle `vehicle_system_id`; with `signer`,
    /// signed (module doc).
    pub fn bind(
        addr: &str,
        vehicle_system_id: u8,
        signer: Option<Arc<Signer>>,
    ) -> io::Result<Self> {
        Ok(Self::on(
            UdpSocket::bind(addr)?,
            vehicle_system_id,
            None,
            signer,
        ))
    }

    /// `udpout`: sends to `addr` from an ephemeral port, and takes datagrams from there only.
    pub fn connect(
        addr: &str,
        vehicle_system_id: u8,
        signer: Option<Arc<Signer>>,
    ) -> io::Result<Self> {
        let peer = addr
            .to_socket_addrs()?
            .next()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "the name has no address"))?;
        let local = if peer.is_ipv4() {
            "0.0.0.0:0"
        } else {
            "[::]:0"
        };
        let socket = UdpSocket::bind(local)?;
        socket.connect(peer)?;
        Ok(Self::on(socket, vehicle_system_id, Some(peer), signer))
    }

    fn on(
        socket: UdpSocket,
        vehicle_system_id: u8,
        peer: Option<SocketAddr>,
        signer: Option<Arc<Signer>>,
    ) -> Self {
        Self {
            socket,
            vehicle_system_id: u32::from(vehicle_system_id),
            fixed_peer: peer.is_some(),
            peer: Mutex::new(peer),
            pending: Mutex::new(VecDeque::new()),
            receiving: Mutex::new((vec![0_u8; DATAGRAM], Framer::default())),
            counts: Mutex::new(FrameCounts::default()),
            sequence: AtomicU8::new(0),
            garbage: AtomicU64::new(0),
            signer,
        }
    }

    /// Datagrams that held no CRC-valid MAVLink frame (dropped).
    pub fn garbage_datagrams(&self) -> u64 {
        self.garbage.load(Ordering::Relaxed)
    }

    /// What the datagrams held, counted ([`super::framer`]).
    pub fn frame_counts(&self) -> FrameCounts {
        self.counts.lock().map(|c| *c).unwrap_or_default()
    }

    /// The address replies go to, once the vehicle has been heard (`udpin`) or from the start
    /// (`udpout`).
    pub fn peer(&self) -> Option<SocketAddr> {
        self.peer.lock().ok().and_then(|p| *p)
    }

    /// Blocks until one message arrives (datagrams are split into their messages).
    pub fn recv(&self) -> io::Result<(MavHeader, MavMessage)> {
        loop {
            if let Some(m) = self.pending.lock().ok().and_then(|mut p| p.pop_front()) {
                return Ok(m);
            }
            let mut receiving = self
                .receiving
                .lock()
                .map_err(|_| io::Error::other("the receive buffer's lock is poisoned"))?;
            let (buffer, framer) = &mut *receiving;
            let (n, from) = self.socket.recv_from(buffer)?;
            let before = framer.counts().frames;
            framer.push(buffer.get(..n).unwrap_or_default());
            let messages = self.messages(framer);
            framer.finish();
            if let Ok(mut c) = self.counts.lock() {
                *c = framer.counts();
            }
            if framer.counts().frames == before {
                self.garbage.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            if !self.fixed_peer
                && messages
                    .iter()
                    .any(|(h, _)| h.system_id == self.vehicle_system_id)
                && let Ok(mut peer) = self.peer.lock()
            {
                *peer = Some(from);
            }
            if let Ok(mut pending) = self.pending.lock() {
                pending.extend(messages);
            }
        }
    }

    /// The messages of a datagram to pass on (with a key, those refused are counted by the
    /// signer and left out).
    fn messages(&self, framer: &mut Framer) -> VecDeque<(MavHeader, MavMessage)> {
        let mut messages = VecDeque::new();
        while let Some(frame) = framer.next_frame(true) {
            messages.extend(receive(self.signer.as_deref(), &frame));
        }
        messages
    }

    /// Sends one message as MAVLink 2 with `header`'s ids (the sequence is this link's), signed
    /// with a key; 0 bytes when the vehicle has not been heard yet.
    pub fn send(&self, header: &MavHeader, message: &MavMessage) -> io::Result<usize> {
        let Some(peer) = self.peer() else {
            return Ok(0);
        };
        let header = MavHeader {
            sequence: self.sequence.fetch_add(1, Ordering::Relaxed),
            ..*header
        };
        let bytes = encode(self.signer.as_deref(), header, message)?;
        if self.fixed_peer {
            self.socket.send(&bytes)
        } else {
            self.socket.send_to(&bytes, peer)
        }
    }
}

/// One message as MAVLink 2 bytes, signed with `signer`.
pub(super) fn encode(
    signer: Option<&Signer>,
    header: MavHeader,
    message: &MavMessage,
) -> io::Result<Vec<u8>> {
    if let Some(signer) = signer {
        return Ok(signer.sign(header, message).raw_bytes().to_vec());
    }
    let mut bytes = Vec::with_capacity(300);
    ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, message)
        .map_err(|e| io::Error::other(e.to_string()))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use ::mavlink::MavlinkReader;
    use ::mavlink::dialects::common::HEARTBEAT_DATA;

    use super::*;

    fn datagram(system_id: u32) -> Vec<u8> {
        let mut bytes = Vec::new();
        let header = MavHeader {
            system_id,
            component_id: 1,
            sequence: 0,
        };
        let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &heartbeat)
            .expect("encoded");
        bytes
    }

    #[test]
    fn replies_go_to_the_vehicle_not_to_the_last_sender() {
        let link = UdpLink::bind("127.0.0.1:0", 1, None).expect("bound");
        let to = link.socket.local_addr().expect("address");
        let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        let ours = MavHeader {
            system_id: 1,
            component_id: 197,
            sequence: 0,
        };
        assert_eq!(link.send(&ours, &heartbeat).expect("nothing sent"), 0);

        let fc = UdpSocket::bind("127.0.0.1:0").expect("fc");
        let stranger = UdpSocket::bind("127.0.0.1:0").expect("stranger");
        fc.set_read_timeout(Some(Duration::from_secs(5)))
            .expect("timeout");
        stranger
            .set_read_timeout(Some(Duration::from_millis(200)))
            .expect("timeout");
        fc.send_to(&datagram(1), to).expect("sent");
        assert_eq!(link.recv().expect("fc message").0.system_id, 1);
        assert_eq!(link.peer(), fc.local_addr().ok());

        // Another system's HEARTBEAT and garbage: passed on or counted, the peer unmoved.
        stranger.send_to(&datagram(9), to).expect("sent");
        stranger.send_to(&[0x55; 300], to).expect("sent");
        fc.send_to(&datagram(1), to).expect("sent");
        assert_eq!(link.recv().expect("stranger's").0.system_id, 9);
        assert_eq!(link.recv().expect("fc's again").0.system_id, 1);
        assert_eq!(link.garbage_datagrams(), 1);
        assert_eq!(link.frame_counts().garbage_bytes, 300);
        assert_eq!(link.peer(), fc.local_addr().ok());

        assert!(link.send(&ours, &heartbeat).expect("sent") > 0);
        let mut buffer = [0_u8; 512];
        let (n, _) = fc.recv_from(&mut buffer).expect("the reply reaches the fc");
        let mut reader = MavlinkReader::new(buffer.get(..n).unwrap_or_default());
        let (h, _) = reader.read_any_message::<MavMessage>().expect("a message");
        assert_eq!((h.system_id, h.component_id), (1, 197));
        assert!(
            stranger.recv_from(&mut buffer).is_err(),
            "nothing to the stranger"
        );
    }

    #[test]
    fn a_datagram_of_several_messages_gives_each() {
        let link = UdpLink::bind("127.0.0.1:0", 1, None).expect("bound");
        let to = link.socket.local_addr().expect("address");
        let fc = UdpSocket::bind("127.0.0.1:0").expect("fc");
        let mut two = datagram(1);
        two.extend(datagram(1));
        fc.send_to(&two, to).expect("sent");
        assert!(link.recv().is_ok());
        assert!(link.recv().is_ok());
        assert_eq!(link.garbage_datagrams(), 0);
    }
}
