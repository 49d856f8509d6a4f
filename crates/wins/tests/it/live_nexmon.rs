//! `wins live` on a Nexmon rig, without sockets: a simulated RT-AC86U flight's pcaps sent as
//! nexmon_csi sends them (one UDP datagram per core, from the router), through the listener's
//! frame assembly ([`Sources`]) into the session with the flight controller's IMU. Checks that
//! the frames are assembled whole, that stray and foreign datagrams are counted and left out, and
//! that the recording (a Nexmon pcap per AP) replays to the same trajectory.

use std::net::SocketAddr;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};
use wins::Config;
use wins::csi::format::CaptureFormat;
use wins::csi::nexmon::read_nexmon;
use wins::csi::nexmon::write::encode_payload;
use wins::dataset::stream::DatasetStream;
use wins::live::csi_server::CsiServerLimits;
use wins::live::nexmon_udp::Sources;
use wins::live::{CsiEvent, LiveInput};
use wins::sim::{Scenario, simulate, write_dataset};

use crate::live_session::{
    Arrival, HOST_MINUS_FC_NS, assert_replays, converged, fly, imu_arrivals, session, through_udp,
};

/// The router nexmon_csi runs on.
const ROUTER: &str = "127.0.0.1:5500";

/// The flight's inputs as they arrive: IMU late by 0.2 + Exp(0.5 ms), each core's datagram by
/// 1 + Exp(2 ms), through the listener's sources (`limits`); `extra` datagrams (bytes, peer,
/// flight time) go in among them.
fn arrivals(
    dir: &std::path::Path,
    limits: CsiServerLimits,
    extra: &[(Vec<u8>, &str, f64)],
) -> Vec<Arrival> {
    let stream = DatasetStream::open(dir).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let csi_jitter = Exp::new(1.0 / 2e6).unwrap();
    let mut out = imu_arrivals(dir, &mut rng);
    // Every core's datagram with its arrival, all APs through the one router.
    let mut datagrams: Vec<(i64, Vec<u8>, SocketAddr)> = vec![];
    for entry in &stream.manifest.aps {
        for p in read_nexmon(&dir.join(&entry.log)).unwrap().packets {
            let t = p.time_ns + entry.imu_minus_nic_ns;
            let host_ns = t + HOST_MINUS_FC_NS + (1e6 + csi_jitter.sample(&mut rng)) as i64;
            let mut bytes = vec![];
            encode_payload(&p, &mut bytes);
            datagrams.push((host_ns, bytes, ROUTER.parse().unwrap()));
        }
    }
    let mut sources = Sources::new(limits, 3);
    through_udp(&mut out, datagrams, extra, |b, peer, t| {
        sources.datagram(b, peer, t)
    });
    out
}

#[test]
fn a_nexmon_rig_flies_live_and_its_recording_replays_to_the_same_trajectory() {
    let dir = std::env::temp_dir().join(format!("wins-live-nexmon-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::built_in("paper-circle")
        .unwrap()
        .with_card(CaptureFormat::Nexmon);
    s.duration_s = 40.0;
    write_dataset(&dir, &s, &simulate(&s, &mut |_| {}).unwrap()).unwrap();
    let rec = dir.with_extension("recording");
    let mut config = Config::default();
    config.live.csi_extra_latency_ms = 0.8;
    config.live.csi_peers = vec!["127.0.0.1".into()];
    let limits = CsiServerLimits {
        allowed_peers: vec!["127.0.0.1".parse().unwrap()],
        ..CsiServerLimits::default()
    };
    // A stray datagram from the router, and one from a host not allowed.
    let extra = [
        (b"not a nexmon packet".to_vec(), ROUTER, 20.0),
        (b"\x11\x11spoofed".to_vec(), "10.0.0.9:5500", 21.0),
    ];
    let arrivals = arrivals(&dir, limits, &extra);
    let records = arrivals
        .iter()
        .filter(|a| matches!(a.input, LiveInput::Csi(CsiEvent::Record { .. })))
        .count();
    let frames_in_files: usize = DatasetStream::open(&dir)
        .unwrap()
        .manifest
        .aps
        .iter()
        .map(|a| read_nexmon(&dir.join(&a.log)).unwrap().packets.len() / 3)
        .sum();
    assert_eq!(
        records, frames_in_files,
        "one record per frame of three cores"
    );
    let (frames, stats) = fly(session(&dir, &config, Some(&rec)), arrivals);
    let live = converged(&frames);
    eprintln!(
        "{} frames, {} converged; {} records, {} used",
        frames.len(),
        live.len(),
        stats.csi_records,
        stats.csi_used_per_ap.iter().sum::<u64>()
    );
    assert!(live.len() > 300, "{} converged frames", live.len());
    assert_eq!(stats.csi_unusable, 0, "{stats:?}");
    assert_eq!(
        (stats.csi_skips, stats.csi_skipped_bytes),
        (1, 19),
        "{stats:?}"
    );
    assert_eq!(stats.csi_refused_connections, 1, "{stats:?}");
    // The recording is a Nexmon rig's dataset, and `wins run` on it flies the live trajectory.
    let recorded = DatasetStream::open(&rec).unwrap();
    assert_eq!(recorded.manifest.array.card, CaptureFormat::Nexmon);
    assert_replays(&rec, &config, &live);
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&rec);
}

#[test]
fn a_rig_of_a_card_without_a_live_stream_is_refused_before_any_socket_opens() {
    let dir = std::env::temp_dir().join(format!("wins-live-atheros-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::built_in("paper-circle")
        .unwrap()
        .with_card(CaptureFormat::Atheros);
    s.duration_s = 20.0;
    write_dataset(&dir, &s, &simulate(&s, &mut |_| {}).unwrap()).unwrap();
    let options = wins::live::run::LiveOptions {
        rig_dir: dir.clone(),
        out: dir.join("live"),
    };
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let e = wins::live::run::run_live(&Config::default(), &options, &stop, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("the rig's card is atheros"), "{e}");
    assert!(!options.out.exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}
