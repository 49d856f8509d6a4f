use std::net::UdpSocket;
use std::sync::mpsc;

use super::*;
use crate::csi::feitcsi::{encode_record, test_record};

fn datagram(mu_clock: u32) -> Vec<u8> {
    let mut bytes = Vec::new();
    encode_record(&test_record(mu_clock), &mut bytes);
    bytes
}

/// Against a stand-in for FeitCSI on the loopback: the start command reaches it (and comes
/// again while it has not answered), its records come back as records of their transmitter on
/// the card's clock, a stray datagram from it is counted, a stranger is refused, and the stop
/// flag sends `stop`.
#[test]
fn the_server_is_started_its_records_handed_on_and_stopped() {
    let server = UdpSocket::bind("127.0.0.1:0").unwrap();
    server
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let (tx, rx) = mpsc::sync_channel(64);
    let stop = Arc::new(AtomicBool::new(false));
    let listener = FeitListener::spawn(
        "127.0.0.1:0".parse().unwrap(),
        server.local_addr().unwrap(),
        " -f 5180 -w 20 -r HT ",
        tx,
        HostClock::new(),
        Arc::clone(&stop),
        CsiServerLimits::default(),
    )
    .unwrap();
    let mut buf = [0u8; 256];
    let (n, client) = server.recv_from(&mut buf).unwrap();
    assert_eq!(&buf[..n], b"feitcsi -f 5180 -w 20 -r HT");
    assert_eq!(client, listener.local_addr);
    // Not answered yet: the command comes again.
    let (n, _) = server.recv_from(&mut buf).unwrap();
    assert_eq!(&buf[..n], b"feitcsi -f 5180 -w 20 -r HT");
    server.send_to(&datagram(1_000), client).unwrap();
    server.send_to(b"not a record", client).unwrap();
    let stranger = UdpSocket::bind("127.0.0.1:0").unwrap();
    stranger.send_to(&datagram(2_000), client).unwrap();
    let mut events = Vec::new();
    while events.len() < 4 {
        match rx.recv_timeout(Duration::from_secs(5)) {
            Ok(LiveInput::Csi(e)) => events.push(e),
            Ok(_) => {}
            Err(e) => panic!("{e}: {events:?}"),
        }
    }
    stop.store(true, Ordering::Relaxed);
    listener.thread.join().unwrap();
    let (n, _) = server.recv_from(&mut buf).unwrap();
    assert_eq!(&buf[..n], b"stop");
    assert!(matches!(events[0], CsiEvent::Connected { conn: 0, .. }));
    let CsiEvent::Record {
        record,
        transmitter,
        ..
    } = &events[1]
    else {
        panic!("{:?}", events[1])
    };
    assert_eq!(record.nic_time_ns(), 1_000_000);
    assert_eq!(*transmitter, Some([2, 0, 0, 0, 0, 1]));
    assert!(matches!(events[2], CsiEvent::NotCsi { conn: 0, bytes: 12 }));
    assert!(
        matches!(&events[3], CsiEvent::Refused { reason, .. } if reason.contains("not the FeitCSI server"))
    );
}

#[test]
fn a_server_outside_the_allowed_peers_is_refused() {
    let limits = CsiServerLimits {
        allowed_peers: vec!["10.0.0.1".parse().unwrap()],
        ..CsiServerLimits::default()
    };
    let server: SocketAddr = "127.0.0.1:8008".parse().unwrap();
    let mut s = FeitServer::new(server, limits);
    let e = s.datagram(&datagram(1), server, 0);
    assert!(
        matches!(&e[..], [CsiEvent::Refused { reason, .. }] if reason.contains("csi_peers")),
        "{e:?}"
    );
    assert!(!s.answered());
    let mut open = FeitServer::new(server, CsiServerLimits::default());
    let e = open.datagram(&datagram(1), server, 0);
    assert!(matches!(
        &e[..],
        [CsiEvent::Connected { .. }, CsiEvent::Record { .. }]
    ));
    assert!(open.answered());
}

#[test]
fn the_rigs_channel_gives_the_options() {
    assert_eq!(
        options_for_channel(5.18e9, Bandwidth::Ht20),
        "-f 5180 -w 20 -r HT"
    );
    assert_eq!(
        options_for_channel(5.19e9, Bandwidth::Ht40),
        "-f 5180 -w 40 -r HT"
    );
    assert_eq!(start_command("  -f 2412 -w 20 "), "feitcsi -f 2412 -w 20");
}
