//! The MAVLink connection to the flight controller: its address ([`MavlinkUrl`]) and opening it
//! ([`open`]).
//!
//! Addresses are the usual connection strings:
//!
//! | form | meaning |
//! |---|---|
//! | `udpin:HOST:PORT` | listen on HOST:PORT; replies go to the address the vehicle's messages come from, so one link works both ways (what a flight controller's `udpout`/telemetry forwarding talks to); another sender never takes the replies ([`super::udp_in`]) |
//! | `udpout:HOST:PORT` | send to HOST:PORT from an ephemeral port; read what comes back |
//! | `tcp:HOST:PORT` (or `tcpout:`) | TCP client |
//! | `tcpin:HOST:PORT` | TCP server, waits for one client |
//! | `serial:DEVICE:BAUD` | serial port, e.g. `serial:/dev/ttyACM0:921600` |

use std::fmt;
use std::str::FromStr;

use ::mavlink::dialects::common::{MavComponent, MavMessage};
use ::mavlink::error::{MessageReadError, MessageWriteError};
use ::mavlink::{MavConnection, MavHeader, MavlinkVersion};

use super::udp_in::UdpIn;

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
    /// A device name with a `:` (the mavlink crate splits at the first `:`).
    #[error(
        "MAVLink address `{url}`: the serial device `{device}` contains `:`, which cannot be passed on"
    )]
    DeviceWithColon {
        /// The address given.
        url: String,
        /// The device text.
        device: String,
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
            if device.contains(':') {
                return Err(MavlinkUrlError::DeviceWithColon {
                    url: owned(),
                    device: device.to_string(),
                });
            }
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
    /// The mavlink crate's connection string (`tcp:` is written `tcpout:`).
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

/// The mavlink crate's blocking connection, boxed, for the common dialect.
pub type FcConnection = Box<dyn MavConnection<MavMessage> + Send + Sync>;

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
    /// A message could not be sent.
    #[error("cannot send MAVLink message: {0}")]
    Send(#[from] MessageWriteError),
    /// A message could not be received.
    #[error("cannot receive MAVLink message: {0}")]
    Recv(#[from] MessageReadError),
    /// The socket failed.
    #[error("MAVLink socket: {0}")]
    Io(std::io::Error),
}

/// An open link: the connection and the header our messages go out with.
pub struct MavlinkLink {
    transport: Transport,
    /// Our system and component ids (the sequence number is the connection's).
    pub header: MavHeader,
}

/// What carries the bytes.
enum Transport {
    /// The mavlink crate's connection (MAVLink 2 out; MAVLink 1 or 2 accepted in).
    Crate(FcConnection),
    /// Our UDP server for `udpin:`.
    UdpIn(UdpIn),
}

impl MavlinkLink {
    /// Sends one message with our ids; returns the bytes written (0 when a `udpin` link has not
    /// heard from a peer yet, so there is nobody to answer).
    pub fn send(&self, message: &MavMessage) -> Result<usize, LinkError> {
        match &self.transport {
            Transport::Crate(c) => Ok(c.send(&self.header, message)?),
            Transport::UdpIn(u) => Ok(u.send(&self.header, message).map_err(LinkError::Io)?),
        }
    }

    /// Blocks until one message arrives.
    pub fn recv(&self) -> Result<(MavHeader, MavMessage), LinkError> {
        match &self.transport {
            Transport::Crate(c) => Ok(c.recv()?),
            Transport::UdpIn(u) => u.recv().map_err(LinkError::Io),
        }
    }

    /// Datagrams dropped for holding no CRC-valid message (`udpin:` only; 0 otherwise).
    pub fn garbage_datagrams(&self) -> u64 {
        match &self.transport {
            Transport::Crate(_) => 0,
            Transport::UdpIn(u) => u.garbage_datagrams(),
        }
    }
}

impl fmt::Debug for MavlinkLink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MavlinkLink")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

/// Opens the link: MAVLink 2 for what we send (ODOMETRY needs it), either version accepted for
/// what we receive, our messages sent as `system_id` / `component_id` (usually the flight
/// controller's system id and [`DEFAULT_COMPONENT_ID`]). A `udpin:` link answers the vehicle
/// `system_id` only ([`super::udp_in`]).
pub fn open(url: &MavlinkUrl, system_id: u8, component_id: u8) -> Result<MavlinkLink, LinkError> {
    let header = MavHeader {
        system_id: u32::from(system_id),
        component_id,
        sequence: 0,
    };
    let text = url.to_string();
    if let MavlinkUrl::UdpIn { host, port } = url {
        let addr = if host.contains(':') && !host.starts_with('[') {
            format!("[{host}]:{port}")
        } else {
            format!("{host}:{port}")
        };
        let server = UdpIn::bind(&addr, system_id)
            .map_err(|source| LinkError::Open { url: text, source })?;
        return Ok(MavlinkLink {
            transport: Transport::UdpIn(server),
            header,
        });
    }
    let mut connection = ::mavlink::connect::<MavMessage>(&text)
        .map_err(|source| LinkError::Open { url: text, source })?;
    connection.set_protocol_version(MavlinkVersion::V2);
    connection.set_allow_recv_any_version(true);
    Ok(MavlinkLink {
        transport: Transport::Crate(Box::new(connection)),
        header,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::mavlink::MavlinkReader;
    use ::mavlink::dialects::common::HEARTBEAT_DATA;
    use std::net::UdpSocket;
    use std::time::Duration;

    #[test]
    fn parses_every_form_and_prints_the_crate_string() {
        let cases = [
            ("udpin:0.0.0.0:14550", "udpin:0.0.0.0:14550"),
            ("udpout:192.168.1.2:14555", "udpout:192.168.1.2:14555"),
            ("tcp:127.0.0.1:5760", "tcpout:127.0.0.1:5760"),
            ("tcpout:localhost:5760", "tcpout:localhost:5760"),
            ("tcpin:0.0.0.0:5761", "tcpin:0.0.0.0:5761"),
            ("serial:/dev/ttyACM0:921600", "serial:/dev/ttyACM0:921600"),
            ("UDPIN:[::1]:14550", "udpin:[::1]:14550"),
        ];
        for (text, shown) in cases {
            let url: MavlinkUrl = text.parse().unwrap();
            assert_eq!(url.to_string(), shown);
            assert_eq!(shown.parse::<MavlinkUrl>().unwrap(), url);
        }
        assert_eq!(
            "serial:COM3:57600".parse::<MavlinkUrl>().unwrap(),
            MavlinkUrl::Serial {
                device: "COM3".into(),
                baud: 57600
            }
        );
    }

    #[test]
    fn errors_say_what_is_wrong_and_list_the_forms() {
        let cases = [
            ("14550", "no scheme"),
            ("udp:1.2.3.4:14550", "unknown scheme `udp`"),
            ("udpin:14550", "expected HOST:PORT"),
            ("udpout::14550", "host is empty"),
            ("tcp:host:port", "port `port`"),
            ("tcp:host:0", "port `0`"),
            ("udpin:host:70000", "port `70000`"),
            ("serial:/dev/ttyS0", "expected serial:DEVICE:BAUD"),
            ("serial::57600", "expected serial:DEVICE:BAUD"),
            ("serial:/dev/ttyS0:fast", "baud rate `fast`"),
            ("serial:a:b:57600", "contains `:`"),
        ];
        for (text, needle) in cases {
            let message = text.parse::<MavlinkUrl>().unwrap_err().to_string();
            assert!(message.contains(needle), "{text}: {message}");
            if !needle.contains("contains") {
                assert!(message.contains("udpin:HOST:PORT"), "{message}");
                assert!(message.contains("serial:DEVICE:BAUD"), "{message}");
            }
        }
    }

    /// A free local UDP port (bound and released).
    fn free_udp_port() -> u16 {
        UdpSocket::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    }

    #[test]
    fn udpin_answers_the_sender_on_one_socket() {
        let port = free_udp_port();
        let url: MavlinkUrl = format!("udpin:127.0.0.1:{port}").parse().unwrap();
        let link = open(&url, 1, DEFAULT_COMPONENT_ID).unwrap();
        // Nobody to answer yet: nothing is sent.
        let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        assert_eq!(link.send(&heartbeat).unwrap(), 0);

        // A "flight controller" on its own socket sends one message to us.
        let fc = UdpSocket::bind("127.0.0.1:0").unwrap();
        fc.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut bytes = Vec::new();
        let fc_header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 7,
        };
        ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, fc_header, &heartbeat)
            .unwrap();
        fc.send_to(&bytes, ("127.0.0.1", port)).unwrap();
        let (header, message) = link.recv().unwrap();
        assert_eq!(header.system_id, 1);
        assert!(matches!(message, MavMessage::HEARTBEAT(_)));

        // Our reply reaches the sender's address, as MAVLink 2 with our ids.
        assert!(link.send(&heartbeat).unwrap() > 0);
        let mut buffer = [0_u8; 512];
        let (n, from) = fc.recv_from(&mut buffer).unwrap();
        assert_eq!(from.port(), port);
        let slice = buffer.get(..n).unwrap();
        let mut reader = MavlinkReader::new(slice);
        let (reply_header, reply) = reader
            .read_message::<MavMessage>(MavlinkVersion::V2)
            .unwrap();
        assert_eq!(reply_header.system_id, 1);
        assert_eq!(reply_header.component_id, 197);
        assert!(matches!(reply, MavMessage::HEARTBEAT(_)));
    }

    #[test]
    fn udpout_reaches_a_listener() {
        let listener = UdpSocket::bind("127.0.0.1:0").unwrap();
        listener
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let port = listener.local_addr().unwrap().port();
        let url: MavlinkUrl = format!("udpout:127.0.0.1:{port}").parse().unwrap();
        let link = open(&url, 1, DEFAULT_COMPONENT_ID).unwrap();
        let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
        assert!(link.send(&heartbeat).unwrap() > 0);
        let mut buffer = [0_u8; 512];
        let n = listener.recv(&mut buffer).unwrap();
        assert_eq!(buffer.first(), Some(&0xFD), "MAVLink 2 start byte");
        assert!(n > 10);
    }

    #[test]
    fn opening_a_busy_port_is_an_error_naming_it() {
        let busy = UdpSocket::bind("127.0.0.1:0").unwrap();
        let port = busy.local_addr().unwrap().port();
        let url: MavlinkUrl = format!("udpin:127.0.0.1:{port}").parse().unwrap();
        let error = open(&url, 1, DEFAULT_COMPONENT_ID).unwrap_err().to_string();
        assert!(
            error.contains(&format!("udpin:127.0.0.1:{port}")),
            "{error}"
        );
    }
}
