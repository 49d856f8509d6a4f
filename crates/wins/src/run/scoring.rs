//! A run scored against its dataset's truth: one scoring for a run held in memory
//! ([`RunOutput::score_against`]) and a spooled one ([`super::run_dataset_into`]), reading the
//! estimate and the truth in passes ([`crate::eval::stream`]) from memory or from the spool's
//! files, so the metrics and figures' data are the same either way and a spooled run holds
//! neither trajectory.

use std::io;
use std::path::Path;

use super::output::TRUTH_PAIR_NS;
use super::run_output::{Evaluation, RunOutput};
use super::scoring_truth::ScoringTruth;
use super::spool::{ScoringSpool, aoa_record, est_record};
use crate::dataset::truth::Truth;
use crate::eval::records::{AoaRecord, EstRecord, read_records};
use crate::eval::scan::TrajectoryScan;
use crate::eval::stream::{EstSource, StreamedError, StreamedEval};
use crate::eval::{EvalError, EvalOptions, Metrics, SentMetrics};

/// The poses the merge-join of the estimate and the truth holds: one of the driving trajectory,
/// and of the other the last before it and the next.
const POSES_HELD_BY_THE_JOIN: usize = 3;

/// `(AP, time s, measured AoA °, true AoA °)` of a fed packet with a truth row.
type AoaPair = (usize, f64, f64, f64);

/// What the scoring reads of a run's estimate.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ScoringEstimate<'a> {
    /// The converged poses with their position covariances, in time order.
    poses: EstSource<'a>,
    /// What one pass over them found.
    scan: &'a TrajectoryScan,
    /// The poses sent to a flight controller, in time order.
    sent: EstSource<'a>,
    /// What one pass over them found.
    sent_scan: &'a TrajectoryScan,
    /// The fed packets' AoA, in processing order.
    aoa: AoaSource<'a>,
}

/// Where the fed packets' AoA are read from.
#[derive(Clone, Copy, Debug)]
enum AoaSource<'a> {
    /// A file of [`AoaRecord`]s, with so many.
    File(&'a Path, usize),
    /// Records in memory.
    Records(&'a [AoaRecord]),
}

impl<'a> ScoringEstimate<'a> {
    /// The spool's scoring files.
    pub(crate) fn spooled(spool: &'a ScoringSpool) -> Self {
        Self {
            poses: EstSource::File(&spool.est_path),
            scan: &spool.est_scan,
            sent: EstSource::File(&spool.sent_path),
            sent_scan: &spool.sent_scan,
            aoa: AoaSource::File(&spool.aoa_path, spool.aoa_count),
        }
    }
}

impl RunOutput {
    /// Scores the run against `truth` ([`RunOutput::score`]) and keeps the metrics; when it
    /// cannot be scored (it never converged, say), says why in `warnings` and `evaluation`.
    pub fn score_against(&mut self, truth: &Truth, options: &EvalOptions) {
        if let Err(e) = self.score_held(&ScoringTruth::of(truth), options) {
            // Records in memory are read again without fail; should one not be, say so.
            self.not_scored(&e.to_string());
        }
    }

    /// Scores the run, held in memory, against `truth`; a run that cannot be scored says why
    /// in `warnings` and `evaluation`. Errors: a truth file that cannot be read again.
    pub(crate) fn score_held(
        &mut self,
        truth: &ScoringTruth<'_>,
        options: &EvalOptions,
    ) -> io::Result<()> {
        let scored = self.in_memory(|run, est| run.scored(&est, truth, options));
        self.keep(scored)
    }

    /// The run scored against `truth`: the converged trajectory's metrics ([`crate::eval`]),
    /// with the run-only fields (AoA median error, position NEES, packets, real-time factor).
    /// A spooled run holds no frames: [`super::run_dataset_into`] scores it from its files.
    pub fn score(&self, truth: &Truth, options: &EvalOptions) -> Result<Metrics, EvalError> {
        let scored = self.in_memory(|run, est| run.scored(&est, &ScoringTruth::of(truth), options));
        match scored {
            Ok(metrics) => Ok(metrics),
            Err(StreamedError::Eval(e)) => Err(e),
            Err(StreamedError::Read(e)) => Err(EvalError::Read(e.to_string())),
        }
    }

    /// Scores the spooled run whose scoring files are `spool` against `truth`; a run that
    /// cannot be scored says why in `warnings` and `evaluation`. Errors: a file that cannot be
    /// read again.
    pub(crate) fn score_spooled(
        &mut self,
        truth: &ScoringTruth<'_>,
        spool: &ScoringSpool,
        options: &EvalOptions,
    ) -> io::Result<()> {
        if let Some(s) = &mut self.spooled {
            s.scoring_poses_held = spool.est_scan.most_poses_held()
                + truth.scan.most_poses_held()
                + POSES_HELD_BY_THE_JOIN;
        }
        let scored = self.scored(&ScoringEstimate::spooled(spool), truth, options);
        self.keep(scored)
    }

    /// `f` of the run with its estimate held in memory.
    fn in_memory<T>(&self, f: impl FnOnce(&Self, ScoringEstimate<'_>) -> T) -> T {
        let poses: Vec<EstRecord> = self.frames.iter().filter_map(est_record).collect();
        let sent: Vec<EstRecord> = self.sent_frames().filter_map(est_record).collect();
        let aoa: Vec<AoaRecord> = self.packets.iter().filter_map(aoa_record).collect();
        let scan_of = |records: &[EstRecord]| {
            let mut scan = TrajectoryScan::default();
            records.iter().for_each(|r| scan.push(&r.pose));
            scan
        };
        let (scan, sent_scan) = (scan_of(&poses), scan_of(&sent));
        f(
            self,
            ScoringEstimate {
                poses: EstSource::Records(&poses),
                scan: &scan,
                sent: EstSource::Records(&sent),
                sent_scan: &sent_scan,
                aoa: AoaSource::Records(&aoa),
            },
        )
    }

    /// Keeps a scoring's outcome: its metrics, or why the run cannot be scored.
    /// Errors: a trajectory that could not be read again.
    fn keep(&mut self, scored: Result<Metrics, StreamedError>) -> io::Result<()> {
        match scored {
            Ok(metrics) => {
                self.metrics = Some(metrics);
                self.evaluation = Evaluation::Scored;
                Ok(())
            }
            Err(StreamedError::Eval(e)) => {
                self.not_scored(&e.to_string());
                Ok(())
            }
            Err(StreamedError::Read(e)) => Err(e),
        }
    }

    /// The run cannot be scored, for `why`.
    fn not_scored(&mut self, why: &str) {
        self.warnings.push(format!("cannot score the run: {why}"));
        self.evaluation = Evaluation::NotScored(why.to_string());
    }

    /// The metrics of `est` against `truth`.
    fn scored(
        &self,
        est: &ScoringEstimate<'_>,
        truth: &ScoringTruth<'_>,
        options: &EvalOptions,
    ) -> Result<Metrics, StreamedError> {
        let eval = StreamedEval {
            est: est.poses,
            est_scan: est.scan,
            truth: truth.poses(),
            truth_scan: &truth.scan,
            options,
        };
        let streamed = eval.evaluate(&self.estimated_aps(), &truth.aps)?;
        let mut m = streamed.metrics;
        let (mut errors, _) = aoa_errors(est.aoa, truth, false)?;
        errors.sort_by(f64::total_cmp);
        m.aoa_error_median_deg = errors.get(errors.len() / 2).copied();
        drop(errors);
        if let Some(n) = streamed.nees {
            m.position_nees_mean = Some(n.mean);
            m.position_nees_within_95 = Some(n.within_95);
        }
        m.packets_used = Some(self.stats.fed());
        m.packets_dropped = Some(self.stats.dropped());
        m.realtime_factor = Some(self.realtime_factor());
        m.sent = sent_metrics(est, truth, options)?;
        Ok(m)
    }

    /// `(AP, time s, measured AoA °, true AoA °)` of every fed packet that has a truth row.
    pub fn aoa_vs_truth(&self, truth: &Truth) -> Vec<(usize, f64, f64, f64)> {
        let aoa: Vec<AoaRecord> = self.packets.iter().filter_map(aoa_record).collect();
        aoa_errors(AoaSource::Records(&aoa), &ScoringTruth::of(truth), true)
            .map_or_else(|_| Vec::new(), |(_, pairs)| pairs)
    }
}

/// The poses sent scored alone ([`SentMetrics`]); too few to score leaves the errors null.
/// Errors: a file that cannot be read again.
fn sent_metrics(
    est: &ScoringEstimate<'_>,
    truth: &ScoringTruth<'_>,
    options: &EvalOptions,
) -> Result<SentMetrics, StreamedError> {
    let eval = StreamedEval {
        est: est.sent,
        est_scan: est.sent_scan,
        truth: truth.poses(),
        truth_scan: &truth.scan,
        options,
    };
    let mut sent = SentMetrics {
        poses: est.sent_scan.poses(),
        time_to_first_s: est
            .sent_scan
            .first_t()
            .zip(truth.scan.first_t())
            .map(|(first_sent, first_truth)| first_sent.secs_since(first_truth)),
        ..SentMetrics::default()
    };
    match eval.evaluate(&[], &[]) {
        Ok(s) => {
            sent.ate_rmse_m = Some(s.metrics.ate_rmse_m);
            sent.position_error_median_m = Some(s.metrics.position_error_median_m);
            sent.position_error_max_m = Some(s.metrics.position_error_max_m);
            sent.attitude_error_rmse_deg = Some(s.metrics.attitude_error_rmse_deg);
            sent.position_nees_mean = s.nees.map(|n| n.mean);
        }
        Err(StreamedError::Eval(_)) => {}
        Err(e) => return Err(e),
    }
    Ok(sent)
}

/// `|AoA − true AoA|` of every fed packet with a truth row (the slot within
/// [`TRUTH_PAIR_NS`] of the packet's time), and with `keep_pairs` the pairs themselves.
fn aoa_errors(
    aoa: AoaSource<'_>,
    truth: &ScoringTruth<'_>,
    keep_pairs: bool,
) -> io::Result<(Vec<f64>, Vec<AoaPair>)> {
    let (mut errors, mut pairs) = (Vec::new(), Vec::new());
    let records: Box<dyn Iterator<Item = io::Result<AoaRecord>>> = match aoa {
        AoaSource::File(path, count) => Box::new(read_records::<AoaRecord>(path, count)?),
        AoaSource::Records(records) => Box::new(records.iter().map(|r| Ok(*r))),
    };
    for r in records {
        let AoaRecord { ap, t_ns, aoa_deg } = r?;
        let Some(rows) = truth.packet_aoa_deg.get(ap) else {
            continue;
        };
        let i = rows.partition_point(|p| p.0 < t_ns - TRUTH_PAIR_NS);
        let row = rows.get(i).filter(|p| (p.0 - t_ns).abs() <= TRUTH_PAIR_NS);
        let (Some(&(_, true_deg)), Some(est_deg)) = (row, aoa_deg) else {
            continue;
        };
        errors.push((est_deg - true_deg).abs());
        if keep_pairs {
            pairs.push((ap, t_ns as f64 * 1e-9, est_deg, true_deg));
        }
    }
    Ok((errors, pairs))
}
