//! `wins live` wired together: the links' threads, the session, the outputs, the status line.
//!
//! Output folder (which must not exist, or be empty):
//! - `trajectory.tum`: every converged frame, flight controller time, world frame `w` (z up);
//! - `stats.json` ([`LiveSummary`]): the session's counts ([`LiveStats`]), the flight
//!   controller link's ([`super::mavlink::inbound::InboundStats`], and
//!   [`super::mavlink::signing::SigningCounts`] with a signing key), the clocks and the latency
//!   of the poses sent;
//! - `config.toml`: the settings in effect (give it to `wins run --config` with the recording);
//! - `recording/`: every input as a dataset (when `live.record`).
//!
//! The streamed files (`trajectory.tum`, the recording's) are handed whole lines and records
//! only ([`crate::io_safety::WholeRecords`]), every [`FLUSH_PERIOD`]; `stats.json` is replaced
//! atomically every [`STATS_PERIOD`] (`"complete": false`). A run killed (SIGKILL, a crash)
//! leaves them readable: the trajectory and the recording up to at most [`FLUSH_PERIOD`] before,
//! the counts up to [`STATS_PERIOD`] before. Every file is flushed, and `stats.json` written
//! `"complete": true`, when the run stops (the stop flag, set by Ctrl-C in the binary, or
//! `live.idle_exit_s` without input).

mod outputs;
mod stats;

#[cfg(test)]
mod fuzz;

use std::fs::{self, File};
use std::io;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::Duration;

use ::mavlink::MavHeader;
use ::mavlink::dialects::common::MavMessage;

use super::csi_input::{CsiInput, spawn_csi_input};
use super::csi_server::CsiServerLimits;
use super::mavlink::inbound::{InboundConfig, InboundDecoder, RawImuScale};
use super::mavlink::link::{MavlinkLink, MavlinkUrl, open_signed};
use super::mavlink::signing::MavlinkKey;
use super::recorder::Recorder;
use super::session::{LiveSession, LiveStats, SessionError};
use super::status::{Histogram, LiveStatus, percentiles};
use super::{FcEvent, HostClock, LiveInput};
use crate::config::Config;
use crate::csi::intel5300::MacAddress;
use crate::dataset::Manifest;
use crate::dataset::load::read_manifest;
use crate::rig::{ChainCalibration, Rig};
use crate::run::output::TRAJECTORY_FILE;
use crate::run::replay::rig_of_manifest;
use crate::run::trajectory::TrajectoryWriter;
use outputs::Outputs;
pub use outputs::{FLUSH_PERIOD, QUALITY_SIGMA_M, quality};
use stats::StatsFile;
pub use stats::{LiveSummary, STATS_FILE, STATS_PERIOD};

/// Capacity of the inputs' channel (about 10 s of a 200 Hz IMU and two 100 packet/s APs):
/// beyond it the links wait, and the TCP stream backs up to the logger.
const CHANNEL: usize = 4096;
/// The loop's longest sleep waiting for inputs.
const TICK: Duration = Duration::from_millis(2);

/// Why `wins live` cannot run.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// A setting or the rig cannot be used.
    #[error("{0}")]
    Setup(String),
    /// A file or socket failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The cause.
        source: io::Error,
    },
    /// The session failed.
    #[error(transparent)]
    Session(#[from] SessionError),
}

fn io_err(what: impl Into<String>) -> impl FnOnce(io::Error) -> LiveError {
    let what = what.into();
    move |source| LiveError::Io { what, source }
}

/// Where `wins live` reads and writes.
#[derive(Clone, Debug)]
pub struct LiveOptions {
    /// The rig's dataset folder (its `dataset.toml` and calibration).
    pub rig_dir: PathBuf,
    /// The output folder.
    pub out: PathBuf,
}

/// Runs `wins live` until `stop` is set (or the idle limit), calling `on_status` every
/// `live.status_interval_s`.
pub fn run_live(
    config: &Config,
    options: &LiveOptions,
    stop: &Arc<AtomicBool>,
    on_status: &mut dyn FnMut(&LiveStatus),
) -> Result<LiveSummary, LiveError> {
    let live = &config.live;
    config
        .validate()
        .map_err(|e| LiveError::Setup(e.to_string()))?;
    // Everything that can fail does so before any socket opens.
    let (manifest, rig, macs) = load_rig(&options.rig_dir)?;
    let csi_addr: SocketAddr = live
        .csi_listen
        .parse()
        .map_err(|_| LiveError::Setup(format!("live.csi_listen {:?}", live.csi_listen)))?;
    let input = CsiInput::for_rig(&manifest, csi_addr, live).map_err(LiveError::Setup)?;
    let url: MavlinkUrl = live
        .mavlink
        .parse()
        .map_err(|e| LiveError::Setup(format!("live.mavlink: {e}")))?;
    let key = match live.mavlink_key.as_str() {
        "" => None,
        path => Some(
            MavlinkKey::read(Path::new(path))
                .map_err(|e| LiveError::Setup(format!("live.mavlink_key: {e}")))?,
        ),
    };
    prepare_out(&options.out, &options.rig_dir)?;
    let use_baro = live.barometer && config.pipeline.use_barometer;
    let recorder = match live.record {
        true => Some(
            Recorder::create(&options.out.join("recording"), &options.rig_dir, &manifest)
                .map_err(io_err("creating the recording"))?,
        ),
        false => None,
    };
    let names = rig.ap_names.clone();
    let mut session = LiveSession::new(config, rig, macs, use_baro, recorder)?;
    let config_text = toml::to_string(config).map_err(|e| LiveError::Setup(e.to_string()))?;
    fs::write(options.out.join("config.toml"), config_text)
        .map_err(io_err("writing config.toml"))?;
    let tum = TrajectoryWriter::new(
        File::create(options.out.join(TRAJECTORY_FILE))
            .map_err(io_err("creating trajectory.tum"))?,
    )
    .map_err(io_err("writing trajectory.tum"))?;

    let clock = HostClock::new();
    let (tx, rx) = mpsc::sync_channel(CHANNEL);
    let limits = CsiServerLimits {
        allowed_peers: live
            .csi_peers
            .iter()
            .filter_map(|p| p.parse().ok())
            .collect(),
        ..CsiServerLimits::default()
    };
    let (csi_local, csi_thread) =
        spawn_csi_input(&input, tx.clone(), clock, Arc::clone(stop), limits)
            .map_err(io_err(format!("listening for CSI on {csi_addr}")))?;
    let link = Arc::new(
        open_signed(&url, live.system_id, live.component_id, key).map_err(|e| LiveError::Io {
            what: format!("opening the MAVLink link {}", live.mavlink),
            source: io::Error::other(e.to_string()),
        })?,
    );
    let inbound = Arc::new(Mutex::new(InboundDecoder::new(inbound_config(
        config, &manifest,
    ))));
    spawn_mavlink_reader(&link, &inbound, tx, clock, stop)?;

    let mut out = Outputs {
        link: &link,
        message: live.message,
        tum,
        sent: 0,
        not_sent: 0,
        ages: Histogram::default(),
        window_ages_ms: Vec::new(),
    };
    let stats_file = StatsFile {
        path: options.out.join(STATS_FILE),
        inbound: &inbound,
        link: &link,
        csi_listen: csi_local.to_string(),
        recording: session.recording().map(Path::to_path_buf),
    };
    let run = Loop {
        rx: &rx,
        clock,
        status_every_ns: (live.status_interval_s * 1e9) as i64,
        idle_exit_ns: (live.idle_exit_s * 1e9) as i64,
        names: &names,
        stats: &stats_file,
    };
    run.go(&mut session, &mut out, stop, on_status)?;
    stop.store(true, Ordering::Relaxed);
    let clocks = session.clocks();
    let fc_epoch_offset_ns = session.fc_epoch_offset_ns();
    let (frames, stats) = session.finish()?;
    for f in frames {
        out.frame(&f, None, fc_epoch_offset_ns)?;
    }
    out.flush()?;
    let _ = csi_thread.join();
    let summary = stats_file.summary(stats, clocks, &out, true);
    stats_file.write(&summary)?;
    Ok(summary)
}

/// The rig described by the dataset manifest in `dir` (its calibration read), and each AP's
/// transmitter address.
pub fn load_rig(dir: &Path) -> Result<(Manifest, Rig, Vec<Option<MacAddress>>), LiveError> {
    let setup = |e: &dyn std::fmt::Display| LiveError::Setup(e.to_string());
    let manifest = read_manifest(dir).map_err(|e| setup(&e))?;
    let calibration = match &manifest.array.calibration {
        Some(file) => Some(ChainCalibration::load(&dir.join(file)).map_err(|e| setup(&e))?),
        None => None,
    };
    let rig =
        rig_of_manifest(&manifest, calibration.as_ref(), None, None).map_err(|e| setup(&e))?;
    let macs = manifest
        .aps
        .iter()
        .map(|a| a.mac_address())
        .collect::<Result<Vec<_>, String>>()
        .map_err(LiveError::Setup)?;
    Ok((manifest, rig, macs))
}

/// The output folder: refused when it is, or lies inside, the rig's folder, or holds files.
fn prepare_out(out: &Path, rig_dir: &Path) -> Result<(), LiveError> {
    crate::io_safety::refuse_overlap(out, &[rig_dir])
        .map_err(|e| LiveError::Setup(e.to_string()))?;
    if out.exists() {
        let mut entries =
            fs::read_dir(out).map_err(io_err(format!("reading {}", out.display())))?;
        if entries.next().is_some() {
            return Err(LiveError::Setup(format!(
                "the output folder {} is not empty: a live run writes into a new folder",
                out.display()
            )));
        }
    }
    fs::create_dir_all(out).map_err(io_err(format!("creating {}", out.display())))
}

/// The decoder's settings: the rig's sensor ranges (as `wins run` checks them) and the flight
/// controller's ids.
fn inbound_config(config: &Config, manifest: &Manifest) -> InboundConfig {
    let live = &config.live;
    InboundConfig {
        raw_imu_scale: (live.raw_accel_m_s2_per_count > 0.0 && live.raw_gyro_rad_s_per_count > 0.0)
            .then_some(RawImuScale {
                accel_m_s2_per_count: live.raw_accel_m_s2_per_count,
                gyro_rad_s_per_count: live.raw_gyro_rad_s_per_count,
            }),
        fc_system_id: live.system_id,
        fc_component_id: live.fc_component_id,
        max_accel_m_s2: manifest.imu.accel_range_m_s2,
        max_gyro_rad_s: manifest.imu.gyro_range_rad_s,
        ..InboundConfig::default()
    }
}

/// The flight controller link's reader: decodes and forwards; it ends with the process (a
/// blocked read cannot be interrupted).
fn spawn_mavlink_reader(
    link: &Arc<MavlinkLink>,
    inbound: &Arc<Mutex<InboundDecoder>>,
    tx: SyncSender<LiveInput>,
    clock: HostClock,
    stop: &Arc<AtomicBool>,
) -> Result<(), LiveError> {
    let (link, inbound, stop) = (Arc::clone(link), Arc::clone(inbound), Arc::clone(stop));
    thread::Builder::new()
        .name("mavlink-in".into())
        .spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                let events = match link.recv() {
                    Ok((header, message)) => decode(&inbound, &header, &message, clock.now_ns()),
                    Err(e) => {
                        thread::sleep(Duration::from_millis(20));
                        vec![FcEvent::LinkError(e.to_string())]
                    }
                };
                for e in events {
                    if tx.send(LiveInput::Fc(e)).is_err() {
                        return;
                    }
                }
            }
        })
        .map(|_| ())
        .map_err(io_err("starting the MAVLink reader"))
}

fn decode(
    inbound: &Mutex<InboundDecoder>,
    header: &MavHeader,
    message: &MavMessage,
    arrival_ns: i64,
) -> Vec<FcEvent> {
    let Ok(mut decoder) = inbound.lock() else {
        return Vec::new();
    };
    let before = decoder.stats().refused.total();
    let got = decoder.decode_from(header, message);
    let mut events = Vec::new();
    if decoder.stats().refused.total() > before {
        events.push(FcEvent::Refused(format!("{:?}", decoder.stats().refused)));
    }
    if let Some(sample) = got.imu {
        events.push(FcEvent::Imu { sample, arrival_ns });
    }
    if let Some(b) = got.baro {
        events.push(FcEvent::Baro {
            t: b.t,
            altitude_m: b.altitude_m,
            arrival_ns,
        });
    }
    events
}

/// The main loop's settings.
struct Loop<'a> {
    rx: &'a Receiver<LiveInput>,
    clock: HostClock,
    status_every_ns: i64,
    idle_exit_ns: i64,
    names: &'a [String],
    stats: &'a StatsFile<'a>,
}

impl Loop<'_> {
    fn go(
        &self,
        session: &mut LiveSession,
        out: &mut Outputs<'_>,
        stop: &AtomicBool,
        on_status: &mut dyn FnMut(&LiveStatus),
    ) -> Result<(), LiveError> {
        let mut last_input: Option<i64> = None;
        let start = self.clock.now_ns();
        let mut last_status = (start, LiveStats::default(), 0u64);
        let (mut last_flush, mut last_stats) = (start, start);
        while !stop.load(Ordering::Relaxed) {
            match self.rx.recv_timeout(TICK) {
                Ok(input) => {
                    session.handle(input);
                    while let Ok(more) = self.rx.try_recv() {
                        session.handle(more);
                    }
                    last_input = Some(self.clock.now_ns());
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            let now = self.clock.now_ns();
            // The frames go out first, the keyframe solve after them, then the inputs that
            // waited behind the frames.
            loop {
                for f in session.advance(now)? {
                    let age = session
                        .host_time(f.pose.t)
                        .map(|h| (self.clock.now_ns() - h) as f64 * 1e-6);
                    out.frame(&f, age, session.fc_epoch_offset_ns())?;
                }
                session.solve_pending();
                if !session.has_backlog() {
                    break;
                }
            }
            // The recording first: the trajectory's lines on disk then come from inputs the
            // recording on disk holds.
            if now - last_flush >= duration_ns(FLUSH_PERIOD) {
                session.flush_recording()?;
                out.flush()?;
                last_flush = now;
            }
            if now - last_stats >= duration_ns(STATS_PERIOD) {
                let summary =
                    self.stats
                        .summary(session.stats().clone(), session.clocks(), out, false);
                self.stats.write(&summary)?;
                last_stats = now;
            }
            if self.status_every_ns > 0 && now - last_status.0 >= self.status_every_ns {
                let status = self.status(session, out, &last_status, now);
                on_status(&status);
                out.window_ages_ms.clear();
                last_status = (now, session.stats().clone(), out.sent);
            }
            if self.idle_exit_ns > 0 && last_input.is_some_and(|t| now - t > self.idle_exit_ns) {
                break;
            }
        }
        Ok(())
    }

    fn status(
        &self,
        session: &LiveSession,
        out: &mut Outputs<'_>,
        last: &(i64, LiveStats, u64),
        now: i64,
    ) -> LiveStatus {
        let dt = ((now - last.0) as f64 * 1e-9).max(1e-9);
        let stats = session.stats().clone();
        let packets_hz = self
            .names
            .iter()
            .enumerate()
            .map(|(l, name)| {
                let n = stats.csi_used_per_ap.get(l).copied().unwrap_or(0);
                let before = last.1.csi_used_per_ap.get(l).copied().unwrap_or(0);
                (name.clone(), n.saturating_sub(before) as f64 / dt)
            })
            .collect();
        LiveStatus {
            fc_time_s: session.fc_time(now).map(|t| t.as_secs_f64()),
            imu_hz: stats.imu_received.saturating_sub(last.1.imu_received) as f64 / dt,
            packets_hz,
            poses_hz: out.sent.saturating_sub(last.2) as f64 / dt,
            estimate: session.estimate_state(),
            clocks: session.clocks(),
            latency_ms: percentiles(&mut out.window_ages_ms),
            mavlink_signing: out.link.signing_counts(),
            mavlink_link: out.link.counts(),
            new_notices: stats
                .notices
                .get(last.1.notices.len()..)
                .unwrap_or_default()
                .to_vec(),
            stats,
        }
    }
}

/// `d` in ns (saturating).
fn duration_ns(d: Duration) -> i64 {
    i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)
}
