//! WINS end to end (paper Fig. 1 and Algorithm 1 with the estimator in the loop), as a push API:
//! feed IMU samples and CSI packets in time order, get poses. A dataset replay ([`crate::run::replay`]) and a
//! live stream are two drivers of the same [`Pipeline`].
//!
//! Per packet of AP `l` (`track`): the first angle from SpotFi over the AP's first
//! [`PipelineConfig::init_packets`] packets; then PAoA around a prediction, the previous angle
//! turned by the gyro plus the translation part: before convergence the track's own learnt rate
//! (an alpha-beta track: no lag at a slow packet rate), after it the exact part of the state's
//! velocity at the state's range. The window is not centred on the state's direction to the AP:
//! a wrong state would steer it off the AP for good. The side of the linear array (front/back
//! mirror) is told by the turns (the side whose prediction follows the angles wins) and, once
//! converged, by the state near the array's axis; until the turns tell, a track is assumed in
//! front ([`PipelineConfig::assume_front_until_converged`], the paper's ±90° set-up) and the packet
//! log says so. A packet whose window holds no credible peak, or (after convergence) whose angle is
//! further than [`PipelineConfig::gate_deg`] (or [`PipelineConfig::gate_sigmas`] σ) from the
//! state's prediction, is dropped and counted.
//! Accepted bearings join the frame at the next grid time (`slot`), moved to that instant by
//! the gyro (and the velocity once known); the frame is solved by the estimator ([`Estimator`]) when the IMU stream
//! passes it. Gyro drift is removed by the window's joint gyro-bias estimate (the paper's relaxed
//! rotation averaging made attitude worse when fed back: docs/RESULTS.md).

pub mod aoa_log;
pub mod chains;
mod packet;
pub(crate) mod slot;
pub mod stats;
pub(crate) mod track;

use std::collections::VecDeque;
use std::time::Instant;

use nalgebra::UnitQuaternion;
use serde::Serialize;

pub use self::chains::{ChainReport, ChainResolver, EstimateState, FRESH_NS, Finished, Released};
use self::slot::{FrameSlot, move_bearing, rotation_between};
pub use self::stats::{ApStats, PacketLog, PacketStatus, PipelineStats};
use self::track::{ArrayPose, Track, TrackState};
use crate::aoa::{AoaError, ReceivedAoa};
pub use crate::config::{ChainOffsetsConfig, PipelineConfig};
use crate::config::{Config, ConfigError};
use crate::csi::Received;
use crate::fusion::bearing::Bearing;
use crate::fusion::choice::{Estimator, EstimatorKind};
use crate::fusion::error::EstimatorError;
use crate::fusion::paper::estimator::LinearConfig;
use crate::fusion::pose::{PoseEstimate, Step};
use crate::imu::{ImuGap, ImuSample};
use crate::rig::{ChainCalibration, Rig, RigError};
use crate::so3::exp;
use crate::time::Timestamp;

/// Why the pipeline cannot be built or an input was refused.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The AoA stage cannot be set up.
    #[error("AoA stage: {0}")]
    Aoa(#[from] AoaError),
    /// Settings that cannot be used (every one listed).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The rig cannot be used.
    #[error("rig: {0}")]
    Rig(#[from] RigError),
    /// No hypothesis of the chain offsets ran (cannot happen with a valid configuration).
    #[error("no hypothesis of the receive chains' offsets ran")]
    NoHypothesis,
    /// The estimator refused an input (counted; the state is unchanged).
    #[error(transparent)]
    LinearEstimator(#[from] EstimatorError),
}

/// Wall time spent per stage, s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageTiming {
    /// AoA: SpotFi and PAoA.
    pub aoa_s: f64,
    /// The estimator: IMU integration, window solves, marginalization.
    pub estimator_s: f64,
}

impl std::ops::AddAssign for StageTiming {
    fn add_assign(&mut self, other: Self) {
        self.aoa_s += other.aoa_s;
        self.estimator_s += other.estimator_s;
    }
}

/// WINS as one object (module doc).
#[derive(Debug)]
pub struct Pipeline {
    config: PipelineConfig,
    rig: Rig,
    aoa: ReceivedAoa,
    wins: Estimator,
    tracks: Vec<Track>,
    slot: FrameSlot,
    history: VecDeque<ImuSample>,
    /// The body's attitude integrated from the gyro (bias-corrected with the estimator's
    /// estimate) in a fixed frame of its own: the tracks' rotation, available from the first
    /// sample and unchanged by the estimator's restarts.
    gyro_from_body: UnitQuaternion<f64>,
    latest: Option<PoseEstimate>,
    /// Whether the tracks learn their rate and side from the angles (not with the paper's
    /// estimator: its model puts every AP in front, and it is run with the paper's Algorithm 1).
    learn_from_turns: bool,
    /// The estimator's frame changes seen so far (a start or restart gives a new `b0`).
    restarts_seen: u64,
    /// IMU gaps, and how far the rate may turn across one (`imu_gap`).
    imu_gap: ImuGap,
    stats: PipelineStats,
    timing: StageTiming,
}

/// The state may move an AP's track to the other side of the array only when the measured cone
/// angle is at least this far from broadside, degrees.
const SIDE_SWITCH_MIN_AOA_DEG: f64 = 60.0;

/// IMU samples kept for moving bearings to their frame, beyond the frame period.
const HISTORY_MARGIN_NS: i64 = 50_000_000;

impl Pipeline {
    /// A pipeline for `rig` (initialization-free: no state is needed) without a barometer.
    pub fn new(config: &Config, rig: Rig) -> Result<Self, PipelineError> {
        Self::with_baro(config, rig, false)
    }

    /// A pipeline for `rig`; `has_baro`: barometer samples will come ([`Self::push_baro`]).
    pub fn with_baro(config: &Config, rig: Rig, has_baro: bool) -> Result<Self, PipelineError> {
        config.validate()?;
        rig.validate()?;
        let aoa = ReceivedAoa::new(
            &config.aoa,
            rig.geometry,
            rig.center_freq_hz,
            rig.calibration.clone(),
        )?;
        let wins_config = LinearConfig {
            imu_gap: config.imu_gap,
            ..LinearConfig::for_rig(
                config.window.clone(),
                rig.imu_noise.clone(),
                rig.body_from_array,
            )
        };
        Ok(Self {
            tracks: vec![Track::default(); rig.ap_names.len()],
            stats: PipelineStats::new(&rig.ap_names),
            wins: Estimator::new(
                config.estimator,
                wins_config,
                config.nonlinear.clone(),
                has_baro,
            ),
            aoa,
            config: config.pipeline.clone(),
            rig,
            slot: FrameSlot::default(),
            history: VecDeque::new(),
            gyro_from_body: UnitQuaternion::identity(),
            latest: None,
            learn_from_turns: config.estimator != EstimatorKind::Paper,
            restarts_seen: 0,
            imu_gap: config.imu_gap,
            timing: StageTiming::default(),
        })
    }

    /// The estimator (AP positions, counters).
    pub fn wins(&self) -> &Estimator {
        &self.wins
    }

    /// Packet counters per AP.
    pub fn stats(&self) -> &PipelineStats {
        &self.stats
    }

    /// Wall time per stage so far.
    pub fn timing(&self) -> StageTiming {
        self.timing
    }

    /// The rig.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The chain calibration the AoA stage applies.
    pub fn chain_calibration(&self) -> &ChainCalibration {
        self.aoa.calibration()
    }

    /// Replaces the chain calibration the AoA stage applies from the next packet on (checked
    /// against the set-up as [`ReceivedAoa::set_calibration`]).
    pub fn set_chain_calibration(&mut self, calibration: ChainCalibration) -> Result<(), AoaError> {
        self.aoa.set_calibration(calibration)
    }

    /// Runs the estimator's keyframe solve that is due, if one is
    /// ([`crate::fusion::nonlinear::NonlinearEstimator::solve_pending`]): every push runs it
    /// first; a caller that sends poses calls it after sending them.
    pub fn solve_pending(&mut self) {
        let started = Instant::now();
        self.wins.solve_pending();
        self.timing.estimator_s += started.elapsed().as_secs_f64();
    }

    /// The latest pose, propagated to the last IMU sample.
    pub fn latest(&self) -> Option<&PoseEstimate> {
        self.latest.as_ref()
    }

    /// Integrates one IMU sample: first closes the frame it passes (its bearings go to the
    /// estimator), then lets the estimator solve every frame the sample passes.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<Step, PipelineError> {
        let started = Instant::now();
        self.wins.solve_pending();
        if self.slot.t.is_some_and(|t| t <= s.t) {
            self.flush_slot()?;
        }
        let step = self.wins.push_imu(s);
        self.timing.estimator_s += started.elapsed().as_secs_f64();
        let step = step?;
        let restarts = self.wins.epoch();
        if restarts != self.restarts_seen {
            // The latest pose is in the lost window's `b0`.
            self.restarts_seen = restarts;
            self.latest = None;
        }
        if let Some(p) = step.imu_pose {
            self.latest = Some(p);
        }
        if let Some(previous) = self.history.back() {
            let dt_s = s.t.secs_since(previous.t);
            if self.imu_gap.is_gap(dt_s)
                && dt_s * self.imu_gap.gyro_sigma_rad_s > self.config.track_gate_deg.to_radians()
            {
                // The gyro did not see the turns across the gap, which may have turned every
                // track's window off its AP (by more than the track's own gate): every track
                // starts over.
                for (track, stats) in self.tracks.iter_mut().zip(&mut self.stats.per_ap) {
                    if let TrackState::Tracking { .. } = track.state {
                        track.restart_after_silence();
                        stats.imu_gap_restarts += 1;
                    }
                }
            } else if dt_s > 0.0 {
                let bias = self.wins.gyro_bias_rad_s();
                self.gyro_from_body *= exp(&((previous.gyro_rad_s - bias) * dt_s));
                self.gyro_from_body.renormalize_fast();
            }
        }
        self.history.push_back(*s);
        let keep_from = self.slot.bearings.first().map_or(s.t.0, |b| b.t.0) - HISTORY_MARGIN_NS;
        while self.history.len() > 2 && self.history[1].t.0 < keep_from {
            self.history.pop_front();
        }
        Ok(step)
    }

    /// Queues a barometer altitude at `t` (IMU clock), m.
    pub fn push_baro(&mut self, t: Timestamp, altitude_m: f64) -> Result<(), PipelineError> {
        self.solve_pending();
        if self.slot.t.is_some_and(|st| st <= t) {
            self.flush_slot()?;
        }
        Ok(self.wins.push_baro(t, altitude_m)?)
    }

    /// Processes one packet of AP `ap` received at `t` (IMU clock); returns its log row.
    /// Packets must come in time order with the IMU samples (a packet at `t` before the samples
    /// after `t`).
    pub fn push_csi(&mut self, ap: usize, t: Timestamp, record: &Received) -> PacketLog {
        self.solve_pending();
        let converged = self.wins.is_converged();
        let mut row = PacketLog::new(ap, t, converged);
        if self.tracks.get(ap).is_none() {
            row.status = PacketStatus::Skipped;
            row.reason = format!("unknown AP index {ap}");
            self.stats.count_unknown_ap();
            return row;
        }
        let now = self
            .latest
            .map(|p| ArrayPose::of_body(&p.b0_from_body, &p.p_b_in_b0, &self.rig.body_from_array));
        let attitude = self.gyro_from_body * self.rig.body_from_array.rotation;
        let started = Instant::now();
        let silent = self.tracks[ap]
            .packet_at(t)
            .is_some_and(|s| s > self.config.max_silence_s);
        if silent {
            self.tracks[ap].restart_after_silence();
            self.stats.per_ap[ap].silences += 1;
            row.reason = "the AP fell silent: reacquiring with SpotFi".into();
        }
        if let TrackState::Acquiring { .. } = self.tracks[ap].state {
            self.acquire(ap, t, attitude, record, &mut row);
        } else {
            self.follow(ap, t, attitude, record, now.as_ref(), converged, &mut row);
        }
        self.timing.aoa_s += started.elapsed().as_secs_f64();
        self.stats.count(&row);
        row
    }

    /// Sends the open frame to the estimator, each bearing moved to the frame's time.
    fn flush_slot(&mut self) -> Result<(), PipelineError> {
        let Some(frame_t) = self.slot.t.take() else {
            return Ok(());
        };
        let pending = std::mem::take(&mut self.slot.bearings);
        let bias = self.wins.gyro_bias_rad_s();
        let bearings: Vec<Bearing> = pending
            .iter()
            .map(|p| {
                let bp_from_bk = rotation_between(&self.history, p.t, frame_t, &bias);
                let dt_s = frame_t.secs_since(p.t);
                move_bearing(p, &bp_from_bk.inverse(), dt_s, &self.rig.body_from_array)
            })
            .collect();
        let n = bearings.len();
        if let Err(e) = self.wins.push_bearings(frame_t, bearings) {
            self.stats.refused_bearings += n as u64;
            return Err(e.into());
        }
        Ok(())
    }
}
