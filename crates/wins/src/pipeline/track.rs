//! One AP's AoA track (paper Algorithm 1): the first angle from SpotFi over the AP's first
//! packets, then PAoA per packet around a prediction: the previous angle turned by the gyro's
//! rotation since, plus the translation part. Once converged that part is the state's (its
//! velocity at its range, paper `eqn:translation`); before, the range is not known and the track
//! learns the part as a rate from the angles themselves (an alpha-beta tracker, so a slow packet
//! rate leaves no lag). The estimated pose and AP give a gate once converged. A track that finds
//! no credible peak for too long starts over from SpotFi.
//!
//! The rotation comes from the pipeline's own gyro attitude (integrated at every IMU sample, with
//! the estimator's gyro bias once known), so the prediction turns with the array before the
//! estimator has a pose and through its restarts.
//!
//! A turn moves the cone angle of an AP in front one way and of an AP behind the other way, so the
//! prediction uses the track's side, and a turn through the array's axis carries the track to the
//! other side. SpotFi's first angle cannot tell the side: a track starts in front (the paper's
//! set-up) until the turns ([`Track::weigh_side`]) or the state say otherwise.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::aoa::AoaPrediction;
use crate::aoa::steering::aoa_rad;
use crate::csi::Received;
use crate::fusion::bearing::{Side, side_of};
use crate::time::Timestamp;

/// The rate is extrapolated over at most this long; an angle older than this restarts the rate
/// from zero (a gap of misses says nothing about the motion since), s.
const RATE_HORIZON_S: f64 = 0.3;

/// The largest cone-angle rate the track believes, rad/s (1 m/s across at 1 m).
const MAX_RATE_RAD_S: f64 = 1.0;

/// The rate takes at most this share of one interval's innovation ÷ interval.
const MAX_RATE_SHARE: f64 = 0.5;

/// The shortest interval a rate is learnt over, s (two packets in the same instant say nothing).
const MIN_RATE_DT_S: f64 = 1e-3;

/// Evidence (log-likelihood ratio) for the other side at which the track changes side.
const SIDE_SWITCH_EVIDENCE: f64 = 12.0;

/// One packet's share of the side evidence is clipped to this (one reflection cannot switch).
const SIDE_EVIDENCE_PER_PACKET: f64 = 1.5;

/// The gains of the alpha-beta track.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackGains {
    /// Share of the innovation the angle takes.
    pub angle: f64,
    /// The rate takes this much of the innovation per second, 1/s (per second, not per packet:
    /// the rate then settles in the same time at any packet rate).
    pub rate_hz: f64,
}

/// The array's pose in `b0` at one instant (from the estimator's propagated pose).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrayPose {
    /// `R_{a}^{b_0}`.
    pub b0_from_array: UnitQuaternion<f64>,
    /// Array centre in `b0`, m.
    pub p_a_in_b0: Vector3<f64>,
}

impl ArrayPose {
    /// The array pose of a body pose in `b0`.
    pub fn of_body(
        b0_from_body: &UnitQuaternion<f64>,
        p_b_in_b0: &Vector3<f64>,
        body_from_array: &Isometry3<f64>,
    ) -> Self {
        Self {
            b0_from_array: b0_from_body * body_from_array.rotation,
            p_a_in_b0: p_b_in_b0 + b0_from_body * body_from_array.translation.vector,
        }
    }

    /// The cone angle and side of a point (in `b0`) seen from this pose, or `None` when the point
    /// is at the array centre.
    pub fn bearing_to(&self, point_in_b0: &Vector3<f64>) -> Option<(f64, Side)> {
        let d = self.b0_from_array.inverse() * (point_in_b0 - self.p_a_in_b0);
        (d.norm() > 1e-9).then(|| (aoa_rad(&d), side_of(&d)))
    }
}

/// Where a track is.
#[derive(Clone, Debug)]
pub enum TrackState {
    /// Collecting the first packets for SpotFi.
    Acquiring {
        /// Records collected so far.
        records: Vec<Received>,
    },
    /// Following the AP packet by packet.
    Tracking {
        /// The last angle (measured or SpotFi's), rad.
        aoa_rad: f64,
        /// The change of the angle not due to rotation (the translation part), rad/s.
        rate_rad_s: f64,
        /// When the last angle was taken.
        t: Timestamp,
        /// The array's gyro attitude then (`gyro_from_array`: any fixed frame, the pipeline's
        /// gyro integration).
        attitude: UnitQuaternion<f64>,
        /// Consecutive packets without a credible peak.
        misses: usize,
    },
}

/// One AP's track.
#[derive(Clone, Debug)]
pub struct Track {
    /// The current state.
    pub state: TrackState,
    /// Packets gated in a row after convergence (see `PipelineConfig::max_gated_in_row`).
    pub gated_in_row: usize,
    /// The AP fell silent (see `PipelineConfig::max_silence_s`): the state's prediction, dead
    /// reckoned across the silence, is not trusted to gate until a bearing falls within it.
    pub state_doubted: bool,
    /// When the AP's last packet came (whatever became of it).
    pub last_packet: Option<Timestamp>,
    /// Packets off the track in a row (see `PipelineConfig::track_gate_deg`).
    pub off_track_in_row: usize,
    /// The side of the array the AP is on (front until the turns or the state say otherwise).
    pub side: Side,
    /// Evidence for the other side from how the angles follow the turns (a CUSUM of
    /// log-likelihood ratios, never below zero).
    pub side_evidence: f64,
}

impl Default for Track {
    fn default() -> Self {
        Self {
            state: TrackState::Acquiring {
                records: Vec::new(),
            },
            gated_in_row: 0,
            state_doubted: false,
            last_packet: None,
            off_track_in_row: 0,
            side: Side::Front,
            side_evidence: 0.0,
        }
    }
}

impl Track {
    /// The Algorithm-1 prediction for a packet at `t` with the array's gyro attitude `attitude`:
    /// the previous angle turned by the array's rotation since (no range is needed) plus the
    /// track's rate times the time since. `None` while acquiring.
    ///
    /// `translation`: the array's velocity in its own frame (m/s) and the range to the AP (m),
    /// from a state that knows them; the translation part is then the exact one of that motion
    /// (paper `eqn:translation`) and the learnt rate is not used.
    pub fn predict(
        &self,
        t: Timestamp,
        attitude: &UnitQuaternion<f64>,
        translation: Option<(Vector3<f64>, f64)>,
    ) -> Option<AoaPrediction> {
        self.predict_on(self.side, t, attitude, translation)
    }

    /// [`Self::predict`] with the AP on `side`.
    fn predict_on(
        &self,
        side: Side,
        t: Timestamp,
        attitude: &UnitQuaternion<f64>,
        translation: Option<(Vector3<f64>, f64)>,
    ) -> Option<AoaPrediction> {
        let TrackState::Tracking {
            aoa_rad,
            rate_rad_s,
            t: then,
            attitude: then_attitude,
            ..
        } = &self.state
        else {
            return None;
        };
        let aj_from_ai = attitude.inverse() * then_attitude;
        let dt_s = t.secs_since(*then);
        if let Some((v_a_in_a, range_m)) = translation {
            let p_aj_in_ai = then_attitude.inverse() * attitude * v_a_in_a * dt_s.max(0.0);
            return Some(AoaPrediction::from_motion(
                *aoa_rad,
                side == Side::Front,
                &aj_from_ai,
                &p_aj_in_ai,
                range_m,
            ));
        }
        let mut p = AoaPrediction::from_motion(
            *aoa_rad,
            side == Side::Front,
            &aj_from_ai,
            &Vector3::zeros(),
            f64::INFINITY,
        );
        if (0.0..=RATE_HORIZON_S).contains(&dt_s) && p.in_front_after == (side == Side::Front) {
            p.translation_part_rad = rate_rad_s * dt_s;
        }
        Some(p)
    }

    /// Weighs a measured angle at `t` for the side: a turn moves the cone angle of an AP in
    /// front one way and of an AP behind the other, so the side whose prediction keeps nearer
    /// the angles (σ `sigma_rad` each) gathers evidence. Switches the side and returns `true`
    /// when the other side's evidence passes [`SIDE_SWITCH_EVIDENCE`]. A linear array cannot
    /// tell the side any other way: without turns the evidence stays at zero.
    pub fn weigh_side(
        &mut self,
        aoa_rad: f64,
        t: Timestamp,
        attitude: &UnitQuaternion<f64>,
        translation: Option<(Vector3<f64>, f64)>,
        sigma_rad: f64,
    ) -> bool {
        let other = match self.side {
            Side::Front => Side::Back,
            Side::Back => Side::Front,
        };
        let (Some(this), Some(that)) = (
            self.predict_on(self.side, t, attitude, translation),
            self.predict_on(other, t, attitude, translation),
        ) else {
            return false;
        };
        let r_this = aoa_rad - this.predicted_aoa_rad();
        let r_that = aoa_rad - that.predicted_aoa_rad();
        let llr = (r_this.powi(2) - r_that.powi(2)) / (2.0 * sigma_rad.powi(2));
        self.side_evidence = (self.side_evidence
            + llr.clamp(-SIDE_EVIDENCE_PER_PACKET, SIDE_EVIDENCE_PER_PACKET))
        .max(0.0);
        if self.side_evidence < SIDE_SWITCH_EVIDENCE {
            return false;
        }
        // The rate learnt on the wrong side partly stood in for the turns' mirrored part.
        if let TrackState::Tracking { rate_rad_s, .. } = &mut self.state {
            *rate_rad_s = 0.0;
        }
        self.side = other;
        self.side_evidence = 0.0;
        true
    }

    /// Records an angle with no rate known (SpotFi's, or a track restarted).
    pub fn accept(&mut self, aoa_rad: f64, t: Timestamp, attitude: UnitQuaternion<f64>) {
        self.state = TrackState::Tracking {
            aoa_rad,
            rate_rad_s: 0.0,
            t,
            attitude,
            misses: 0,
        };
    }

    /// Records a measured angle `aoa_rad` at `t` against the track's `prediction` (an alpha-beta
    /// step): the angle moves by `gains.angle` of the innovation (one packet's multipath error
    /// does not become the next packet's window centre, which let tracks random-walk onto
    /// reflections; `1` keeps the raw angle, the paper's Algorithm 1) and the rate by
    /// `gains.rate_hz` of it per second, so a steady change is followed without
    /// lag. The track takes the predicted side (a turn through the array's axis carries the AP to
    /// the other side, where the rate's sign flips: it starts again from zero).
    pub fn update(
        &mut self,
        aoa_rad: f64,
        prediction: &AoaPrediction,
        gains: TrackGains,
        t: Timestamp,
        attitude: UnitQuaternion<f64>,
    ) {
        self.off_track_in_row = 0;
        let side = if prediction.in_front_after {
            Side::Front
        } else {
            Side::Back
        };
        let (rate_before, dt_s) = match &self.state {
            TrackState::Tracking {
                rate_rad_s,
                t: then,
                ..
            } => (*rate_rad_s, t.secs_since(*then)),
            TrackState::Acquiring { .. } => (0.0, f64::INFINITY),
        };
        let predicted_rad = prediction.predicted_aoa_rad();
        let innovation = aoa_rad - predicted_rad;
        let rate_rad_s = if gains.rate_hz == 0.0
            || side != self.side
            || !(MIN_RATE_DT_S..=RATE_HORIZON_S).contains(&dt_s)
        {
            0.0
        } else {
            let gain_per_s = gains.rate_hz.min(MAX_RATE_SHARE / dt_s);
            (rate_before + gain_per_s * innovation).clamp(-MAX_RATE_RAD_S, MAX_RATE_RAD_S)
        };
        self.side = side;
        self.state = TrackState::Tracking {
            aoa_rad: predicted_rad + gains.angle * innovation,
            rate_rad_s,
            t,
            attitude,
            misses: 0,
        };
    }

    /// Records a packet whose angle jumped off the track; returns `true` when more than
    /// `max_in_row` did so in a row: the track is then lost (acquiring again).
    pub fn off_track(&mut self, max_in_row: usize) -> bool {
        self.off_track_in_row += 1;
        if self.off_track_in_row > max_in_row {
            self.restart();
            return true;
        }
        false
    }

    /// Records a packet at `t`; returns the seconds since the previous one while tracking
    /// (`None` while acquiring or for the first packet).
    pub fn packet_at(&mut self, t: Timestamp) -> Option<f64> {
        let before = self.last_packet.replace(t)?;
        match &self.state {
            TrackState::Tracking { .. } => Some(t.secs_since(before)),
            TrackState::Acquiring { .. } => None,
        }
    }

    /// After a silence of the AP, or of the gyro (an IMU gap): starts over from SpotFi (the
    /// gyro's and the state's predictions have run on without an angle, or without the turns)
    /// and doubts the state's gate until a bearing agrees with it.
    pub fn restart_after_silence(&mut self) {
        self.restart();
        self.state_doubted = true;
    }

    /// Starts over from SpotFi (the side and its evidence are kept).
    fn restart(&mut self) {
        *self = Self {
            side: self.side,
            side_evidence: self.side_evidence,
            state_doubted: self.state_doubted,
            last_packet: self.last_packet,
            ..Self::default()
        };
    }

    /// Records a packet without a credible peak; returns `true` when the track was lost (it is
    /// then acquiring again).
    pub fn miss(&mut self, max_misses: usize) -> bool {
        if let TrackState::Tracking { misses, .. } = &mut self.state {
            *misses += 1;
            if *misses > max_misses {
                self.restart();
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests;
