//! The replay's loop, shared by a dataset in memory and one read as it is consumed: inputs pushed
//! into a [`ChainResolver`] one at a time, what it releases handed to a [`RunSink`] as it comes.

use std::io;
use std::time::Instant;

use super::coverage::CoverageCheck;
use super::run_output::{ApEstimate, Evaluation, ReplayError, RunOutput};
use crate::config::Config;
use crate::dataset::checks::InputReport;
use crate::fusion::pose::{ApInWorld, PoseEstimate};
use crate::pipeline::{ChainResolver, PacketLog, Released};
use crate::rig::Rig;
use crate::time::{NANOS_PER_SEC, Timestamp};

/// Where a replay's frames and packet rows go, as they are produced, in order.
pub trait RunSink {
    /// One solved frame; `sent`: whether a flight controller is sent it
    /// ([`Released::is_sent`]).
    fn frame(&mut self, frame: PoseEstimate, sent: bool) -> io::Result<()>;
    /// One packet's row.
    fn packet(&mut self, row: PacketLog) -> io::Result<()>;
}

/// A sink that keeps everything in memory.
#[derive(Clone, Debug, Default)]
pub struct Collected {
    /// Every frame, in order.
    pub frames: Vec<PoseEstimate>,
    /// Beside `frames`: whether each was sent.
    pub sent: Vec<bool>,
    /// Every packet row, in order.
    pub packets: Vec<PacketLog>,
}

impl RunSink for Collected {
    fn frame(&mut self, frame: PoseEstimate, sent: bool) -> io::Result<()> {
        self.frames.push(frame);
        self.sent.push(sent);
        Ok(())
    }

    fn packet(&mut self, row: PacketLog) -> io::Result<()> {
        self.packets.push(row);
        Ok(())
    }
}

/// An AP's position in the world and its σ, m, when placed.
type ApFix = Option<ApInWorld>;

/// What a replay knows of its flight before it starts.
pub(crate) struct Flight<'a> {
    /// First to last IMU sample, s.
    pub flight_s: f64,
    /// Whether barometer samples will be pushed.
    pub has_baro: bool,
    /// The input checks' report.
    pub inputs: &'a InputReport,
}

/// Runs a pipeline for `rig` over the inputs `push` pushes (one per call, `None` after the
/// last), handing what is released to `sink`, each frame marked sent or not as `wins live`
/// marks it. The output's `frames`, `sent` and `packets` are empty; its `warnings` say only
/// whether the APs are those of before a loss.
pub(crate) fn drive(
    config: &Config,
    rig: Rig,
    flight: &Flight<'_>,
    sink: &mut dyn RunSink,
    mut push: impl FnMut(&mut ChainResolver) -> Result<Option<Released>, ReplayError>,
) -> Result<RunOutput, ReplayError> {
    let started = Instant::now();
    let mut pipeline = ChainResolver::new(config, rig, flight.has_baro)?;
    let mut imu_refused = 0;
    let mut coverage = CoverageCheck::default();
    let mut first_sent = None;
    // The APs as the last converged frame had them, and its time: what `aps.csv` keeps when the
    // run ends lost.
    let (mut held_aps, mut held_at): (Vec<ApFix>, Option<Timestamp>) = (Vec::new(), None);
    let mut keep = |r: Released| -> io::Result<Option<Timestamp>> {
        let sent: Vec<bool> = r.frames.iter().map(|f| r.is_sent(f)).collect();
        let mut last_converged = None;
        for (f, sent) in r.frames.into_iter().zip(sent) {
            if f.converged {
                coverage.push(f.t);
                last_converged = Some(f.t);
            }
            if sent {
                first_sent.get_or_insert(f.t);
            }
            sink.frame(f, sent)?;
        }
        for p in r.packets {
            sink.packet(p)?;
        }
        imu_refused += r.imu_refused;
        Ok(last_converged)
    };
    while let Some(released) = push(&mut pipeline)? {
        if let Some(t) = keep(released)? {
            held_aps.clear();
            held_aps.extend((0..pipeline.ap_count()).map(|l| pipeline.decided_ap_in_w(l)));
            held_at = Some(t);
        }
    }
    // What the end releases comes from the final state, which the APs below are taken from.
    let done = pipeline.finish()?;
    keep(done.released)?;
    let end = flight.inputs.imu.span_s.map_or(Timestamp(0), |(_, to)| {
        Timestamp((to * NANOS_PER_SEC as f64).round() as i64)
    });
    let coverage = coverage.finish(end);
    let wins = done.pipeline.wins();
    let names = &done.pipeline.rig().ap_names;
    // A run that ends lost has no AP left: it keeps those of its last converged frame (in that
    // frame's world, the one of the poses before the loss).
    let mut warnings = Vec::new();
    let current: Vec<ApFix> = (0..names.len()).map(|l| wins.ap_in_w(l)).collect();
    let lost = current.iter().all(Option::is_none);
    let final_aps = match held_at {
        Some(t) if lost && held_aps.iter().any(Option::is_some) => {
            warnings.push(format!(
                "the run ends lost: aps.csv holds the APs of the last converged pose, at {:.3} s",
                t.as_secs_f64()
            ));
            held_aps
        }
        _ => current,
    };
    let aps = names
        .iter()
        .zip(final_aps)
        .filter_map(|(name, ap)| {
            let ap = ap?;
            Some(ApEstimate {
                name: name.clone(),
                p_in_w: ap.p_in_w,
                sigma_m: ap.sigma_m(),
                covariance_in_w: ap.covariance_in_w,
            })
        })
        .collect();
    Ok(RunOutput {
        frames: Vec::new(),
        sent: Vec::new(),
        packets: Vec::new(),
        aps,
        converged_at: wins.converged_at(),
        first_sent,
        stats: done.pipeline.stats().clone(),
        wins: wins.stats(),
        phases: wins.timeline().to_vec(),
        timing: done.timing,
        chains: done.report,
        wall_s: started.elapsed().as_secs_f64(),
        flight_s: flight.flight_s,
        imu_refused,
        metrics: None,
        evaluation: Evaluation::NoTruth,
        inputs: flight.inputs.clone(),
        coverage,
        warnings,
        spooled: None,
    })
}
