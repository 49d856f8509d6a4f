//! A live session: inputs as they arrive in, frames to send out (module doc of [`super`]).
//!
//! Clocks. Every input carries the host time it arrived. The flight controller's IMU samples
//! relate its clock to the host's, each NIC connection's records relate the NIC's
//! ([`ClockTrack`]: offset and drift through the lower envelope of the arrival delays, a lone
//! time far from the line refused as an outlier, a clock that restarts re-locked after a few
//! samples that agree), so a CSI record's time on the flight controller's clock is
//! `fc(host(nic time))`, in whole microseconds (less `live.csi_extra_latency_ms`: each relation
//! places its clock late by its link's least delay, and only the difference of the two, which
//! no arrival shows, is left). The pipeline, the trajectory and the messages sent all run on the
//! flight controller's clock; after it restarts, on its timeline ([`ClockTrack`]: the first
//! epoch's clock carried on through the host's), and the messages sent are put back on its
//! current clock ([`LiveSession::fc_epoch_offset_ns`]). A restart or a silence of the IMU is a
//! gap in the IMU, which the estimator bridges as `wins run` bridges any (`[imu_gap]`).
//!
//! Order. An input is released to the pipeline once every stream has passed its time (the IMU
//! and every connected NIC), or `max_latency_ms` after its time, whichever comes first
//! ([`super::merge`]); one that arrives after that is counted late and dropped.
//!
//! AP. A record's AP is the rig's AP whose `mac` is the transmitter named by the frame record
//! before it ([`ApBy::Transmitter`]), or the only AP ([`ApBy::Single`]); a record whose AP cannot
//! be told is counted and left out.

mod clocks;
mod inputs;

use std::collections::{HashMap, VecDeque};

use super::ApBy;
use super::clock::{ClockTrack, TrackConfig};
pub use super::counts::{ClockReport, LiveStats};
use super::merge::{Merged, Merger};
use super::recorder::Recorder;
use crate::config::Config;
use crate::csi::intel5300::MacAddress;
use crate::fusion::pose::PoseEstimate;
use crate::pipeline::{ChainResolver, EstimateState, PipelineError, Released};
use crate::rig::Rig;
use crate::time::Timestamp;

/// Why a session cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The pipeline refused to start or failed.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The rig and the settings do not fit together.
    #[error("{0}")]
    Setup(String),
    /// Writing the recording failed.
    #[error("writing the recording: {0}")]
    Record(#[from] std::io::Error),
}

/// An IMU silence at least this long is said in words (a notice), ns: the estimate restarts
/// after it.
const SILENCE_NOTICE_NS: i64 = 1_000_000_000;

pub use crate::pipeline::FRESH_NS;

/// A frame to send, with what the message needs beside the pose.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveFrame {
    /// The pose, on the flight controller's clock.
    pub pose: PoseEstimate,
    /// Bumped at every restart of the estimate (wraps at 256, as the message's field).
    pub reset_counter: u8,
    /// Whether it is new enough to be worth sending ([`Released::is_fresh`]: the frames the
    /// chain-offset resolution holds come out in a burst once it decides; the flight controller
    /// has no use for the old ones).
    pub fresh: bool,
}

/// How long the inputs are held before the pipeline is built, s of IMU time: long enough to
/// see whether the flight controller sends its barometer.
pub const START_HOLD_S: f64 = 1.0;

/// Before the pipeline is built, or with it.
enum Stage {
    /// The inputs of the first [`START_HOLD_S`], held.
    Waiting {
        config: Box<Config>,
        rig: Box<Rig>,
        held: Vec<Merged>,
    },
    /// The pipeline, fed.
    Running(Box<ChainResolver>),
}

/// One NIC connection's state.
#[derive(Debug, Default)]
struct Nic {
    clock: ClockTrack,
    /// The last record's time on the flight controller's clock.
    last_t: Option<Timestamp>,
    connected: bool,
}

/// A live session (module doc).
pub struct LiveSession {
    max_latency_ns: i64,
    max_jump_ns: i64,
    /// The clocks' settings.
    track: TrackConfig,
    csi_extra_ns: i64,
    ap_by: ApBy,
    /// Whether a barometer the flight controller sends is used.
    use_baro: bool,
    /// Whether it is (decided at the start: it sent readings).
    has_baro: bool,
    macs: Vec<Option<MacAddress>>,
    stage: Stage,
    fc: ClockTrack,
    nics: HashMap<u64, Nic>,
    /// Which connection streams each AP (the first one to bring its records).
    ap_streams: HashMap<usize, u64>,
    merger: Merger,
    /// Released inputs not fed yet: feeding stops at the first input that gives frames, so
    /// that they can be sent before the next input (and the solve it runs first) is fed.
    backlog: VecDeque<Merged>,
    recorder: Option<Recorder>,
    imu_last: Option<Timestamp>,
    stats: LiveStats,
    reset_counter: u8,
}

impl std::fmt::Debug for LiveSession {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveSession")
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl LiveSession {
    /// A session for `rig`, whose APs have the transmitter addresses `macs` (one per AP), with
    /// the barometer when `use_baro` and the flight controller sends it (its first
    /// [`START_HOLD_S`] tell); its inputs are written to `recorder` when given.
    pub fn new(
        config: &Config,
        rig: Rig,
        macs: Vec<Option<MacAddress>>,
        use_baro: bool,
        recorder: Option<Recorder>,
    ) -> Result<Self, SessionError> {
        let live = &config.live;
        let n = rig.ap_names.len();
        if macs.len() != n {
            return Err(SessionError::Setup(format!(
                "{} transmitter addresses for {n} APs",
                macs.len()
            )));
        }
        match live.ap_by {
            ApBy::Single if n != 1 => {
                return Err(SessionError::Setup(format!(
                    "live.ap_by = \"single\" needs a rig with one AP; it has {n}"
                )));
            }
            ApBy::Transmitter if macs.iter().any(Option::is_none) => {
                let missing: Vec<&str> = rig
                    .ap_names
                    .iter()
                    .zip(&macs)
                    .filter(|(_, m)| m.is_none())
                    .map(|(name, _)| name.as_str())
                    .collect();
                return Err(SessionError::Setup(format!(
                    "live.ap_by = \"transmitter\" needs every AP's mac in the rig's dataset.toml; \
                     missing for {}",
                    missing.join(", ")
                )));
            }
            _ => {}
        }
        // The settings are checked now; the pipeline is built after the first second.
        config
            .validate()
            .map_err(|e| SessionError::Setup(e.to_string()))?;
        let max_jump_ns = (live.max_clock_jump_s * 1e9).round() as i64;
        let track = TrackConfig {
            max_late_ns: max_jump_ns,
            ..TrackConfig::default()
        };
        Ok(Self {
            max_latency_ns: (live.max_latency_ms * 1e6).round() as i64,
            max_jump_ns,
            track,
            csi_extra_ns: (live.csi_extra_latency_ms * 1e6).round() as i64,
            ap_by: live.ap_by,
            use_baro,
            has_baro: false,
            macs,
            stage: Stage::Waiting {
                config: Box::new(config.clone()),
                rig: Box::new(rig),
                held: Vec::new(),
            },
            fc: ClockTrack::new(track),
            nics: HashMap::new(),
            ap_streams: HashMap::new(),
            merger: Merger::new(),
            backlog: VecDeque::new(),
            recorder,
            imu_last: None,
            stats: LiveStats {
                csi_used_per_ap: vec![0; n],
                ..LiveStats::default()
            },
            reset_counter: 0,
        })
    }

    /// Releases what every stream has passed, or what is `max_latency_ms` old at host time
    /// `host_now_ns`, to the pipeline; returns the frames it solved.
    pub fn advance(&mut self, host_now_ns: i64) -> Result<Vec<LiveFrame>, SessionError> {
        let Some(fc_now) = self.fc.to_timeline(host_now_ns) else {
            return Ok(Vec::new());
        };
        let mut watermark = Timestamp(fc_now.saturating_sub(self.max_latency_ns));
        // Every stream has passed: the IMU and each connected NIC that has sent anything.
        let mut passed = self.imu_last;
        for nic in self.nics.values().filter(|n| n.connected) {
            if let Some(t) = nic.last_t {
                passed = passed.map(|p| p.min(t));
            }
        }
        if let Some(p) = passed {
            watermark = watermark.max(p);
        }
        let mut inputs: Vec<Merged> = self.backlog.drain(..).collect();
        inputs.extend(self.merger.release(watermark));
        self.feed(inputs)
    }

    /// Whether released inputs wait to be fed ([`LiveSession::advance`] again, after sending
    /// the frames it gave).
    pub fn has_backlog(&self) -> bool {
        !self.backlog.is_empty()
    }

    /// Runs the pipeline's keyframe solve that is due: after the frames are sent, so that the
    /// solve is not on their way out ([`crate::pipeline::Pipeline::solve_pending`]).
    pub fn solve_pending(&mut self) {
        if let Stage::Running(resolver) = &mut self.stage {
            resolver.solve_pending();
        }
    }

    /// Feeds released inputs to the pipeline (and the recording), held until it is built.
    fn feed(&mut self, inputs: Vec<Merged>) -> Result<Vec<LiveFrame>, SessionError> {
        let mut frames = Vec::new();
        let mut inputs = inputs.into_iter();
        while let Some(input) = inputs.next() {
            if !frames.is_empty() {
                // Frames first: the rest waits for the next call.
                self.backlog.push_back(input);
                self.backlog.extend(inputs);
                break;
            }
            let start = match &mut self.stage {
                Stage::Waiting { held, .. } => {
                    let due = matches!(&input, Merged::Imu(s)
                        if held.iter().find_map(|h| match h {
                            Merged::Imu(first) => Some(s.t.secs_since(first.t) >= START_HOLD_S),
                            _ => None,
                        }) == Some(true));
                    held.push(input);
                    due
                }
                Stage::Running(_) => {
                    self.push_one(input, &mut frames)?;
                    false
                }
            };
            if start {
                self.start(&mut frames)?;
            }
        }
        Ok(frames)
    }

    /// Builds the pipeline, the barometer in when the held inputs have it, and feeds them.
    fn start(&mut self, frames: &mut Vec<LiveFrame>) -> Result<(), SessionError> {
        let Stage::Waiting { config, rig, held } = &mut self.stage else {
            return Ok(());
        };
        let held = std::mem::take(held);
        self.has_baro = self.use_baro && held.iter().any(|h| matches!(h, Merged::Baro { .. }));
        let resolver = ChainResolver::new(config, (**rig).clone(), self.has_baro)?;
        self.stage = Stage::Running(Box::new(resolver));
        if self.has_baro
            && let Some(r) = &mut self.recorder
        {
            r.enable_baro()?;
        }
        for input in held {
            self.push_one(input, frames)?;
        }
        Ok(())
    }

    /// Records and pushes one input into the running pipeline.
    fn push_one(&mut self, input: Merged, frames: &mut Vec<LiveFrame>) -> Result<(), SessionError> {
        let Stage::Running(resolver) = &mut self.stage else {
            return Ok(());
        };
        if matches!(input, Merged::Baro { .. }) && !self.has_baro {
            return Ok(());
        }
        if let Some(r) = &mut self.recorder {
            r.record(&input)?;
        }
        let released = match input {
            Merged::Imu(s) => resolver.push_imu(&s)?,
            Merged::Baro { t, altitude_m } => resolver.push_baro(t, altitude_m)?,
            Merged::Csi { ap, t, record } => {
                let Ok(received) = record.into_received() else {
                    self.stats.csi_unusable += 1;
                    return Ok(());
                };
                if let Some(n) = self.stats.csi_used_per_ap.get_mut(ap) {
                    *n += 1;
                }
                resolver.push_csi(ap, t, &received)?
            }
        };
        let restarts = resolver.decided_stats().map_or(0, |s| s.restarts);
        emit(
            &mut self.stats,
            &mut self.reset_counter,
            released,
            restarts,
            frames,
        );
        Ok(())
    }

    /// The end: everything held goes to the pipeline, which finishes; the recording is closed.
    /// Returns the last frames and the statistics.
    pub fn finish(mut self) -> Result<(Vec<LiveFrame>, LiveStats), SessionError> {
        let mut rest: Vec<Merged> = self.backlog.drain(..).collect();
        rest.extend(self.merger.drain());
        let mut frames = Vec::new();
        while !rest.is_empty() {
            frames.extend(self.feed(rest)?);
            rest = self.backlog.drain(..).collect();
        }
        self.start(&mut frames)?;
        if let Stage::Running(resolver) = self.stage {
            let done = resolver.finish()?;
            let restarts = done.pipeline.wins().stats().restarts;
            emit(
                &mut self.stats,
                &mut self.reset_counter,
                done.released,
                restarts,
                &mut frames,
            );
        }
        if let Some(r) = self.recorder.take() {
            r.finish()?;
        }
        Ok((frames, self.stats))
    }

    /// What the estimate is doing now.
    pub fn estimate_state(&self) -> EstimateState {
        match &self.stage {
            Stage::Running(r) => r.state(),
            Stage::Waiting { .. } => EstimateState::Starting,
        }
    }

    /// The counts so far.
    pub fn stats(&self) -> &LiveStats {
        &self.stats
    }

    /// Inputs held: waiting in the merger, released but not yet fed, or held for the start.
    pub fn held(&self) -> usize {
        let waiting = match &self.stage {
            Stage::Waiting { held, .. } => held.len(),
            Stage::Running(_) => 0,
        };
        self.merger.held() + self.backlog.len() + waiting
    }

    /// The recording's folder, when recording.
    pub fn recording(&self) -> Option<&std::path::Path> {
        self.recorder.as_ref().map(Recorder::dir)
    }

    /// Hands the recording's buffered rows and records to its files ([`Recorder::flush`]).
    pub fn flush_recording(&mut self) -> Result<(), SessionError> {
        match &mut self.recorder {
            Some(r) => Ok(r.flush()?),
            None => Ok(()),
        }
    }
}

/// Counts the released frames and appends them to `frames`, the reset counter bumped by the
/// restarts since the last call (`restarts` is the estimator's running count).
fn emit(
    stats: &mut LiveStats,
    reset_counter: &mut u8,
    released: Released,
    restarts: u64,
    frames: &mut Vec<LiveFrame>,
) {
    if restarts > stats.restarts {
        *reset_counter = reset_counter.wrapping_add((restarts - stats.restarts) as u8);
        stats.restarts = restarts;
    }
    let fresh: Vec<bool> = released
        .frames
        .iter()
        .map(|f| released.is_fresh(f))
        .collect();
    for (pose, fresh) in released.frames.into_iter().zip(fresh) {
        stats.frames += 1;
        stats.frames_converged += u64::from(pose.converged);
        frames.push(LiveFrame {
            fresh,
            pose,
            reset_counter: *reset_counter,
        });
    }
}
