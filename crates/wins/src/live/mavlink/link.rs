//! The MAVLink connection to the flight controller: its address ([`MavlinkUrl`]) and opening it
//! ([`open`]). The transports are ours ([`super::udp`], [`super::stream`]): the mavlink crate
//! encodes and decodes, and every byte that arrives is accounted for ([`super::framer`]).
//!
//! Addresses are the usual connection strings:
//!
//! | form | meaning |
//! |---|---|
//! | `udpin:HOST:PORT` | listen on HOST:PORT; replies go to the address the vehicle's messages come from, so one link works both ways (what a flight controller's `udpout`/telemetry forwarding talks to); another sender never takes the replies ([`super::udp`]) |
//! | `udpout:HOST:PORT` | send to HOST:PORT from an ephemeral port; read what comes back from there only |
//! | `tcp:HOST:PORT` (or `tcpout:`) | TCP client; connects again when the connection ends |
//! | `tcpin:HOST:PORT` | TCP server, one client at a time; the next one when it leaves |
//! | `serial:DEVICE:BAUD` | serial port, e.g. `serial:/dev/ttyACM0:921600`; opened again when it goes away |

use std::fmt;
use std::net::TcpListener;
use std::str::FromStr;
use std::sync::Arc;

use ::mavlink::MavHeader;
use ::mavlink::dialects::common::{MavComponent, MavMessage};
use serde::Serialize;

use super::framer::FrameCounts;
use super::signing::{MavlinkKey, Signer, SigningCounts};
use super::stream::{Endpoint, StreamLink};
use super::udp::UdpLink;

/// The component id a WiFi-inertial odometry source uses by default:
/// `MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY` (197).
pub const DEFAULT_COMPONENT_ID: u8 = MavComponent::MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY as u8;

/// The accepted forms, quoted by every parse error.
const ACCEPTED: &str = "accepted forms: udpin:HOST:PORT (listen; replies go to the sender), \
                        udpout:HOST:PORT, tcp:HOST:PORT (= tcpout:), tcpin:HOST:PORT, \
                        serial:DEVICE:BAUD";

/// Where the flight controller is (see the module documentation for the forms).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MavlinkUrl {
    /// `udpin:HOST:PORT`: listen, answer the peer that sent the last datagram.
    UdpIn {
        /// Local address to bind (`0.0.0.0` for every interface).
        host: String,
        /// Local UDP port.
        port: u16,
    },
    /// `udpout:HOST:PORT`: send to a peer.
    UdpOut {
        /// Peer host.
        host: String,
        /// Peer UDP port.
        port: u16,
    },
    /// `tcp:HOST:PORT` or `tcpout:HOST:PORT`: TCP client.
    TcpOut {
        /// Server host.
        host: String,
        /// Server TCP port.
        port: u16,
    },
    /// `tcpin:HOST:PORT`: TCP server.
    TcpIn {
        /// Local address to listen on.
        host: String,
        /// Local TCP port.
        port: u16,
    },
    /// `serial:DEVICE:BAUD`.
    Serial {
        /// Device path (`/dev/ttyACM0`, `COM3`).
        device: String,
        /// Baud rate, bit/s.
        baud: u32,
    },
}

/// Why a MAVLink address could not be parsed; every message lists the accepted forms.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MavlinkUrlError {
    /// No `SCHEME:` prefix.
    #[error("MAVLink address `{url}` has no scheme; {ACCEPTED}")]
    NoScheme {
        /// The address given.
        url: String,
    },
    /// A scheme we do not know.
    #[error("MAVLink address `{url}`: unknown scheme `{scheme}`; {ACCEPTED}")]
    UnknownScheme {
        /// The address given.
        url: String,
        /// Its scheme.
        scheme: String,
    },
    /// Nothing, or no `:PORT`, after the scheme.
    #[error("MAVLink address `{url}`: expected HOST:PORT after `{scheme}:`; {ACCEPTED}")]
    MissingPort {
        /// The address given.
        url: String,
        /// Its scheme.
        scheme: String,
    },
    /// An empty host.
    #[error("MAVLink address `{url}`: the host is empty; {ACCEPTED}")]
    EmptyHost {
        /// The address given.
        url: String,
    },
    /// A port that is not a number in 1..=65535.
    #[error("MAVLink address `{url}`: port `{port}` is not a number from 1 to 65535; {ACCEPTED}")]
    BadPort {
        /// The address given.
        url: String,
        /// The port text.
        port: String,
    },
    /// A serial address without `DEVICE:BAUD`, or with an empty device.
    #[error("MAVLink address `{url}`: expected serial:DEVICE:BAUD; {ACCEPTED}")]
    BadSerial {
        /// The address given.
        url: String,
    },
    /// A baud rate that is not a positive number.
    #[error("MAVLink address `{url}`: baud rate `{baud}` is not a positive number; {ACCEPTED}")]
    BadBaud {
        /// The address given.
        url: String,
        /// The baud text.
        baud: String,
    },
}

impl FromStr for MavlinkUrl {
    type Err = MavlinkUrlError;

    fn from_str(url: &str) -> Result<Self, Self::Err> {
        let url = url.trim();
        let owned = || url.to_string();
        let (scheme, rest) = url
            .split_once(':')
            .ok_or_else(|| MavlinkUrlError::NoScheme { url: owned() })?;
        let scheme_lower = scheme.to_ascii_lowercase();
        if scheme_lower == "serial" {
            let (device, baud_text) = rest
                .rsplit_once(':')
                .filter(|(device, _)| !device.is_empty())
                .ok_or_else(|| MavlinkUrlError::BadSerial { url: owned() })?;
            let baud = baud_text
                .parse::<u32>()
                .ok()
                .filter(|&b| b > 0)
                .ok_or_else(|| MavlinkUrlError::BadBaud {
                    url: owned(),
                    baud: baud_text.to_string(),
                })?;
            return Ok(Self::Serial {
                device: device.to_string(),
                baud,
            });
        }
        let make: fn(String, u16) -> Self = match scheme_lower.as_str() {
            "udpin" => |host, port| Self::UdpIn { host, port },
            "udpout" => |host, port| Self::UdpOut { host, port },
            "tcp" | "tcpout" => |host, port| Self::TcpOut { host, port },
            "tcpin" => |host, port| Self::TcpIn { host, port },
            _ => {
                return Err(MavlinkUrlError::UnknownScheme {
                    url: owned(),
                    scheme: scheme.to_string(),
                });
            }
        };
        let (host, port_text) =
            rest.rsplit_once(':')
                .ok_or_else(|| MavlinkUrlError::MissingPort {
                    url: owned(),
                    scheme: scheme.to_string(),
                })?;
        if host.is_empty() {
            return Err(MavlinkUrlError::EmptyHost { url: owned() });
        }
        let port = port_text
            .parse::<u16>()
            .ok()
            .filter(|&p| p > 0)
            .ok_or_else(|| MavlinkUrlError::BadPort {
                url: owned(),
                port: port_text.to_string(),
            })?;
        Ok(make(host.to_string(), port))
    }
}

impl fmt::Display for MavlinkUrl {
    /// The address in its canonical form (`tcp:` is written `tcpout:`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UdpIn { host, port } => write!(f, "udpin:{host}:{port}"),
            Self::UdpOut { host, port } => write!(f, "udpout:{host}:{port}"),
            Self::TcpOut { host, port } => write!(f, "tcpout:{host}:{port}"),
            Self::TcpIn { host, port } => write!(f, "tcpin:{host}:{port}"),
            Self::Serial { device, baud } => write!(f, "serial:{device}:{baud}"),
        }
    }
}

/// Errors of the link.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The connection could not be opened (address in use, no such device, refused, …).
    #[error("cannot open MAVLink connection `{url}`: {source}")]
    Open {
        /// The connection string.
        url: String,
        /// The system's reason.
        source: std::io::Error,
    },
    /// The connection failed or ended.
    #[error("MAVLink link: {0}")]
    Io(#[from] std::io::Error),
}

/// What arrived on a link, counted (`stats.json`'s `mavlink_link`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct LinkCounts {
    /// Frames, garbage bytes, bad CRCs and unknown messages ([`super::framer`]).
    #[serde(flatten)]
    pub frames: FrameCounts,
    /// UDP datagrams without a single CRC-valid frame, dropped whole.
    pub garbage_datagrams: u64,
    /// Stream connections that ended (each made again).
    pub connections_lost: u64,
}

impl LinkCounts {
    /// Whether anything went wrong on the link (unknown messages are a dialect's, not faults).
    pub fn any_fault(&self) -> bool {
        self.frames.garbage_bytes + self.frames.bad_crc + self.connections_lost > 0
    }
}

/// An open link: the transport, the header our messages go out with, and the signing key's
/// signer when one is given ([`super::signing`]).
pub struct MavlinkLink {
    transport: Transport,
    /// Our system and component ids (the sequence number is the transport's).
    pub header: MavHeader,
    signer: Option<Arc<Signer>>,
}

/// What carries the bytes.
enum Transport {
    /// `udpin:` and `udpout:`.
    Udp(UdpLink),
    /// `tcp:`, `tcpin:` and `serial:`.
    Stream(StreamLink),
}

impl MavlinkLink {
    /// Sends one message with our ids, signed when the link has a key; returns the bytes written
    /// (0 when there is nobody to answer yet: a `udpin` link that has not heard from the vehicle,
    /// a stream between connections).
    pub fn send(&self, message: &MavMessage) -> Result<usize, LinkError> {
        Ok(match &self.transport {
            Transport::Udp(u) => u.send(&self.header, message)?,
            Transport::Stream(s) => s.send(&self.header, message)?,
        })
    }

    /// Blocks until one message arrives; with a key, one whose signature holds (the others are
    /// refused and counted, [`Self::signing_counts`]).
    pub fn recv(&self) -> Result<(MavHeader, MavMessage), LinkError> {
        Ok(match &self.transport {
            Transport::Udp(u) => u.recv()?,
            Transport::Stream(s) => s.recv()?,
        })
    }

    /// What arrived on the link, counted.
    pub fn counts(&self) -> LinkCounts {
        match &self.transport {
            Transport::Udp(u) => LinkCounts {
                frames: u.frame_counts(),
                garbage_datagrams: u.garbage_datagrams(),
                connections_lost: 0,
            },
            Transport::Stream(s) => LinkCounts {
                frames: s.frame_counts(),
                garbage_datagrams: 0,
                connections_lost: s.connections_lost(),
            },
        }
    }

    /// The signed traffic's counts (`None` without a key).
    pub fn signing_counts(&self) -> Option<SigningCounts> {
        self.signer.as_ref().map(|s| s.counts())
    }
}

impl fmt::Debug for MavlinkLink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MavlinkLink")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

/// Opens the link without signing: [`open_signed`] with no key.
pub fn open(url: &MavlinkUrl, system_id: u8, component_id: u8) -> Result<MavlinkLink, LinkError> {
    open_signed(url, system_id, component_id, None)
}

/// Opens the link: MAVLink 2 for what we send (ODOMETRY needs it), either version accepted for
/// what we receive, our messages sent as `system_id` / `component_id` (usually the flight
/// controller's system id and [`DEFAULT_COMPONENT_ID`]). A `udpin:` link answers the vehicle
/// `system_id` only ([`super::udp`]). With `key`, every message sent is signed and only
/// messages signed with it are received ([`super::signing`]).
pub fn open_signed(
    url: &MavlinkUrl,
    system_id: u8,
    component_id: u8,
    key: Option<MavlinkKey>,
) -> Result<MavlinkLink, LinkError> {
    let header = MavHeader {
        system_id: u32::from(system_id),
        component_id,
        sequence: 0,
    };
    let signer = key.map(|k| Arc::new(Signer::new(k)));
    let text = url.to_string();
    let open_error = |source| LinkError::Open {
        url: text.clone(),
        source,
    };
    let address = |host: &str, port: &u16| {
        if host.contains(':') && !host.starts_with('[') {
            format!("[{host}]:{port}")
        } else {
            format!("{host}:{port}")
        }
    };
    let transport = match url {
        MavlinkUrl::UdpIn { host, port } => Transport::Udp(
            UdpLink::bind(&address(host, port), system_id, signer.clone()).map_err(open_error)?,
        ),
        MavlinkUrl::UdpOut { host, port } => Transport::Udp(
            UdpLink::connect(&address(host, port), system_id, signer.clone())
                .map_err(open_error)?,
        ),
        MavlinkUrl::TcpOut { host, port } => Transport::Stream(
            StreamLink::open(Endpoint::TcpOut(address(host, port)), signer.clone())
                .map_err(open_error)?,
        ),
        MavlinkUrl::TcpIn { host, port } => {
            let listener = TcpListener::bind(address(host, port)).map_err(open_error)?;
            Transport::Stream(
                StreamLink::open(Endpoint::TcpIn(listener), signer.clone()).map_err(open_error)?,
            )
        }
        MavlinkUrl::Serial { device, baud } => Transport::Stream(
            StreamLink::open(
                Endpoint::Serial {
                    device: device.clone(),
                    baud: *baud,
                },
                signer.clone(),
            )
            .map_err(open_error)?,
        ),
    };
    Ok(MavlinkLink {
        transport,
        header,
        signer,
    })
}

#[cfg(test)]
mod tests;
