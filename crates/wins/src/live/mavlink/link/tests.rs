use super::*;
use ::mavlink::dialects::common::HEARTBEAT_DATA;
use ::mavlink::{MAVLinkMessageRaw, MavlinkReader, MavlinkVersion};
use std::net::UdpSocket;
use std::time::Duration;

use crate::live::mavlink::signing::Refusal;

#[test]
fn parses_every_form_and_prints_it_canonically() {
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
    // A device path with colons (Linux's /dev/serial/by-path names) is the device.
    assert_eq!(
        "serial:/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0:921600"
            .parse::<MavlinkUrl>()
            .unwrap(),
        MavlinkUrl::Serial {
            device: "/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0".into(),
            baud: 921_600
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
    ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, fc_header, &heartbeat).unwrap();
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

/// A HEARTBEAT whose `custom_mode` tells it apart.
fn marked(mark: u32) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: mark,
        ..HEARTBEAT_DATA::default()
    })
}

fn fc_header() -> MavHeader {
    MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: 0,
    }
}

fn unsigned(mark: u32) -> Vec<u8> {
    let mut bytes = Vec::new();
    ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, fc_header(), &marked(mark))
        .unwrap();
    bytes
}

fn signed(signer: &Signer, mark: u32) -> Vec<u8> {
    signer.sign(fc_header(), &marked(mark)).raw_bytes().to_vec()
}

/// The one frame of a datagram received on `socket`, and where it came from.
fn receive(socket: &UdpSocket) -> (MAVLinkMessageRaw, std::net::SocketAddr) {
    let mut buffer = [0_u8; 512];
    let (n, from) = socket.recv_from(&mut buffer).unwrap();
    let frame = MavlinkReader::new(buffer.get(..n).unwrap())
        .read_any_raw_message::<MavMessage>()
        .unwrap();
    (frame, from)
}

#[test]
fn a_signed_udpin_link_takes_only_signed_messages_and_signs_its_replies() {
    let key = MavlinkKey::from_bytes([42; 32]);
    let port = free_udp_port();
    let url: MavlinkUrl = format!("udpin:127.0.0.1:{port}").parse().unwrap();
    let link = open_signed(&url, 1, DEFAULT_COMPONENT_ID, Some(key.clone())).unwrap();
    let fc = UdpSocket::bind("127.0.0.1:0").unwrap();
    let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
    fc.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    stranger
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let fc_signer = Signer::new(key);
    let to = ("127.0.0.1", port);

    // Unsigned and wrongly signed messages claiming to be the vehicle: refused, and they do not
    // take the replies.
    stranger.send_to(&unsigned(1), to).unwrap();
    let wrong = Signer::new(MavlinkKey::from_bytes([43; 32]));
    stranger.send_to(&signed(&wrong, 2), to).unwrap();
    let valid = signed(&fc_signer, 3);
    fc.send_to(&valid, to).unwrap();
    assert_eq!(link.recv().unwrap().1, marked(3));
    // The same bytes again (a replay) and a fresh one: only the fresh one comes.
    fc.send_to(&valid, to).unwrap();
    fc.send_to(&signed(&fc_signer, 4), to).unwrap();
    assert_eq!(link.recv().unwrap().1, marked(4));
    let counts = link.signing_counts().unwrap();
    assert_eq!(
        (
            counts.unsigned,
            counts.bad_signature,
            counts.replayed,
            counts.accepted
        ),
        (1, 1, 1, 2)
    );

    // The reply goes to the vehicle, signed with the key.
    assert!(link.send(&marked(5)).unwrap() > 0);
    let (reply, from) = receive(&fc);
    assert_eq!(from.port(), port);
    assert_eq!(fc_signer.check(&reply), Ok(()));
    assert_eq!((reply.system_id(), reply.component_id()), (1, 197));
    let mut buffer = [0_u8; 64];
    assert!(
        stranger.recv_from(&mut buffer).is_err(),
        "nothing to the stranger"
    );
}

#[test]
fn a_signed_udpout_link_signs_and_takes_only_signed_messages() {
    let key = MavlinkKey::from_bytes([7; 32]);
    let listener = UdpSocket::bind("127.0.0.1:0").unwrap();
    listener
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let port = listener.local_addr().unwrap().port();
    let url: MavlinkUrl = format!("udpout:127.0.0.1:{port}").parse().unwrap();
    let link = open_signed(&url, 1, DEFAULT_COMPONENT_ID, Some(key.clone())).unwrap();
    let fc_signer = Signer::new(key);
    assert!(link.send(&marked(1)).unwrap() > 0);
    assert!(link.send(&marked(2)).unwrap() > 0);
    let (first, link_addr) = receive(&listener);
    let (second, _) = receive(&listener);
    assert_eq!(
        (fc_signer.check(&first), fc_signer.check(&second)),
        (Ok(()), Ok(()))
    );
    assert_eq!((first.sequence(), second.sequence()), (0, 1));
    assert_eq!(fc_signer.check(&first), Err(Refusal::Replayed));

    listener.send_to(&unsigned(3), link_addr).unwrap();
    listener.send_to(&signed(&fc_signer, 4), link_addr).unwrap();
    assert_eq!(link.recv().unwrap().1, marked(4));
    let counts = link.signing_counts().unwrap();
    assert_eq!(
        (counts.unsigned, counts.accepted, counts.signed_out),
        (1, 1, 2)
    );
}

#[test]
fn without_a_key_nothing_is_signed_or_counted() {
    let listener = UdpSocket::bind("127.0.0.1:0").unwrap();
    listener
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let port = listener.local_addr().unwrap().port();
    let url: MavlinkUrl = format!("udpout:127.0.0.1:{port}").parse().unwrap();
    let link = open(&url, 1, DEFAULT_COMPONENT_ID).unwrap();
    assert!(link.send(&marked(1)).unwrap() > 0);
    let (frame, link_addr) = receive(&listener);
    let MAVLinkMessageRaw::V2(frame) = frame else {
        panic!("MAVLink 2")
    };
    assert_eq!(frame.incompatibility_flags(), 0, "not signed");
    assert_eq!(link.signing_counts(), None);
    listener.send_to(&unsigned(2), link_addr).unwrap();
    assert_eq!(link.recv().unwrap().1, marked(2));
}
