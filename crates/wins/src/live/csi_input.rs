//! The CSI input of a live session, chosen by the rig's card: the CSI Tool's TCP server for an
//! Intel 5300 ([`CsiServer`]), the UDP receiver of nexmon_csi's packets for a Nexmon rig
//! ([`NexmonListener`]), FeitCSI's UDP stream for an Intel AX200/AX210 ([`FeitListener`]).

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;

use super::csi_server::{CsiServer, CsiServerLimits};
use super::feitcsi_udp::FeitListener;
use super::nexmon_udp::NexmonListener;
use super::{HostClock, LiveInput};
use crate::csi::format::CaptureFormat;

/// The cards whose live streams `wins live` takes.
pub const LIVE_CARDS: [CaptureFormat; 3] = [
    CaptureFormat::Intel5300,
    CaptureFormat::Nexmon,
    CaptureFormat::FeitCsi,
];

/// Where and how a rig's CSI comes in.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiInput {
    /// The rig's card.
    pub card: CaptureFormat,
    /// The address listened on (`live.csi_listen`).
    pub listen: SocketAddr,
    /// The array's antennas (a Nexmon frame's cores).
    pub cores: usize,
    /// For FeitCSI: its command socket and the options its measurement starts with.
    pub feitcsi: Option<(SocketAddr, String)>,
}

/// The CSI input `input` describes, on its thread: the CSI Tool's TCP server, the Nexmon
/// receiver of frames of `cores` packets ([`NexmonListener`]) or FeitCSI's client
/// ([`FeitListener`]); its address and thread.
pub fn spawn_csi_input(
    input: &CsiInput,
    tx: SyncSender<LiveInput>,
    clock: HostClock,
    stop: Arc<AtomicBool>,
    limits: CsiServerLimits,
) -> io::Result<(SocketAddr, JoinHandle<()>)> {
    let addr = input.listen;
    Ok(match (input.card, &input.feitcsi) {
        (CaptureFormat::Nexmon, _) => {
            let l = NexmonListener::spawn(addr, tx, clock, stop, limits, input.cores)?;
            (l.local_addr, l.thread)
        }
        (CaptureFormat::FeitCsi, Some((server, options))) => {
            let l = FeitListener::spawn(addr, *server, options, tx, clock, stop, limits)?;
            (l.local_addr, l.thread)
        }
        _ => {
            let s = CsiServer::spawn(addr, tx, clock, stop, limits)?;
            (s.local_addr, s.thread)
        }
    })
}
