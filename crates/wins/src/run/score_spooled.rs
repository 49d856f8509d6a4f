//! The scoring of a spooled run ([`super::run_dataset_into`]) against its dataset's truth
//! without holding either trajectory: the estimate's records and the truth's poses are read in
//! passes ([`crate::eval::stream`]); the metrics and figures' data are those
//! [`RunOutput::score_against_with`] gives for the same run held in memory.

use std::io;

use super::figure_data::RunFigures;
use super::output::TRUTH_PAIR_NS;
use super::run_output::{Evaluation, RunOutput};
use super::scoring_truth::ScoringTruth;
use super::spool::ScoringSpool;
use crate::eval::records::{AoaRecord, read_records};
use crate::eval::stream::{StreamedError, StreamedEval};
use crate::eval::{EvalOptions, Metrics};
use crate::time::Timestamp;

/// The poses the merge-join of the estimate and the truth holds: one of the driving trajectory,
/// and of the other the last before it and the next.
const POSES_HELD_BY_THE_JOIN: usize = 3;

/// `(AP, time s, measured AoA °, true AoA °)` of a fed packet with a truth row.
type AoaPair = (usize, f64, f64, f64);

impl RunOutput {
    /// Scores the spooled run whose scoring files are `spool` against `truth` (the figures'
    /// data too when `figures`); a run that cannot be scored says why in `warnings` and
    /// `evaluation`. Errors: a file that cannot be read again.
    pub(crate) fn score_spooled(
        &mut self,
        truth: &ScoringTruth,
        spool: &ScoringSpool,
        options: &EvalOptions,
        figures: bool,
    ) -> io::Result<()> {
        if let Some(s) = &mut self.spooled {
            s.scoring_poses_held = spool.est_scan.most_poses_held()
                + truth.poses.most_poses_held()
                + POSES_HELD_BY_THE_JOIN;
        }
        let eval = StreamedEval {
            est_path: spool.est_path.clone(),
            est: &spool.est_scan,
            truth_path: truth.poses_path.clone(),
            truth: &truth.poses,
            options,
        };
        let streamed = match eval.evaluate(&self.estimated_aps(), &truth.aps, figures) {
            Ok(s) => s,
            Err(StreamedError::Eval(e)) => {
                self.warnings.push(format!("cannot score the run: {e}"));
                self.evaluation = Evaluation::NotScored(e.to_string());
                return Ok(());
            }
            Err(StreamedError::Read(e)) => return Err(e),
        };
        let mut m = streamed.metrics;
        let (mut errors, pairs) = aoa_errors(spool, truth, figures)?;
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
        self.figures = match streamed.series {
            Some(series) if figures => {
                Some(self.streamed_figures(&eval, truth, &m, &series, &pairs)?)
            }
            _ => None,
        };
        self.metrics = Some(m);
        self.evaluation = Evaluation::Scored;
        Ok(())
    }

    /// [`RunOutput::figures`] from the files: `series` is the pairs' position error, `pairs`
    /// the fed packets' AoA against the truth.
    fn streamed_figures(
        &self,
        eval: &StreamedEval<'_>,
        truth: &ScoringTruth,
        metrics: &Metrics,
        series: &[(Timestamp, f64)],
        pairs: &[AoaPair],
    ) -> io::Result<RunFigures> {
        let align = &metrics.alignment;
        let t0 = truth.poses.first_t().map_or(0.0, |t| t.as_secs_f64());
        let xy = |p: &nalgebra::Vector3<f64>| (p.x, p.y);
        let aoa = self.aoa_series(pairs, t0, |l| {
            truth.packet_aoa_deg.get(l).map(|rows| {
                rows.iter()
                    .map(|&(t_ns, aoa_deg)| (t_ns as f64 * 1e-9 - t0, aoa_deg))
                    .collect()
            })
        });
        Ok(RunFigures {
            truth_xy: eval
                .truth_poses()?
                .map(|p| p.map(|p| xy(&p.p_b_in_w)))
                .collect::<io::Result<_>>()?,
            estimate_xy: eval
                .est_records()?
                .map(|r| r.map(|r| xy(&align.apply_point(&r.pose.p_b_in_w))))
                .collect::<io::Result<_>>()?,
            truth_aps_xy: truth.aps.iter().map(|a| (a.x_m, a.y_m)).collect(),
            estimated_aps_xy: self
                .aps
                .iter()
                .map(|a| xy(&align.apply_point(&a.p_in_w)))
                .collect(),
            position_error: series
                .iter()
                .map(|(t, e)| (t.as_secs_f64() - t0, *e))
                .collect(),
            converged_s: self.converged_at.map(|t| t.as_secs_f64() - t0),
            aoa,
        })
    }
}

/// `|AoA − true AoA|` of every fed packet with a truth row ([`RunOutput::aoa_vs_truth`]'s
/// pairing), and with `keep_pairs` the pairs themselves.
fn aoa_errors(
    spool: &ScoringSpool,
    truth: &ScoringTruth,
    keep_pairs: bool,
) -> io::Result<(Vec<f64>, Vec<AoaPair>)> {
    let (mut errors, mut pairs) = (Vec::new(), Vec::new());
    for r in read_records::<AoaRecord>(&spool.aoa_path, spool.aoa_count)? {
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
