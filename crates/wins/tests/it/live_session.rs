//! `wins live`'s session without sockets: a simulated flight's inputs handed over as the links
//! would, each with an arrival time late by a seeded jitter, on a host clock offset from the
//! flight controller's and the NIC's. Checks that the recording replays to the same trajectory,
//! that the clocks are related to within a millisecond, and that faults while flying (a
//! dropped CSI connection, garbage, a silent AP, a NIC clock jump, an IMU gap) are counted and
//! flown through.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};
use wins::Config;
use wins::csi::intel5300::{Skip, SkipReason};
use wins::csi::logged::Logged;
use wins::dataset::parse_mac;
use wins::dataset::stream::{DatasetEvent, DatasetStream};
use wins::live::recorder::Recorder;
use wins::live::run::load_rig;
use wins::live::session::{LiveFrame, LiveSession, LiveStats};
use wins::live::{CsiEvent, FcEvent, LiveInput};
use wins::sim::{Scenario, simulate, write_dataset};
use wins::time::Timestamp;

/// The host clock reads this much more than the flight controller's.
pub(crate) const HOST_MINUS_FC_NS: i64 = 3_600_000_000_000;

fn flight(name: &str, seconds: f64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-live-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::built_in("paper-circle").unwrap();
    s.duration_s = seconds;
    write_dataset(&dir, &s, &simulate(&s, &mut |_| {}).unwrap()).unwrap();
    dir
}

/// One input as a link delivers it.
#[derive(Clone, Debug)]
pub(crate) struct Arrival {
    pub(crate) host_ns: i64,
    pub(crate) input: LiveInput,
    /// The input's time on the flight controller's clock (for the faults' windows).
    pub(crate) t: Timestamp,
}

impl Arrival {
    fn is_csi(&self) -> bool {
        matches!(self.input, LiveInput::Csi(CsiEvent::Record { .. }))
    }

    fn is_imu(&self) -> bool {
        matches!(self.input, LiveInput::Fc(FcEvent::Imu { .. }))
    }

    fn within(&self, from_s: f64, to_s: f64) -> bool {
        (from_s..to_s).contains(&self.t.as_secs_f64())
    }
}

fn csi_event(host_ns: i64, t: Timestamp, event: CsiEvent) -> Arrival {
    Arrival {
        host_ns,
        input: LiveInput::Csi(event),
        t,
    }
}

/// The flight's inputs as they arrive: IMU late by 0.2 + Exp(0.5 ms), CSI by 1 + Exp(2 ms) (a
/// TCP stream), on connection 0, each record named by its AP's `mac`.
fn arrivals(dir: &Path, seed: u64) -> Vec<Arrival> {
    let stream = DatasetStream::open(dir).unwrap();
    let macs: Vec<_> = stream
        .manifest
        .aps
        .iter()
        .map(|a| a.mac.as_deref().and_then(parse_mac))
        .collect();
    let mut events = stream.events(false).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (imu_jitter, csi_jitter) = (Exp::new(1.0 / 0.5e6).unwrap(), Exp::new(1.0 / 2e6).unwrap());
    let mut out = vec![];
    while let Some(e) = events.next_event().unwrap() {
        let a = match e {
            DatasetEvent::Imu(sample) => {
                let host_ns = sample.t.as_nanos()
                    + HOST_MINUS_FC_NS
                    + (0.2e6 + imu_jitter.sample(&mut rng)) as i64;
                Arrival {
                    host_ns,
                    t: sample.t,
                    input: LiveInput::Fc(FcEvent::Imu {
                        sample,
                        arrival_ns: host_ns,
                    }),
                }
            }
            DatasetEvent::Csi { ap, packet } => {
                let host_ns = packet.t.as_nanos()
                    + HOST_MINUS_FC_NS
                    + (1e6 + csi_jitter.sample(&mut rng)) as i64;
                csi_event(
                    host_ns,
                    packet.t,
                    CsiEvent::Record {
                        conn: 0,
                        record: Box::new(Logged::Intel5300(
                            packet.record.intel5300().unwrap().clone(),
                        )),
                        transmitter: macs[ap],
                        arrival_ns: host_ns,
                    },
                )
            }
            DatasetEvent::Baro(_) => continue,
        };
        out.push(a);
    }
    out.sort_by_key(|a| a.host_ns);
    let first = out[0].clone();
    out.insert(
        0,
        csi_event(
            first.host_ns - 1,
            first.t,
            CsiEvent::Connected {
                conn: 0,
                peer: "127.0.0.1:40000".parse().unwrap(),
            },
        ),
    );
    out
}

/// A session on `dir`'s rig, recording into `record` when given.
pub(crate) fn session(dir: &Path, config: &Config, record: Option<&Path>) -> LiveSession {
    let (manifest, rig, macs) = load_rig(dir).unwrap();
    let recorder = record.map(|out| {
        let _ = std::fs::remove_dir_all(out);
        Recorder::create(out, dir, &manifest).unwrap()
    });
    LiveSession::new(config, rig, macs, true, recorder).unwrap()
}

/// Feeds the arrivals in order, moving the session on at each; the frames and the stats.
pub(crate) fn fly(mut s: LiveSession, arrivals: Vec<Arrival>) -> (Vec<LiveFrame>, LiveStats) {
    let mut frames = vec![];
    for a in arrivals {
        s.handle(a.input);
        frames.extend(s.advance(a.host_ns).unwrap());
    }
    let (rest, stats) = s.finish().unwrap();
    frames.extend(rest);
    (frames, stats)
}

pub(crate) fn converged(frames: &[LiveFrame]) -> Vec<&LiveFrame> {
    frames.iter().filter(|f| f.pose.converged).collect()
}

/// The flight's IMU samples as the flight controller's link delivers them: late by
/// 0.2 + Exp(0.5 ms), drawn from `rng`.
pub(crate) fn imu_arrivals(dir: &Path, rng: &mut ChaCha8Rng) -> Vec<Arrival> {
    let stream = DatasetStream::open(dir).unwrap();
    let jitter = Exp::new(1.0 / 0.5e6).unwrap();
    let mut out = vec![];
    let mut events = stream.events(false).unwrap();
    while let Some(e) = events.next_event().unwrap() {
        if let DatasetEvent::Imu(sample) = e {
            let host_ns =
                sample.t.as_nanos() + HOST_MINUS_FC_NS + (0.2e6 + jitter.sample(rng)) as i64;
            out.push(Arrival {
                host_ns,
                t: sample.t,
                input: LiveInput::Fc(FcEvent::Imu {
                    sample,
                    arrival_ns: host_ns,
                }),
            });
        }
    }
    out
}

/// A UDP input's datagrams (host time, bytes, sender) and `extra` ones (bytes, sender, flight
/// time), in the order they arrive, through `handle` (the input's own handling of a datagram)
/// into `out` as arrivals; `out` sorted by arrival.
pub(crate) fn through_udp(
    out: &mut Vec<Arrival>,
    mut datagrams: Vec<(i64, Vec<u8>, SocketAddr)>,
    extra: &[(Vec<u8>, &str, f64)],
    mut handle: impl FnMut(&[u8], SocketAddr, i64) -> Vec<CsiEvent>,
) {
    for (bytes, peer, t_s) in extra {
        let host_ns = (t_s * 1e9) as i64 + HOST_MINUS_FC_NS;
        datagrams.push((host_ns, bytes.clone(), peer.parse().unwrap()));
    }
    datagrams.sort_by_key(|d| d.0);
    for (host_ns, bytes, peer) in datagrams {
        for e in handle(&bytes, peer, host_ns) {
            out.push(Arrival {
                host_ns,
                t: Timestamp(host_ns - HOST_MINUS_FC_NS),
                input: LiveInput::Csi(e),
            });
        }
    }
    out.sort_by_key(|a| a.host_ns);
}

/// `wins run` on the recording `rec` flies the `live` trajectory's converged poses, bit for bit;
/// its run.
pub(crate) fn assert_replays(rec: &Path, config: &Config, live: &[&LiveFrame]) -> wins::RunOutput {
    let run = wins::run_dataset(rec, config).unwrap();
    let offline: Vec<_> = run.frames.iter().filter(|f| f.converged).collect();
    assert_eq!(offline.len(), live.len());
    for (a, b) in offline.iter().zip(live) {
        assert_eq!(a.t, b.pose.t);
        assert_eq!(a.p_b_in_w, b.pose.p_b_in_w);
        assert_eq!(a.world_from_body, b.pose.world_from_body);
    }
    run
}

#[test]
fn the_recording_replays_to_the_same_trajectory_and_packets_land_within_a_millisecond() {
    let dir = flight("record", 40.0);
    let rec = dir.with_extension("recording");
    let mut config = Config::default();
    // The CSI link's least delay (1 ms) less the IMU link's (0.2 ms), as a user measures it.
    config.live.csi_extra_latency_ms = 0.8;
    let (frames, stats) = fly(session(&dir, &config, Some(&rec)), arrivals(&dir, 7));
    let live = converged(&frames);
    assert!(live.len() > 500, "{} converged frames", live.len());
    assert_eq!(
        (stats.fc_clock_outliers, stats.fc_clock_relocks),
        (0, 0),
        "{stats:?}"
    );
    assert_eq!(
        (stats.nic_clock_outliers, stats.nic_clock_relocks),
        (0, 0),
        "{stats:?}"
    );
    // Until each clock locks on five samples spanning 50 ms: ten IMU samples at 200 Hz, four
    // records.
    assert_eq!(stats.imu_clock_locking, 10, "{stats:?}");
    assert!(stats.late <= 2, "{stats:?}");
    assert_eq!(stats.csi_clock_warmup, 4, "{stats:?}");
    // Every packet handed over is within 1 ms of its time on the flight controller's clock.
    let truth = DatasetStream::open(&dir).unwrap();
    let mut original = truth.events(false).unwrap();
    let mut want = vec![];
    while let Some(e) = original.next_event().unwrap() {
        if let DatasetEvent::Csi { packet, .. } = e {
            want.push(packet.t);
        }
    }
    let recorded = DatasetStream::open(&rec).unwrap();
    let mut got = vec![];
    let mut events = recorded.events(false).unwrap();
    while let Some(e) = events.next_event().unwrap() {
        if let DatasetEvent::Csi { packet, .. } = e {
            got.push(packet.t);
        }
    }
    assert!(
        got.len() + (4 + stats.late + stats.csi_before_fc_clock) as usize >= want.len(),
        "{stats:?}"
    );
    // Each recorded packet against the original nearest to it (both in time order).
    let mut j = 0;
    let mut worst = 0;
    for g in &got {
        while j + 1 < want.len()
            && (want[j + 1].as_nanos() - g.as_nanos()).abs()
                <= (want[j].as_nanos() - g.as_nanos()).abs()
        {
            j += 1;
        }
        worst = worst.max((want[j].as_nanos() - g.as_nanos()).abs());
    }
    eprintln!("worst packet time error: {worst} ns");
    assert!(worst <= 1_000_000, "a packet {worst} ns off its time");
    // `wins run` on the recording gives the live trajectory, bit for bit.
    let run = assert_replays(&rec, &config, &live);
    // What went to the flight controller is what `wins run` calls sent: the same first pose and
    // the same poses (so the same causal figures), and none before the chain offsets' decision
    // released the held frames in a burst.
    let live_sent: Vec<Timestamp> = frames
        .iter()
        .filter(|f| f.pose.converged && f.fresh)
        .map(|f| f.pose.t)
        .collect();
    let run_sent: Vec<Timestamp> = run.sent_frames().map(|f| f.t).collect();
    assert!(live_sent.len() > 400, "{} poses sent", live_sent.len());
    assert_eq!(run_sent, live_sent);
    assert_eq!(run.first_sent, live_sent.first().copied());
    let decided_s = run.chains.decided_at_s.expect("the offsets were decided");
    let first_sent_s = live_sent[0].as_secs_f64() - run.inputs.imu.span_s.unwrap().0;
    assert!(
        first_sent_s >= decided_s - 0.25,
        "first pose sent at {first_sent_s:.2} s, the offsets decided at {decided_s:.2} s"
    );
    assert!(
        live[0].pose.t < live_sent[0],
        "the hindsight trajectory starts before the first pose sent"
    );
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&rec);
}

/// Converged frames after `t_s`.
fn converged_after(frames: &[LiveFrame], t_s: f64) -> usize {
    frames
        .iter()
        .filter(|f| f.pose.converged && f.pose.t.as_secs_f64() > t_s)
        .count()
}

#[test]
fn faults_while_flying_are_counted_and_flown_through() {
    let dir = flight("faults", 90.0);
    let config = Config::default();
    let mut a = arrivals(&dir, 11);
    let at = |a: &[Arrival], s: f64| {
        a.iter()
            .find(|x| x.t.as_secs_f64() >= s)
            .map(|x| (x.host_ns, x.t))
            .unwrap()
    };
    // 25–27 s: the CSI connection drops; it comes back as connection 1.
    let (drop_host, drop_t) = at(&a, 25.0);
    let (back_host, back_t) = at(&a, 27.0);
    a.retain(|x| !(x.is_csi() && x.within(25.0, 27.0)));
    for x in a.iter_mut().filter(|x| x.t.as_secs_f64() >= 27.0) {
        if let LiveInput::Csi(CsiEvent::Record { conn, .. }) = &mut x.input {
            *conn = 1;
        }
    }
    a.push(csi_event(
        drop_host,
        drop_t,
        CsiEvent::Disconnected {
            conn: 0,
            reason: "closed by the peer".into(),
            clean: false,
        },
    ));
    a.push(csi_event(
        back_host - 1,
        back_t,
        CsiEvent::Connected {
            conn: 1,
            peer: "127.0.0.1:40001".parse().unwrap(),
        },
    ));
    // 35 s: a second connection sends 64 KiB of garbage and closes.
    let (g_host, g_t) = at(&a, 35.0);
    a.push(csi_event(
        g_host,
        g_t,
        CsiEvent::Connected {
            conn: 9,
            peer: "127.0.0.1:40009".parse().unwrap(),
        },
    ));
    for k in 0..4 {
        let skip = Skip {
            offset: k * 16_384,
            len: 16_384,
            reason: SkipReason::TruncatedTail { needed: 3 },
        };
        a.push(csi_event(
            g_host + 1 + k as i64,
            g_t,
            CsiEvent::Skipped { conn: 9, skip },
        ));
    }
    a.push(csi_event(
        g_host + 10,
        g_t,
        CsiEvent::Disconnected {
            conn: 9,
            reason: "closed by the peer".into(),
            clean: false,
        },
    ));
    // 45–48 s: the AP is silent.
    a.retain(|x| !(x.is_csi() && x.within(45.0, 48.0)));
    // From 55 s: the NIC's clock jumps 100 s ahead (a driver reload).
    for x in a.iter_mut().filter(|x| x.t.as_secs_f64() >= 55.0) {
        if let LiveInput::Csi(CsiEvent::Record { record, .. }) = &mut x.input {
            let Logged::Intel5300(record) = record.as_mut() else {
                panic!("a 5300 record")
            };
            record.timestamp = Timestamp(record.timestamp.as_nanos() + 100_000_000_000);
        }
    }
    // 40–42 s: a second connection streams the same AP's records (0.1 ms after the real ones):
    // refused and counted, not taken as more packets.
    let (s_host, s_t) = at(&a, 40.0);
    a.push(csi_event(
        s_host - 1,
        s_t,
        CsiEvent::Connected {
            conn: 5,
            peer: "127.0.0.1:40005".parse().unwrap(),
        },
    ));
    let spoofed: Vec<Arrival> = a
        .iter()
        .filter(|x| x.is_csi() && x.within(40.0, 42.0))
        .filter_map(|x| match &x.input {
            LiveInput::Csi(CsiEvent::Record {
                record,
                transmitter,
                arrival_ns,
                ..
            }) => Some(csi_event(
                x.host_ns + 100_000,
                x.t,
                CsiEvent::Record {
                    conn: 5,
                    record: record.clone(),
                    transmitter: *transmitter,
                    arrival_ns: arrival_ns + 100_000,
                },
            )),
            _ => None,
        })
        .collect();
    let second_stream = spoofed.len() as u64;
    assert!(second_stream > 50);
    a.extend(spoofed);
    let (e_host, e_t) = at(&a, 42.0);
    a.push(csi_event(
        e_host,
        e_t,
        CsiEvent::Disconnected {
            conn: 5,
            reason: "closed by the peer".into(),
            clean: false,
        },
    ));
    // 62–62.3 s: no IMU.
    a.retain(|x| !(x.is_imu() && x.within(62.0, 62.3)));
    a.sort_by_key(|x| x.host_ns);
    let (frames, stats) = fly(session(&dir, &config, None), a);
    assert_eq!(stats.csi_connections, 4, "{stats:?}");
    assert_eq!(stats.csi_disconnects, 3, "{stats:?}");
    assert_eq!(stats.csi_second_stream, second_stream, "{stats:?}");
    assert_eq!(stats.csi_skips, 4, "{stats:?}");
    assert_eq!(stats.csi_skipped_bytes, 65_536, "{stats:?}");
    assert_eq!(stats.nic_clock_relocks, 1, "{stats:?}");
    assert_eq!(stats.nic_clock_outliers, 0, "{stats:?}");
    // Connection 0, connection 1, and connection 1 again after its clock jumped: four records
    // each, and a few more where a record's delay, 20 ms off the others', restarted a lock.
    assert!((12..=16).contains(&stats.csi_clock_warmup), "{stats:?}");
    assert!(stats.late <= 2, "{stats:?}");
    for (label, from) in [("drop", 27.0), ("garbage", 35.0), ("silence", 48.0)] {
        assert!(
            converged_after(&frames, from + 2.0) > 100,
            "no converged frames after the {label}: {stats:?}"
        );
    }
    // After the NIC clock jump and the IMU gap, flown into the last seconds.
    assert!(
        converged_after(&frames, 80.0) > 100,
        "not converged at the end: {} restarts, {stats:?}",
        stats.restarts
    );
    let _ = std::fs::remove_dir_all(&dir);
}
