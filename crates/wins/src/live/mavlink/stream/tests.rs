#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::time::Duration;

use ::mavlink::dialects::common::{HEARTBEAT_DATA, SYSTEM_TIME_DATA};
use ::mavlink::{MavHeader, MavlinkReader, MavlinkVersion};

use super::*;

fn frame(sequence: u8) -> Vec<u8> {
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence,
    };
    let message = MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
        time_unix_usec: 0,
        time_boot_ms: u32::from(sequence),
    });
    let mut bytes = Vec::new();
    ::mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &message).unwrap();
    bytes
}

fn ours() -> MavHeader {
    MavHeader {
        system_id: 1,
        component_id: 197,
        sequence: 0,
    }
}

/// A flight controller's side of a TCP link that writes `bytes` and then closes.
fn write_and_close(mut fc: TcpStream, bytes: &[u8]) {
    fc.write_all(bytes).unwrap();
    fc.flush().unwrap();
}

#[test]
fn tcp_garbage_and_bad_crcs_are_counted_and_a_closed_connection_is_made_again() {
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = server.local_addr().unwrap().to_string();
    let link = StreamLink::open(Endpoint::TcpOut(addr), None).unwrap();
    let (fc, _) = server.accept().unwrap();
    fc.set_read_timeout(Some(Duration::from_secs(5))).unwrap();

    // Our message reaches the flight controller.
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
    assert!(link.send(&ours(), &heartbeat).unwrap() > 0);
    let mut reader = MavlinkReader::new(fc.try_clone().unwrap());
    let (h, _) = reader.read_any_message::<MavMessage>().unwrap();
    assert_eq!((h.system_id, h.component_id), (1, 197));
    drop(reader);

    let mut corrupt = frame(1);
    corrupt[11] ^= 1;
    let mut bytes = frame(0);
    bytes.extend([0x00, 0x55, 0xAA, 0x42, 0x13]);
    bytes.extend(&corrupt);
    bytes.extend(frame(2));
    write_and_close(fc, &bytes);
    assert_eq!(link.recv().unwrap().0.sequence, 0);
    assert_eq!(link.recv().unwrap().0.sequence, 2);
    let e = link.recv().expect_err("the connection closed");
    assert_eq!(e.kind(), io::ErrorKind::UnexpectedEof);
    let c = link.frame_counts();
    assert_eq!((c.frames, c.bad_crc), (2, 1));
    assert_eq!(c.garbage_bytes, 5 + corrupt.len() as u64);
    assert_eq!(link.connections_lost(), 1);
    assert_eq!(
        link.send(&ours(), &heartbeat).unwrap(),
        0,
        "nobody to send to"
    );

    // The next receive connects again.
    let again = thread::spawn(move || {
        let (fc, _) = server.accept().unwrap();
        write_and_close(fc, &frame(3));
    });
    assert_eq!(link.recv().unwrap().0.sequence, 3);
    again.join().unwrap();
}

#[test]
fn tcpin_takes_the_next_client_after_one_leaves() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let link = StreamLink::open(Endpoint::TcpIn(listener), None).unwrap();
    let clients = thread::spawn(move || {
        for s in [5, 6] {
            write_and_close(TcpStream::connect(addr).unwrap(), &frame(s));
        }
    });
    assert_eq!(link.recv().unwrap().0.sequence, 5);
    assert!(link.recv().is_err(), "the first client left");
    assert_eq!(link.recv().unwrap().0.sequence, 6);
    clients.join().unwrap();
    assert_eq!(link.frame_counts().frames, 2);
}

#[test]
fn a_serial_device_that_is_not_there_is_an_error_at_open() {
    let e = StreamLink::open(
        Endpoint::Serial {
            device: "/dev/wins-no-such-serial-device".into(),
            baud: 57_600,
        },
        None,
    )
    .expect_err("no such device");
    assert!(!e.to_string().is_empty());
}
