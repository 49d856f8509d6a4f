//! One packet of a tracked AP ([`super::Pipeline::push_csi`]): the first packets start its track
//! from SpotFi (acquisition), every later one is PAoA around the track's prediction, gated by
//! the state once converged, and its bearing joins the open frame.

use super::slot::{PendingBearing, grid_time};
use super::track::{ArrayPose, TrackGains, TrackState};
use crate::csi::Received;
use crate::fusion::bearing::Bearing;
use crate::fusion::nonlinear::factors::cone::sin_sigma;
use crate::time::Timestamp;
use nalgebra::UnitQuaternion;

use super::SIDE_SWITCH_MIN_AOA_DEG;
use super::stats::{PacketLog, PacketStatus};

impl super::Pipeline {
    /// SpotFi over the first packets starts the track.
    pub(super) fn acquire(
        &mut self,
        ap: usize,
        t: Timestamp,
        attitude: UnitQuaternion<f64>,
        record: &Received,
        row: &mut PacketLog,
    ) {
        row.status = PacketStatus::Acquisition;
        let TrackState::Acquiring { records } = &mut self.tracks[ap].state else {
            return;
        };
        records.push(record.clone());
        if records.len() < self.config.init_packets {
            return;
        }
        let group = self.aoa.spotfi(records.iter());
        records.clear();
        match group.direct {
            Ok(direct) => {
                row.aoa_deg = Some(direct.aoa_rad.to_degrees());
                row.tof_ns = Some(direct.tof_s * 1e9);
                self.tracks[ap].accept(direct.aoa_rad, t, attitude);
                self.stats.per_ap[ap].acquisitions += 1;
            }
            Err(e) => {
                row.reason = format!("SpotFi found no direct path: {e}");
                self.stats.per_ap[ap].acquisition_failures += 1;
            }
        }
    }

    /// PAoA around the prediction, then into the frame slot.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn follow(
        &mut self,
        ap: usize,
        t: Timestamp,
        attitude: UnitQuaternion<f64>,
        record: &Received,
        now: Option<&ArrayPose>,
        converged: bool,
        row: &mut PacketLog,
    ) {
        let from_state = if converged {
            // What the array measures: the state's cone angle with the bearings' estimated
            // common offset.
            let bias = self.wins.sin_bias().map_or(0.0, |b| b.0);
            self.wins.ap_in_b0(ap).zip(now).and_then(|(c, pose)| {
                pose.bearing_to(&c).map(|(aoa, side)| {
                    let measured = (aoa.sin() + bias).clamp(-1.0, 1.0).asin();
                    ((measured, side), (c - pose.p_a_in_b0).norm())
                })
            })
        } else {
            None
        };
        // Algorithm 1: the previous angle turned by the gyro, plus the translation part: the
        // state's (its velocity and range) once converged, else the track's learnt rate. Not
        // the state's direction to the AP: a wrong state would then steer the window away from
        // the AP for good (measured: it did, on a busy AP).
        let translation = from_state.zip(self.latest).map(|((_, range_m), p)| {
            let v_b_in_b = p.world_from_body.inverse() * p.v_b_in_w;
            (
                self.rig.body_from_array.rotation.inverse() * v_b_in_b,
                range_m,
            )
        });
        let prediction = self.tracks[ap].predict(t, &attitude, translation);
        let Some(prediction) = prediction else {
            return;
        };
        let predicted = prediction.predicted_aoa_rad();
        row.predicted_aoa_deg = Some(predicted.to_degrees());
        let result = match self.aoa.paoa(record, &prediction) {
            Ok(r) => r,
            Err(e) => {
                row.status = PacketStatus::Skipped;
                row.reason = e.to_string();
                return;
            }
        };
        let Some(peak) = result.peak else {
            row.status = PacketStatus::NoCrediblePeak;
            if self.tracks[ap].miss(self.config.max_misses) {
                row.reason = "track lost: reacquiring with SpotFi".into();
                self.stats.per_ap[ap].track_losses += 1;
            }
            return;
        };
        row.aoa_deg = Some(peak.aoa_deg());
        row.tof_ns = Some(peak.tof_s * 1e9);
        row.residual = Some(peak.residual);
        row.candidates = Some(result.candidates);
        // The turns tell the side (the prediction of the other side follows the angles better).
        let sigma_rad = self.config.bearing_sigma_deg.to_radians();
        let prediction = if self.learn_from_turns
            && self.tracks[ap].weigh_side(peak.aoa_rad, t, &attitude, translation, sigma_rad)
        {
            self.stats.per_ap[ap].side_switches += 1;
            self.tracks[ap]
                .predict(t, &attitude, translation)
                .unwrap_or(prediction)
        } else {
            prediction
        };
        let predicted = prediction.predicted_aoa_rad();
        if (peak.aoa_rad - predicted).abs() > self.config.track_gate_deg.to_radians() {
            row.status = PacketStatus::OffTrack;
            if self.tracks[ap].off_track(self.config.max_off_track_in_row) {
                row.reason = "track lost: reacquiring with SpotFi".into();
                self.stats.per_ap[ap].track_losses += 1;
            }
            return;
        }
        // Once converged the state gives the translation part: the track learns no rate.
        let gains = TrackGains {
            angle: self.config.track_gain,
            rate_hz: if converged || !self.learn_from_turns {
                0.0
            } else {
                self.config.track_rate_gain_hz
            },
        };
        self.tracks[ap].update(peak.aoa_rad, &prediction, gains, t, attitude);
        // The side: continuous along the track (the AP crosses from front to back only through
        // the array's axis, |θ| → 90°); the state may switch it only there.
        let track = &mut self.tracks[ap];
        let side = match from_state {
            Some(((state_aoa, state_side), _)) => {
                let off = if self.config.gate_sigmas > 0.0 {
                    let sigma_pred = self.wins.predicted_sin_sigma(ap).unwrap_or(0.0);
                    let sigma_meas =
                        sin_sigma(peak.aoa_rad, self.config.bearing_sigma_deg.to_radians());
                    (peak.aoa_rad.sin() - state_aoa.sin()).abs()
                        > self.config.gate_sigmas * sigma_meas.hypot(sigma_pred)
                } else {
                    (peak.aoa_rad - state_aoa).abs() > self.config.gate_deg.to_radians()
                };
                // A run of gated packets means the state, not the AoA, is off: feed again.
                // After a silence the state is doubted until a bearing agrees with it.
                track.state_doubted &= off;
                if off && !track.state_doubted && track.gated_in_row < self.config.max_gated_in_row
                {
                    track.gated_in_row += 1;
                    row.status = PacketStatus::Gated;
                    return;
                }
                track.gated_in_row = 0;
                if state_side != track.side
                    && peak.aoa_rad.abs() >= SIDE_SWITCH_MIN_AOA_DEG.to_radians()
                {
                    track.side = state_side;
                }
                row.side_from_state = state_side == track.side;
                track.side
            }
            None if self.config.assume_front_until_converged => track.side,
            None => {
                row.status = PacketStatus::SideUnknown;
                return;
            }
        };
        row.side = Some(side);
        row.status = PacketStatus::Fed;
        let motion = from_state
            .zip(self.latest)
            .map(|((_, range), p)| (p.world_from_body.inverse() * p.v_b_in_w, range));
        let pending = PendingBearing {
            t,
            bearing: Bearing {
                ap,
                aoa_rad: peak.aoa_rad,
                side,
                sigma_rad: self.config.bearing_sigma_deg.to_radians(),
            },
            motion,
        };
        let frame_t = grid_time(t, (self.config.frame_period_ms * 1e6).round() as i64);
        if self.slot.t.is_some_and(|st| st != frame_t)
            && let Err(e) = self.flush_slot()
        {
            row.reason = format!("estimator refused the previous frame: {e}");
        }
        self.slot.t = Some(frame_t);
        self.slot.bearings.push(pending);
    }
}
