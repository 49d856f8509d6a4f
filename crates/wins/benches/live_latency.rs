//! Latency of `wins live`: from a CSI record's arrival to its ODOMETRY leaving (target: p99 ≤
//! 2 ms on one core).
//!
//! `paper-circle-3ap` (three APs at 50 packets/s each, a 200 Hz IMU, a 25 Hz barometer) is
//! simulated for 60 s and its inputs are handed to a [`LiveSession`] as the links would hand them
//! over: the IMU and barometer late by 0.2 ms + Exp(0.5 ms) (MAVLink), the CSI records late by
//! 1 ms + Exp(2 ms) (the CSI Tool's TCP stream), each record named by its AP's transmitter
//! (`tests/it/live_session.rs` builds its flights the same way), each link in order (three APs
//! share one NIC's stream, which does not reorder them). Every frame the session returns
//! is treated as `wins live` treats it (`live::run`): a converged, fresh one is encoded as
//! `ODOMETRY` (`live::mavlink::outbound`) and sent over a MAVLink `udpout` link to a loopback
//! UDP socket, which a thread reads as the flight controller would.
//!
//! A frame on the 20 ms grid is solved when the IMU passes its time, and the session releases
//! that IMU sample once every stream has passed it (docs/LIVE.md): the input whose arrival
//! releases it (usually the next CSI record, the slowest stream; sometimes an IMU sample; or the
//! loop's 2 ms tick after `max_latency_ms`) *completes* the frame. The latency of a frame is the
//! wall time from that input's hand-over to the return of the `send` of its ODOMETRY; it is
//! reported by what completed the frame. Four passes over the same inputs, one after the other
//! in one run:
//!
//! - **A. live, in real time**: a feeder thread hands each input to the session's channel at its
//!   arrival time on the host's monotonic clock (stamping it then, as the CSI server thread
//!   does), and the main thread runs the session as `wins live`'s loop does (`recv_timeout` of
//!   2 ms, every queued input handed over, `advance` at the host's time, encode, send). The
//!   latency includes the channel's hand-over and the wait of an input queued behind a slow one;
//!   when several were handed over together it runs from the earliest of them (an upper bound:
//!   the one that completed the frame is among them). 60 s of wall time.
//! - **B. the same session flat out**: no threads, no waiting; each input's arrival time is its
//!   simulated one, and the latency is the compute from `handle` to the `send` (what A costs
//!   without the hand-over and the scheduler).
//! - **C. reference, `wins run`'s path**: the same inputs in time order straight into a
//!   [`ChainResolver`] (what `wins run` drives); the latency of a frame is the push that
//!   released it.
//! - **D. where the time goes**: the estimator alone, one [`Pipeline`] on the rig's calibration
//!   (no chain-offset hypotheses, `[pipeline.chains] resolve = false`), timing each IMU push
//!   that solves a frame, split by whether the frame became a keyframe of the nonlinear window
//!   (the window solved) or not.
//!
//! Percentiles are nearest-rank over the frames. Run on one core:
//! `taskset -c 0 cargo bench -p wins --bench live_latency` (the workspace forbids `unsafe`, so
//! the benchmark cannot pin itself).

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread;
use std::time::{Duration, Instant};

use mavlink::dialects::common::MavMessage;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};
use wins::Config;
use wins::csi::Received;
use wins::csi::logged::Logged;
use wins::dataset::stream::{DatasetEvent, DatasetStream};
use wins::fusion::choice::Estimator;
use wins::live::mavlink::link::{DEFAULT_COMPONENT_ID, MavlinkLink, MavlinkUrl, open};
use wins::live::mavlink::outbound::{OdometryExtras, odometry};
use wins::live::run::{load_rig, quality};
use wins::live::session::{LiveFrame, LiveSession, LiveStats};
use wins::live::{CsiEvent, FcEvent, HostClock, LiveInput};
use wins::pipeline::{ChainResolver, Pipeline};
use wins::sim::{Scenario, simulate, write_dataset};

/// The flight, s.
const FLIGHT_S: f64 = 60.0;
/// The arrival jitter's seed.
const SEED: u64 = 7;
/// The host clock reads this much more than the flight controller's (pass B).
const HOST_MINUS_FC_NS: i64 = 3_600_000_000_000;
/// `wins live`'s loop: its longest wait for an input.
const TICK: Duration = Duration::from_millis(2);
/// An `advance` that returns more frames than this is the chain-offset decision releasing the
/// frames it held.
const BURST: usize = 3;

fn main() {
    let dir = flight();
    let (events, arrivals) = inputs(&dir);
    let mut config = Config::default();
    // The CSI link's least delay (1 ms) less the IMU link's (0.2 ms), as a user measures it
    // (docs/LIVE.md).
    config.live.csi_extra_latency_ms = 0.8;
    let csi = arrivals.iter().filter(|a| a.kind == Kind::Csi).count();
    println!(
        "live latency: paper-circle-3ap, {FLIGHT_S} s, {} inputs ({csi} CSI records), seed {SEED}",
        arrivals.len()
    );
    println!(
        "latency of a frame: the hand-over of the input that completed it → its ODOMETRY sent \
         (not converged: → the session done with it; nothing is sent)\n"
    );
    let fc = FlightController::start();
    let a = live_realtime(&dir, &config, &arrivals, &fc);
    let b = live_flat_out(&dir, &config, &arrivals, &fc);
    let received = fc.stop();
    let c = offline(&dir, &config, &events);
    let d = estimator_alone(&dir, &config, &events);

    println!("{HEADER}");
    a.print("A. live, real time", true);
    b.print("B. live, flat out (compute only)", false);
    println!("C. reference: wins run's path (ChainResolver), the push that released the frame");
    row("  converged", &c.converged);
    row("  not converged", &c.unconverged);
    println!("D. the estimator alone (one Pipeline, resolve = false), the IMU push that solved it");
    row("  converged, keyframe (window solved)", &d.keyframe);
    row("  converged, not a keyframe", &d.other);
    row("  not converged, window running", &d.unconverged_window);
    row("  not converged, before the window", &d.starting);
    if !d.slow.is_empty() {
        let mut slow = d.slow.clone();
        slow.sort_by(|a, b| b.1.total_cmp(&a.1));
        let list: Vec<String> = slow
            .iter()
            .take(8)
            .map(|(t, ns)| format!("{:.1} ms at {t:.2} s", ns * 1e-6))
            .collect();
        let first = d.slow.first().map_or(0.0, |s| s.0);
        println!(
            "  D: {} converged keyframes over 2 ms, the first at {first:.1} s of flight; the slowest: {}",
            d.slow.len(),
            list.join(", ")
        );
    }
    println!();
    let sent_a = a.sent_by(None);
    let (pa, pc) = (stats(&sent_a), stats(&c.converged));
    if let (Some(pa), Some(pc)) = (pa, pc) {
        println!(
            "ratio A / C over the converged frames: p50 {:.2}×, p99 {:.2}×",
            pa.p50 / pc.p50,
            pa.p99 / pc.p99
        );
    }
    if let (Some(k), Some(o)) = (stats(&d.keyframe), stats(&d.other)) {
        let share = d.keyframe.len() as f64 / (d.keyframe.len() + d.other.len()) as f64;
        println!(
            "keyframes: {:.0} % of the converged frames; a keyframe's push is {:.1}× another's (p50)",
            100.0 * share,
            k.p50 / o.p50
        );
    }
    println!("{}", a.summary("A"));
    println!("{}", b.summary("B"));
    println!("datagrams the flight controller received: {received}");
    let _ = std::fs::remove_dir_all(&dir);
}

const HEADER: &str = "                                                     frames       p50       p90       p99       max  > 2 ms";

/// The flight written as a dataset (the rig, the logs) in a temporary folder.
fn flight() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-bench-live-latency-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = Scenario::built_in("paper-circle-3ap").expect("built-in scenario");
    s.duration_s = FLIGHT_S;
    let out = simulate(&s, &mut |_| {}).expect("valid scenario");
    write_dataset(&dir, &s, &out).expect("writable temp dir");
    dir
}

/// What an input is; as what completed a frame, also several inputs queued and handed over
/// together, or the loop's tick (no input).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Csi,
    Imu,
    Baro,
    Other,
    Batch,
    Tick,
}

/// One input as a link hands it over, at `host_ns` (flight controller time + the link's delay).
#[derive(Clone, Debug)]
struct Arrival {
    host_ns: i64,
    kind: Kind,
    input: LiveInput,
}

/// The dataset's events in time order, and the same as arrivals in arrival order (with the CSI
/// connection first).
fn inputs(dir: &Path) -> (Vec<DatasetEvent>, Vec<Arrival>) {
    let stream = DatasetStream::open(dir).expect("the dataset just written");
    let (_, _, macs) = load_rig(dir).expect("the rig");
    let mut reader = stream.events(true).expect("readable");
    let mut events = Vec::new();
    while let Some(e) = reader.next_event().expect("a valid dataset") {
        events.push(e);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let (fc_jitter, csi_jitter) = (
        Exp::new(1.0 / 0.5e6).expect("rate"),
        Exp::new(1.0 / 2e6).expect("rate"),
    );
    // Each link delivers in order (a serial or UDP MAVLink link, one TCP stream for the NIC): an
    // input is not handed over before the one sent before it on its link.
    let mut fc_last = i64::MIN;
    let mut fc_delay = |t: i64| {
        fc_last =
            (fc_last + 1).max(t + HOST_MINUS_FC_NS + (0.2e6 + fc_jitter.sample(&mut rng)) as i64);
        fc_last
    };
    let mut csi_last = i64::MIN;
    let mut out: Vec<Arrival> = Vec::new();
    let mut csi_rng = ChaCha8Rng::seed_from_u64(SEED + 1);
    for e in &events {
        let a = match e.clone() {
            DatasetEvent::Imu(sample) => {
                let host_ns = fc_delay(sample.t.as_nanos());
                Arrival {
                    host_ns,
                    kind: Kind::Imu,
                    input: LiveInput::Fc(FcEvent::Imu {
                        sample,
                        arrival_ns: host_ns,
                    }),
                }
            }
            DatasetEvent::Baro(b) => {
                let host_ns = fc_delay(b.t.as_nanos());
                Arrival {
                    host_ns,
                    kind: Kind::Baro,
                    input: LiveInput::Fc(FcEvent::Baro {
                        t: b.t,
                        altitude_m: b.altitude_m,
                        arrival_ns: host_ns,
                    }),
                }
            }
            DatasetEvent::Csi { ap, packet } => {
                csi_last = (csi_last + 1).max(
                    packet.t.as_nanos()
                        + HOST_MINUS_FC_NS
                        + (1e6 + csi_jitter.sample(&mut csi_rng)) as i64,
                );
                let host_ns = csi_last;
                Arrival {
                    host_ns,
                    kind: Kind::Csi,
                    input: LiveInput::Csi(CsiEvent::Record {
                        conn: 0,
                        record: match packet.record {
                            Received::Intel5300(r) => Box::new(Logged::Intel5300(r)),
                            Received::Card(_) => {
                                panic!("the CSI Tool's stream carries 5300 records")
                            }
                        },
                        transmitter: macs[ap],
                        arrival_ns: host_ns,
                    }),
                }
            }
        };
        out.push(a);
    }
    out.sort_by_key(|a| a.host_ns);
    let first = out[0].host_ns;
    out.insert(
        0,
        Arrival {
            host_ns: first - 1,
            kind: Kind::Other,
            input: LiveInput::Csi(CsiEvent::Connected {
                conn: 0,
                peer: "127.0.0.1:40000".parse().expect("an address"),
            }),
        },
    );
    (events, out)
}

/// Sets the arrival time an input carries.
fn stamp(input: &mut LiveInput, now_ns: i64) {
    match input {
        LiveInput::Csi(CsiEvent::Record { arrival_ns, .. })
        | LiveInput::Fc(FcEvent::Imu { arrival_ns, .. } | FcEvent::Baro { arrival_ns, .. }) => {
            *arrival_ns = now_ns;
        }
        _ => {}
    }
}

/// A session on the dataset's rig, as `wins live` makes it (no recording).
fn session(dir: &Path, config: &Config) -> LiveSession {
    let (_, rig, macs) = load_rig(dir).expect("the rig");
    let use_baro = config.live.barometer && config.pipeline.use_barometer;
    LiveSession::new(config, rig, macs, use_baro, None).expect("a session")
}

/// The flight controller's end of the link: a loopback UDP socket read by a thread.
struct FlightController {
    port: u16,
    stop: Arc<AtomicBool>,
    thread: thread::JoinHandle<u64>,
}

impl FlightController {
    fn start() -> Self {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("a loopback socket");
        socket
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("a timeout");
        let port = socket.local_addr().expect("bound").port();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = thread::spawn(move || {
            let mut buffer = [0_u8; 512];
            let mut n = 0;
            loop {
                match socket.recv(&mut buffer) {
                    Ok(_) => n += 1,
                    Err(_) if flag.load(Ordering::Relaxed) => return n,
                    Err(_) => {}
                }
            }
        });
        Self { port, stop, thread }
    }

    /// `wins live`'s link to it.
    fn link(&self) -> MavlinkLink {
        let url = MavlinkUrl::UdpOut {
            host: "127.0.0.1".into(),
            port: self.port,
        };
        open(&url, 1, DEFAULT_COMPONENT_ID).expect("a udpout link")
    }

    /// Datagrams received.
    fn stop(self) -> u64 {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().expect("the reader")
    }
}

/// Encodes and sends a frame's ODOMETRY as `wins live` does (`live::run`); whether it went.
fn send(link: &MavlinkLink, f: &LiveFrame) -> bool {
    let extras = OdometryExtras {
        time_usec: u64::try_from(f.pose.t.as_nanos() / 1000).unwrap_or(0),
        reset_counter: f.reset_counter,
        quality: quality(&f.pose),
        angular_velocity_rad_s: None,
        velocity_covariance_in_w: None,
    };
    odometry(&f.pose, &extras)
        .map(MavMessage::ODOMETRY)
        .is_ok_and(|m| link.send(&m).is_ok())
}

/// Frame latencies of a live pass, ns.
#[derive(Default)]
struct LivePass {
    /// Sent (converged, fresh): what completed it, its latency.
    sent: Vec<(Kind, f64)>,
    /// Not converged: latency to the end of the session's work with it (nothing is sent).
    unconverged: Vec<f64>,
    /// Age of the pose when sent (host time then − host time of the pose's time).
    age: Vec<f64>,
    /// Per input: hand-over → the session done with it (and its frames sent).
    per_input: Vec<f64>,
    /// Inputs handed to the session in a batch (queued behind a slow one), and batches.
    batched: (u64, u64),
    burst_sent: u64,
    stale: u64,
    stats: Option<LiveStats>,
}

impl LivePass {
    fn sent_by(&self, kind: Option<Kind>) -> Vec<f64> {
        self.sent
            .iter()
            .filter(|(k, _)| kind.is_none_or(|w| w == *k))
            .map(|(_, l)| *l)
            .collect()
    }

    /// Takes the frames one `advance` returned after inputs completed them (`kind`): sends the
    /// converged, fresh ones (`send` returns whether it went and the latency then, ns) and
    /// counts the others (`done`: the latency once all are sent).
    fn frames(
        &mut self,
        frames: &[LiveFrame],
        kind: Kind,
        mut send: impl FnMut(&LiveFrame) -> (bool, f64),
        mut age: impl FnMut(&LiveFrame) -> Option<f64>,
        done: impl Fn() -> f64,
    ) {
        let burst = frames.len() > BURST;
        let mut unconverged = 0;
        for f in frames {
            if !f.pose.converged {
                // `wins live` sends nothing before convergence.
                unconverged += 1;
                continue;
            }
            if !f.fresh {
                self.stale += 1;
                continue;
            }
            let (sent, latency) = send(f);
            if !sent {
                continue;
            }
            self.burst_sent += u64::from(burst);
            if let Some(a) = age(f) {
                self.age.push(a);
            }
            self.sent.push((kind, latency));
        }
        let end = done();
        self.unconverged
            .extend(std::iter::repeat_n(end, unconverged));
    }

    fn print(&self, title: &str, with_age: bool) {
        println!("{title}");
        let by = |k| self.sent_by(Some(k));
        row(
            "  converged, sent, completed by a CSI record",
            &by(Kind::Csi),
        );
        row(
            "  converged, sent, completed by an IMU sample",
            &by(Kind::Imu),
        );
        row(
            "  converged, sent, completed by a barometer reading",
            &by(Kind::Baro),
        );
        row(
            "  converged, sent, completed by a queued batch",
            &by(Kind::Batch),
        );
        row(
            "  converged, sent, completed by the 2 ms tick",
            &by(Kind::Tick),
        );
        row("  converged, sent, all", &self.sent_by(None));
        row("  not converged (nothing sent)", &self.unconverged);
        row("  per input: hand-over → done with it", &self.per_input);
        if with_age {
            row("  age of the pose when sent (as stats.json)", &self.age);
        }
    }

    fn summary(&self, name: &str) -> String {
        let s = self.stats.clone().unwrap_or_default();
        format!(
            "{name}: {} ODOMETRY sent, {} frames ({} converged), {} inputs late, {} restarts, \
             {} inputs queued behind another in {} batches, {} sent in the chain-offset \
             decision's burst, {} stale not sent",
            self.sent.len(),
            s.frames,
            s.frames_converged,
            s.late,
            s.restarts,
            self.batched.0,
            self.batched.1,
            self.burst_sent,
            self.stale
        )
    }
}

/// Pass A (module doc).
fn live_realtime(
    dir: &Path,
    config: &Config,
    arrivals: &[Arrival],
    fc: &FlightController,
) -> LivePass {
    let mut session = session(dir, config);
    let link = fc.link();
    let clock = HostClock::new();
    let (tx, rx) = mpsc::sync_channel::<LiveInput>(4096);
    // The schedule: arrival times relative to the first, from 50 ms from now.
    let first = arrivals[0].host_ns;
    let start = clock.now_ns() + 50_000_000;
    let schedule: Vec<(i64, LiveInput)> = arrivals
        .iter()
        .map(|a| (start + a.host_ns - first, a.input.clone()))
        .collect();
    let feeder = thread::spawn(move || {
        for (at, mut input) in schedule {
            let wait = at - clock.now_ns();
            if wait > 0 {
                thread::sleep(Duration::from_nanos(wait as u64));
            }
            stamp(&mut input, clock.now_ns());
            if tx.send(input).is_err() {
                return;
            }
        }
    });
    let mut pass = LivePass::default();
    let mut arrivals_in_batch: Vec<i64> = Vec::new();
    loop {
        // As `wins live`'s loop: wait up to 2 ms, hand over what is queued, advance.
        arrivals_in_batch.clear();
        let mut kind = Kind::Tick;
        match rx.recv_timeout(TICK) {
            Ok(input) => {
                let (k, arrival) = kind_and_arrival(&input);
                kind = k;
                arrivals_in_batch.extend(arrival);
                session.handle(input);
                while let Ok(more) = rx.try_recv() {
                    kind = Kind::Batch;
                    arrivals_in_batch.extend(kind_and_arrival(&more).1);
                    session.handle(more);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if arrivals_in_batch.len() > 1 {
            pass.batched.0 += arrivals_in_batch.len() as u64 - 1;
            pass.batched.1 += 1;
        }
        let now = clock.now_ns();
        // The frames' latency runs from the earliest hand-over of the batch (the input that
        // completed them is in it: an upper bound when several were queued), or from the tick.
        let from = arrivals_in_batch.iter().copied().min().unwrap_or(now);
        // As `wins live`: the frames out, the keyframe solve after them, then what waited.
        loop {
            let frames = session.advance(now).expect("the session");
            pass.frames(
                &frames,
                kind,
                |f| (send(&link, f), (clock.now_ns() - from) as f64),
                |f| {
                    session
                        .host_time(f.pose.t)
                        .map(|h| (clock.now_ns() - h) as f64)
                },
                || (clock.now_ns() - from) as f64,
            );
            session.solve_pending();
            if !session.has_backlog() {
                break;
            }
        }
        let done = clock.now_ns();
        pass.per_input
            .extend(arrivals_in_batch.iter().map(|a| (done - a) as f64));
    }
    feeder.join().expect("the feeder");
    let (_, stats) = session.finish().expect("the session's end");
    pass.stats = Some(stats);
    pass
}

/// What an input is and the host time it carries.
fn kind_and_arrival(input: &LiveInput) -> (Kind, Option<i64>) {
    match input {
        LiveInput::Csi(CsiEvent::Record { arrival_ns, .. }) => (Kind::Csi, Some(*arrival_ns)),
        LiveInput::Fc(FcEvent::Imu { arrival_ns, .. }) => (Kind::Imu, Some(*arrival_ns)),
        LiveInput::Fc(FcEvent::Baro { arrival_ns, .. }) => (Kind::Baro, Some(*arrival_ns)),
        _ => (Kind::Other, None),
    }
}

/// Pass B (module doc).
fn live_flat_out(
    dir: &Path,
    config: &Config,
    arrivals: &[Arrival],
    fc: &FlightController,
) -> LivePass {
    let mut session = session(dir, config);
    let link = fc.link();
    let mut pass = LivePass::default();
    for a in arrivals {
        let started = Instant::now();
        session.handle(a.input.clone());
        let elapsed = || started.elapsed().as_nanos() as f64;
        loop {
            let frames = session.advance(a.host_ns).expect("the session");
            pass.frames(
                &frames,
                a.kind,
                |f| (send(&link, f), elapsed()),
                |_| None,
                elapsed,
            );
            session.solve_pending();
            if !session.has_backlog() {
                break;
            }
        }
        if a.kind != Kind::Other {
            pass.per_input.push(elapsed());
        }
    }
    let (_, stats) = session.finish().expect("the session's end");
    pass.stats = Some(stats);
    pass
}

/// Pass C's latencies, ns.
#[derive(Default)]
struct Offline {
    converged: Vec<f64>,
    unconverged: Vec<f64>,
}

/// Pass C (module doc).
fn offline(dir: &Path, config: &Config, events: &[DatasetEvent]) -> Offline {
    let (_, rig, _) = load_rig(dir).expect("the rig");
    let has_baro =
        config.pipeline.use_barometer && events.iter().any(|e| matches!(e, DatasetEvent::Baro(_)));
    let mut resolver = ChainResolver::new(config, rig, has_baro).expect("a pipeline");
    let mut out = Offline::default();
    for e in events {
        let started = Instant::now();
        let released = match e {
            DatasetEvent::Imu(s) => resolver.push_imu(s),
            DatasetEvent::Baro(b) if has_baro => resolver.push_baro(b.t, b.altitude_m),
            DatasetEvent::Baro(_) => continue,
            DatasetEvent::Csi { ap, packet } => resolver.push_csi(*ap, packet.t, &packet.record),
        }
        .expect("the pipeline");
        let ns = started.elapsed().as_nanos() as f64;
        for f in &released.frames {
            match f.converged {
                true => out.converged.push(ns),
                false => out.unconverged.push(ns),
            }
        }
    }
    let _ = resolver.finish().expect("the pipeline's end");
    out
}

/// Pass D's latencies, ns.
#[derive(Default)]
struct Alone {
    keyframe: Vec<f64>,
    /// The converged keyframes' pushes over 2 ms: flight time, s, and ns.
    slow: Vec<(f64, f64)>,
    other: Vec<f64>,
    unconverged_window: Vec<f64>,
    starting: Vec<f64>,
}

/// Pass D (module doc).
fn estimator_alone(dir: &Path, config: &Config, events: &[DatasetEvent]) -> Alone {
    let (_, rig, _) = load_rig(dir).expect("the rig");
    let has_baro =
        config.pipeline.use_barometer && events.iter().any(|e| matches!(e, DatasetEvent::Baro(_)));
    let mut config = config.clone();
    config.pipeline.chains.resolve = false;
    let mut pipeline = Pipeline::with_baro(&config, rig, has_baro).expect("a pipeline");
    let mut out = Alone::default();
    let t0 = events
        .iter()
        .find_map(|e| match e {
            DatasetEvent::Imu(s) => Some(s.t.as_secs_f64()),
            _ => None,
        })
        .unwrap_or(0.0);
    for e in events {
        match e {
            DatasetEvent::Imu(s) => {
                // A keyframe's solve runs at the next push unless asked for: here with the push
                // that gave its frame, to time the two together.
                let started = Instant::now();
                let step = pipeline.push_imu(s).expect("the pipeline");
                pipeline.solve_pending();
                let ns = started.elapsed().as_nanos() as f64;
                let Some(last) = step.frames.last() else {
                    continue;
                };
                let newest = match pipeline.wins() {
                    Estimator::Nonlinear(n) => n.window().map(|w| w.newest().map(|k| k.t)),
                    Estimator::Paper(_) => None,
                };
                match (newest, last.converged) {
                    (None, _) => out.starting.push(ns),
                    (Some(_), false) => out.unconverged_window.push(ns),
                    (Some(k), true) if k == Some(last.t) => {
                        out.keyframe.push(ns);
                        if ns > 2e6 {
                            out.slow.push((last.t.as_secs_f64() - t0, ns));
                        }
                    }
                    (Some(_), true) => out.other.push(ns),
                }
            }
            DatasetEvent::Baro(b) if has_baro => {
                pipeline.push_baro(b.t, b.altitude_m).expect("the pipeline")
            }
            DatasetEvent::Baro(_) => {}
            DatasetEvent::Csi { ap, packet } => {
                let _ = pipeline.push_csi(*ap, packet.t, &packet.record);
            }
        }
    }
    out
}

/// p50, p90, p99, max, ms.
struct Percentiles {
    p50: f64,
    p90: f64,
    p99: f64,
    max: f64,
}

/// Nearest-rank percentiles of latencies in ns, as ms.
fn stats(ns: &[f64]) -> Option<Percentiles> {
    if ns.is_empty() {
        return None;
    }
    let mut v = ns.to_vec();
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1] * 1e-6;
    Some(Percentiles {
        p50: at(0.50),
        p90: at(0.90),
        p99: at(0.99),
        max: v[v.len() - 1] * 1e-6,
    })
}

fn row(label: &str, ns: &[f64]) {
    match stats(ns) {
        Some(p) => println!(
            "{label:<52} {:>6} {:>6.3} ms {:>6.3} ms {:>6.3} ms {:>6.3} ms {:>7}",
            ns.len(),
            p.p50,
            p.p90,
            p.p99,
            p.max,
            ns.iter().filter(|&&l| l > 2e6).count()
        ),
        None => println!("{label:<52} {:>6}", 0),
    }
}
