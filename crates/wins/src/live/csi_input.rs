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
use super::feitcsi_udp::{FeitListener, feitcsi_start};
use super::nexmon_udp::NexmonListener;
use super::{HostClock, LiveInput};
use crate::config::live::LiveConfig;
use crate::csi::format::CaptureFormat;
use crate::dataset::manifest::Manifest;

/// The cards whose live streams `wins live` takes.
pub const LIVE_CARDS: [CaptureFormat; 3] = [
    CaptureFormat::Intel5300,
    CaptureFormat::Nexmon,
    CaptureFormat::FeitCsi,
];

/// What sends a rig's CSI, with what its input needs to know.
#[derive(Clone, Debug, PartialEq)]
pub enum CsiSource {
    /// The CSI Tool's `log_to_server` (TCP).
    Intel5300,
    /// nexmon_csi's UDP packets, one per core of each frame of `cores` packets.
    Nexmon {
        /// The array's antennas (a frame's cores).
        cores: usize,
    },
    /// FeitCSI's UDP stream.
    FeitCsi {
        /// Its command socket.
        server: SocketAddr,
        /// The options its measurement starts with.
        options: String,
    },
}

/// Where and how a rig's CSI comes in.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiInput {
    /// The address listened on (`live.csi_listen`).
    pub listen: SocketAddr,
    /// What sends it.
    pub source: CsiSource,
}

impl CsiInput {
    /// The input of the rig `manifest` describes, listening on `listen`, with the `[live]`
    /// settings `live`; an error in words for a card without a live stream ([`LIVE_CARDS`]) or
    /// a FeitCSI server that is not an address.
    pub fn for_rig(
        manifest: &Manifest,
        listen: SocketAddr,
        live: &LiveConfig,
    ) -> Result<Self, String> {
        let source = match manifest.array.card {
            CaptureFormat::Intel5300 => CsiSource::Intel5300,
            CaptureFormat::Nexmon => CsiSource::Nexmon {
                cores: manifest.array.geometry.num_antennas,
            },
            CaptureFormat::FeitCsi => {
                let (server, options) = feitcsi_start(live, &manifest.channel)?;
                CsiSource::FeitCsi { server, options }
            }
            card => {
                return Err(format!(
                    "the rig's card is {card}: wins live takes the Intel 5300's TCP stream (the \
                     CSI Tool's log_to_server), Nexmon's UDP packets and FeitCSI's UDP stream only"
                ));
            }
        };
        Ok(Self { listen, source })
    }
}

/// The CSI input `input` describes, on its thread: the CSI Tool's TCP server, the Nexmon
/// receiver of whole frames ([`NexmonListener`]) or FeitCSI's client ([`FeitListener`]); its
/// address and thread.
pub fn spawn_csi_input(
    input: &CsiInput,
    tx: SyncSender<LiveInput>,
    clock: HostClock,
    stop: Arc<AtomicBool>,
    limits: CsiServerLimits,
) -> io::Result<(SocketAddr, JoinHandle<()>)> {
    let addr = input.listen;
    Ok(match &input.source {
        CsiSource::Intel5300 => {
            let s = CsiServer::spawn(addr, tx, clock, stop, limits)?;
            (s.local_addr, s.thread)
        }
        CsiSource::Nexmon { cores } => {
            let l = NexmonListener::spawn(addr, tx, clock, stop, limits, *cores)?;
            (l.local_addr, l.thread)
        }
        CsiSource::FeitCsi { server, options } => {
            let l = FeitListener::spawn(addr, *server, options, tx, clock, stop, limits)?;
            (l.local_addr, l.thread)
        }
    })
}
