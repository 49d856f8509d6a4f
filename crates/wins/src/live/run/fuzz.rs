//! A seeded fuzz run of what the network hands `wins live`: the CSI stream's bytes (through the
//! connection's [`StreamDecoder`], as [`crate::live::csi_server`] runs it) and the flight
//! controller's MAVLink bytes (through the MAVLink parser and [`decode`], as the reader thread
//! runs them), into one [`LiveSession`] moved on by a host clock that stalls and leaps.
//!
//! The inputs start from a simulated flight's and are broken at random: bytes flipped, records
//! cut, garbage and wrong lengths put between records, NIC and IMU times shifted or drawn at
//! random, readings NaN or huge, other senders, connections opened and dropped. What must
//! hold: nothing panics, every decoder's and the session's memory stays bounded, every pose
//! given is finite, and the session ends cleanly.
//!
//! CI runs [`SEEDS`] seeds; `WINS_FUZZ_SEEDS=N` runs `N` (a longer hunt), and
//! `WINS_FUZZ_OFF=mangle,mangle_imu,shift,broken` leaves those kinds of damage out (to see which
//! one a count comes from): `cargo test --release -p wins --lib live::run::fuzz -- --nocapture`
//! prints each seed's counts.

use std::path::PathBuf;

use ::mavlink::dialects::common::MavMessage;
use ::mavlink::{MavHeader, MavlinkVersion, write_versioned_msg};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{LiveSession, decode, inbound_config, load_rig};
use crate::Config;
use crate::csi::Received;
use crate::csi::intel5300::{CsiRecord, Event, StreamDecoder, encode_frame_record, encode_record};
use crate::csi::logged::Logged;
use crate::dataset::stream::{DatasetEvent, DatasetStream};
use crate::imu::ImuSample;
use crate::live::mavlink::framer::Framer;
use crate::live::mavlink::inbound::InboundDecoder;
use crate::live::mavlink::signing;
use crate::live::player::{highres_imu, highres_pressure};
use crate::live::{CsiEvent, LiveInput};
use crate::sim::{Scenario, simulate, write_dataset};
use crate::time::Timestamp;

/// Seeds run by default.
const SEEDS: u64 = 3;
/// Seconds of the flight the inputs come from.
const FLIGHT_S: f64 = 24.0;
/// Connections the CSI comes on.
const CONNECTIONS: usize = 3;
/// Most inputs the session may hold at once (the merger's and the start's buffers): far above
/// what a clean second holds (200 IMU samples and ~50 records), far below a leak.
const MAX_HELD: usize = 20_000;

/// The simulated flight the inputs come from, written once per process.
fn flight() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-live-fuzz-{}", std::process::id()));
    if !dir.join("dataset.toml").exists() {
        let mut s = Scenario::built_in("paper-circle").expect("built-in scenario");
        s.duration_s = FLIGHT_S;
        let out = simulate(&s, &mut |_| {}).expect("simulated");
        write_dataset(&dir, &s, &out).expect("written");
    }
    dir
}

/// One clean input of the flight.
enum Clean {
    Imu(ImuSample),
    Baro(Timestamp, f64),
    /// A record and its time on the flight controller's clock.
    Csi(Box<CsiRecord>, Timestamp),
}

fn clean_inputs(dir: &std::path::Path) -> Vec<Clean> {
    let stream = DatasetStream::open(dir).expect("dataset");
    let mut events = stream.events(false).expect("events");
    let mut out = vec![];
    while let Some(e) = events.next_event().expect("event") {
        out.push(match e {
            DatasetEvent::Imu(s) => Clean::Imu(s),
            DatasetEvent::Baro(b) => Clean::Baro(b.t, b.altitude_m),
            DatasetEvent::Csi { packet, .. } => match packet.record {
                Received::Intel5300(record) => Clean::Csi(Box::new(record), packet.t),
                Received::Card(_) => panic!("the live fuzz flies Intel 5300 datasets"),
            },
        });
    }
    out
}

fn on(kind: &str) -> bool {
    std::env::var("WINS_FUZZ_OFF").map_or(true, |v| !v.split(',').any(|k| k == kind))
}

/// Flips, cuts or pads `bytes` at random (most pass intact).
fn mangle(rng: &mut ChaCha8Rng, bytes: &mut Vec<u8>) {
    if !on("mangle") {
        return;
    }
    match rng.random_range(0..100) {
        0 if !bytes.is_empty() => {
            let i = rng.random_range(0..bytes.len());
            bytes[i] ^= 1 << rng.random_range(0..8);
        }
        1 => bytes.truncate(rng.random_range(0..=bytes.len())),
        2 => {
            let n = rng.random_range(1..300);
            let at = rng.random_range(0..=bytes.len());
            let garbage: Vec<u8> = (0..n).map(|_| rng.random()).collect();
            bytes.splice(at..at, garbage);
        }
        3 if bytes.len() >= 2 => {
            // A length field (the CSI Tool's big-endian u16, MAVLink's payload length) wrong.
            let i = rng.random_range(0..2);
            bytes[i] = rng.random();
        }
        _ => {}
    }
}

/// A time off by a random amount: a little, a lot, or drawn anew.
fn shifted_ns(rng: &mut ChaCha8Rng, t_ns: i64) -> i64 {
    if !on("shift") {
        return t_ns;
    }
    match rng.random_range(0..60) {
        0 => rng.random::<i64>(),
        1 => t_ns.saturating_add(rng.random_range(-2_000_000_000_000..2_000_000_000_000)),
        2 => t_ns.saturating_add(rng.random_range(-5_000_000_000..5_000_000_000)),
        3 => 0,
        _ => t_ns,
    }
}

/// A reading broken at random: NaN, huge, or as it was.
fn broken(rng: &mut ChaCha8Rng, v: f64) -> f64 {
    if !on("broken") {
        return v;
    }
    match rng.random_range(0..600) {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => rng.random_range(-1e6..1e6),
        _ => v,
    }
}

/// The CSI side: one decoder per connection, as the server keeps them.
struct CsiSide {
    decoders: Vec<Option<StreamDecoder>>,
    next_conn: u64,
    conn_ids: Vec<u64>,
    /// When each connection last brought bytes, host ns.
    last_bytes_ns: Vec<i64>,
}

/// A connection silent this long is closed, as the server closes it, ns.
const IDLE_CLOSE_NS: i64 = 5_000_000_000;

impl CsiSide {
    fn new() -> Self {
        Self {
            decoders: (0..CONNECTIONS).map(|_| None).collect(),
            next_conn: 0,
            conn_ids: vec![0; CONNECTIONS],
            last_bytes_ns: vec![0; CONNECTIONS],
        }
    }

    /// `bytes` arriving on connection slot `k` (opened if closed), in random chunks.
    fn feed(
        &mut self,
        rng: &mut ChaCha8Rng,
        k: usize,
        bytes: &[u8],
        now_ns: i64,
    ) -> Vec<LiveInput> {
        let mut out = vec![];
        for idle in 0..CONNECTIONS {
            if now_ns - self.last_bytes_ns[idle] >= IDLE_CLOSE_NS {
                out.extend(self.close(idle, now_ns));
            }
        }
        self.last_bytes_ns[k] = now_ns;
        if self.decoders[k].is_none() {
            self.conn_ids[k] = self.next_conn;
            self.next_conn += 1;
            self.decoders[k] = Some(StreamDecoder::new());
            out.push(LiveInput::Csi(CsiEvent::Connected {
                conn: self.conn_ids[k],
                peer: "127.0.0.1:40000".parse().expect("address"),
            }));
        }
        let conn = self.conn_ids[k];
        let Some(decoder) = self.decoders[k].as_mut() else {
            return out;
        };
        let mut rest = bytes;
        while !rest.is_empty() {
            let n = rng.random_range(1..=rest.len().min(4096));
            decoder.push(&rest[..n]);
            rest = &rest[n..];
            drain(conn, decoder, now_ns, &mut out);
            assert!(
                decoder.pending() <= StreamDecoder::MAX_PENDING + 4096,
                "a CSI decoder holds {} bytes",
                decoder.pending()
            );
        }
        out
    }

    /// Connection slot `k` closes.
    fn close(&mut self, k: usize, now_ns: i64) -> Vec<LiveInput> {
        let mut out = vec![];
        if let Some(mut decoder) = self.decoders[k].take() {
            decoder.finish();
            drain(self.conn_ids[k], &mut decoder, now_ns, &mut out);
            out.push(LiveInput::Csi(CsiEvent::Disconnected {
                conn: self.conn_ids[k],
                reason: "closed by the peer".into(),
                clean: false,
            }));
        }
        out
    }
}

fn drain(conn: u64, decoder: &mut StreamDecoder, now_ns: i64, out: &mut Vec<LiveInput>) {
    while let Some(event) = decoder.next_event() {
        out.push(LiveInput::Csi(match event {
            Event::Csi(record) => CsiEvent::Record {
                conn,
                record: Box::new(Logged::Intel5300(*record)),
                transmitter: decoder.transmitter(),
                arrival_ns: now_ns,
            },
            Event::Skipped(skip) => CsiEvent::Skipped { conn, skip },
        }));
    }
}

/// The MAVLink bytes of `message` from a header that is mostly the flight controller's.
fn mavlink_bytes(rng: &mut ChaCha8Rng, sequence: u8, message: &MavMessage) -> Vec<u8> {
    let header = MavHeader {
        system_id: if rng.random_range(0..30) == 0 {
            u32::from(rng.random::<u8>())
        } else {
            1
        },
        component_id: if rng.random_range(0..30) == 0 {
            rng.random::<u8>()
        } else {
            1
        },
        sequence,
    };
    let mut bytes = vec![];
    let version = if rng.random_range(0..10) == 0 {
        MavlinkVersion::V1
    } else {
        MavlinkVersion::V2
    };
    // Writing to a Vec cannot fail; a message too long for V1 is sent as it came out.
    let _ = write_versioned_msg(&mut bytes, version, header, message);
    bytes
}

/// What the MAVLink reader thread hands the session for the bytes of one datagram.
fn fc_inputs(
    inbound: &std::sync::Mutex<InboundDecoder>,
    bytes: &[u8],
    arrival_ns: i64,
) -> Vec<LiveInput> {
    let mut framer = Framer::default();
    framer.push(bytes);
    let mut out = vec![];
    while let Some(frame) = framer.next_frame(true) {
        let Ok((header, message)) = signing::decode(&frame) else {
            continue;
        };
        out.extend(
            decode(inbound, &header, &message, arrival_ns)
                .into_iter()
                .map(LiveInput::Fc),
        );
    }
    out
}

/// One seed's run; returns the poses given.
fn fuzz_once(seed: u64, clean: &[Clean], dir: &std::path::Path) -> usize {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let config = Config::default();
    let (manifest, rig, macs) = load_rig(dir).expect("rig");
    let transmitter = macs.first().copied().flatten();
    let mut session =
        LiveSession::new(&config, rig, macs, true, None).expect("session for the flight's rig");
    let inbound = std::sync::Mutex::new(InboundDecoder::new(inbound_config(&config, &manifest)));
    let mut csi = CsiSide::new();
    let host_minus_fc_ns: i64 = 3_600_000_000_000;
    let mut now_ns = host_minus_fc_ns;
    let (mut poses, mut sequence) = (0, 0u8);
    let mut stalled_until_ns = 0;
    for input in clean {
        // The host reads each input as it comes, but now and then stalls (a busy or suspended
        // process) and reads what came meanwhile at once, late.
        let t_ns = match input {
            Clean::Imu(s) => s.t.as_nanos(),
            Clean::Baro(t, _) => t.as_nanos(),
            Clean::Csi(_, t) => t.as_nanos(),
        };
        let on_time_ns = t_ns + host_minus_fc_ns;
        if rng.random_range(0..2000) == 0 {
            stalled_until_ns = on_time_ns + rng.random_range(0..3_000_000_000);
        }
        now_ns = now_ns.max(on_time_ns.max(stalled_until_ns));
        let mut inputs = vec![];
        match input {
            Clean::Imu(s) => {
                let sample = ImuSample {
                    t: Timestamp(shifted_ns(&mut rng, s.t.as_nanos())),
                    gyro_rad_s: s.gyro_rad_s.map(|v| broken(&mut rng, v)),
                    accel_m_s2: s.accel_m_s2.map(|v| broken(&mut rng, v)),
                };
                let message = highres_imu(&sample);
                let mut bytes = mavlink_bytes(&mut rng, sequence, &message);
                sequence = sequence.wrapping_add(1);
                if on("mangle_imu") {
                    mangle(&mut rng, &mut bytes);
                }
                inputs.extend(fc_inputs(&inbound, &bytes, now_ns));
            }
            Clean::Baro(t, altitude_m) => {
                let t_ns = shifted_ns(&mut rng, t.as_nanos());
                let message = highres_pressure(t_ns, broken(&mut rng, *altitude_m));
                let bytes = mavlink_bytes(&mut rng, sequence, &message);
                inputs.extend(fc_inputs(&inbound, &bytes, now_ns));
            }
            Clean::Csi(record, _) => {
                let mut record = record.clone();
                let low_ns = i64::from(record.header.timestamp_low) * 1000;
                // The 32-bit µs counter wraps: the shifted time modulo 2³² µs.
                record.header.timestamp_low =
                    (shifted_ns(&mut rng, low_ns) / 1000).rem_euclid(1 << 32) as u32;
                let mut bytes = vec![];
                if let Some(mac) = transmitter.filter(|_| rng.random_range(0..20) != 0) {
                    encode_frame_record(&mac, &mut bytes);
                }
                encode_record(&record, &mut bytes);
                mangle(&mut rng, &mut bytes);
                // Mostly the first connection; now and then another, or a drop.
                let k = if rng.random_range(0..500) == 0 {
                    rng.random_range(1..CONNECTIONS)
                } else {
                    0
                };
                if rng.random_range(0..400) == 0 {
                    inputs.extend(csi.close(k, now_ns));
                }
                inputs.extend(csi.feed(&mut rng, k, &bytes, now_ns));
            }
        }
        for i in inputs {
            session.handle(i);
        }
        // The loop takes every input that came before it moves on: within a stall, none moves
        // it (what queued up is read first).
        if on_time_ns >= stalled_until_ns && rng.random_range(0..3) == 0 {
            let frames = session
                .advance(now_ns)
                .expect("no recording: nothing to fail");
            for f in &frames {
                assert!(
                    !f.pose.converged || f.pose.p_b_in_w.iter().all(|v| v.is_finite()),
                    "seed {seed}: a non-finite pose given at {:?}",
                    f.pose.t
                );
            }
            poses += frames.iter().filter(|f| f.pose.converged).count();
        }
        assert!(
            session.held() <= MAX_HELD,
            "seed {seed}: the session holds {} inputs",
            session.held()
        );
    }
    for k in 0..CONNECTIONS {
        for i in csi.close(k, now_ns) {
            session.handle(i);
        }
    }
    let (rest, stats) = session.finish().expect("the session ends");
    poses += rest.iter().filter(|f| f.pose.converged).count();
    println!("seed {seed}: {stats:?}");
    assert!(stats.imu_received > 0, "seed {seed}: {stats:?}");
    poses
}

#[test]
fn broken_bytes_times_and_readings_never_panic_and_memory_stays_bounded() {
    let seeds = std::env::var("WINS_FUZZ_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SEEDS);
    let dir = flight();
    let clean = clean_inputs(&dir);
    for seed in 0..seeds {
        let poses = fuzz_once(seed, &clean, &dir);
        println!("seed {seed}: {poses} poses");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
