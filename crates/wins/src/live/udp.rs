//! What the UDP inputs of a live session (Nexmon's packets, FeitCSI's records) share: a receive
//! that wakes up every [`POLL`] to look at the stop flag, and the largest datagram read.

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::thread;
use std::time::Duration;

/// How often a blocked receive looks at the stop flag.
pub(super) const POLL: Duration = Duration::from_millis(50);
/// The largest datagram read (a UDP datagram's most).
pub(super) const MAX_DATAGRAM: usize = 1 << 16;

/// Binds `addr` for a receive loop (reads time out after [`POLL`]).
pub(super) fn bind(addr: SocketAddr) -> io::Result<UdpSocket> {
    let socket = UdpSocket::bind(addr)?;
    socket.set_read_timeout(Some(POLL))?;
    Ok(socket)
}

/// The next datagram into `buf`, its length and sender; `None` when none came within [`POLL`],
/// or after a transient error (an ICMP unreachable reported on the socket), which is waited out.
pub(super) fn receive(socket: &UdpSocket, buf: &mut [u8]) -> Option<(usize, SocketAddr)> {
    match socket.recv_from(buf) {
        Ok(got) => Some(got),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            ) =>
        {
            None
        }
        Err(_) => {
            thread::sleep(POLL);
            None
        }
    }
}
