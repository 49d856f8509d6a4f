//! The CSI input of a live session, chosen by the rig's card: the CSI Tool's TCP server for an
//! Intel 5300 ([`CsiServer`]), the UDP receiver of nexmon_csi's packets for a Nexmon rig
//! ([`NexmonListener`]).

use std::io;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::SyncSender;
use std::thread::JoinHandle;

use super::csi_server::{CsiServer, CsiServerLimits};
use super::nexmon_udp::NexmonListener;
use super::{HostClock, LiveInput};
use crate::csi::format::CaptureFormat;

/// The cards whose live streams `wins live` takes.
pub const LIVE_CARDS: [CaptureFormat; 2] = [CaptureFormat::Intel5300, CaptureFormat::Nexmon];

/// The CSI input of a rig of `card` on `addr`: the CSI Tool's TCP server, or for Nexmon the UDP
/// receiver of frames of `cores` packets ([`NexmonListener`]); its address and thread.
pub fn spawn_csi_input(
    card: CaptureFormat,
    addr: SocketAddr,
    tx: SyncSender<LiveInput>,
    clock: HostClock,
    stop: Arc<AtomicBool>,
    limits: CsiServerLimits,
    cores: usize,
) -> io::Result<(SocketAddr, JoinHandle<()>)> {
    Ok(match card {
        CaptureFormat::Nexmon => {
            let l = NexmonListener::spawn(addr, tx, clock, stop, limits, cores)?;
            (l.local_addr, l.thread)
        }
        _ => {
            let s = CsiServer::spawn(addr, tx, clock, stop, limits)?;
            (s.local_addr, s.thread)
        }
    })
}
