//! The accounting identity of a dataset run: what [`check_outcome`] asserts of
//! `wins::run_dataset` on any dataset folder, damaged or not.
//!
//! A refusal must say why (a non-empty message). A run must account for every input:
//!
//! - IMU: every data line of the CSV is a row read, or the one cut last line reported; every row
//!   read is kept or dropped for a counted reason (not finite, beyond range, time not
//!   increasing); every kept sample is integrated or refused by the estimator.
//! - CSI, per AP: every byte of the log is in exactly one decoded record or one counted skip,
//!   in file order; every record decoded is placed or dropped for a counted reason (repeated,
//!   after a clock jump); every placed packet reaches the pipeline and gets one row, fed,
//!   collected for acquisition, or dropped for a counted reason; the per-AP counters match the
//!   rows' statuses.
//! - Events: every event counted is listed or counted as not listed.
//! - Truth: the evaluation failed exactly when the truth cannot be read.
//!
//! Shared with the CLI-level fuzz target (`fuzz/fuzz_targets/dataset_run.rs`, by `#[path]`): it
//! uses only `std` and `wins`.

use std::error::Error;
use std::path::Path;

use wins::csi::intel5300::read_log;
use wins::dataset::Dataset;
use wins::dataset::truth::{TRUTH_DIR, Truth};
use wins::pipeline::PacketStatus;
use wins::run::replay::Evaluation;
use wins::{RunError, RunOutput};

/// `Ok` when `outcome` (a run of the dataset at `dir`) is a refusal with a reason or a run whose
/// counts add up; otherwise what does not add up.
pub fn check_outcome(dir: &Path, outcome: &Result<RunOutput, RunError>) -> Result<(), String> {
    match outcome {
        Err(e) => {
            let text = error_text(e);
            if text.trim().is_empty() {
                return Err(format!("a refusal without a reason: {e:?}"));
            }
            Ok(())
        }
        Ok(run) => check_run(dir, run),
    }
}

/// An error's message and its causes'.
pub fn error_text(e: &dyn Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

/// Fails with `what` unless `a == b`.
fn same(what: &str, a: u64, b: u64) -> Result<(), String> {
    if a == b {
        Ok(())
    } else {
        Err(format!("{what}: {a} != {b}"))
    }
}

/// The identity of a run that succeeded.
fn check_run(dir: &Path, run: &RunOutput) -> Result<(), String> {
    // The run loaded the dataset: loading it again gives the same checks.
    let data = Dataset::load(dir).map_err(|e| format!("the run loaded it, a reload fails: {e}"))?;
    if data.inputs != run.inputs {
        return Err("a reload's input report differs from the run's".into());
    }
    check_imu(dir, &data, run)?;
    check_aps(dir, &data, run)?;
    check_events(run)?;
    check_truth(dir, run)
}

/// IMU lines → rows → samples → integrated.
fn check_imu(dir: &Path, data: &Dataset, run: &RunOutput) -> Result<(), String> {
    let bytes = std::fs::read(dir.join(&data.manifest.imu.file))
        .map_err(|e| format!("reading the IMU file: {e}"))?;
    let text = String::from_utf8(bytes).map_err(|_| "the IMU file was read but is not UTF-8")?;
    let (mut lines, mut cut) = (0u64, false);
    for line in text.split_inclusive('\n') {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if line.ends_with('\n') {
            lines += 1;
        } else {
            cut = true;
        }
    }
    let imu = &run.inputs.imu;
    same("IMU data lines vs rows read", lines, imu.rows)?;
    if cut != imu.cut_last_line {
        return Err(format!(
            "IMU cut last line {cut}, reported {}",
            imu.cut_last_line
        ));
    }
    same(
        "IMU rows vs kept + not finite + beyond range + time not increasing",
        imu.rows,
        imu.samples + imu.not_finite + imu.beyond_range + imu.time_not_increasing,
    )?;
    same(
        "IMU samples kept vs loaded",
        imu.samples,
        data.imu.len() as u64,
    )?;
    same(
        "IMU samples kept vs integrated + refused",
        imu.samples,
        run.wins.imu_samples + run.wins.imu_refused,
    )?;
    same(
        "IMU samples refused by the estimator vs by the run",
        run.wins.imu_refused,
        run.imu_refused,
    )
}

/// Log bytes → records → placed packets → rows, per AP.
fn check_aps(dir: &Path, data: &Dataset, run: &RunOutput) -> Result<(), String> {
    let entries = &data.manifest.aps;
    same(
        "APs in the manifest vs inputs",
        entries.len() as u64,
        run.inputs.aps.len() as u64,
    )?;
    same(
        "APs in the manifest vs stats",
        entries.len() as u64,
        run.stats.per_ap.len() as u64,
    )?;
    same("packets of an unknown AP", run.stats.unknown_ap, 0)?;
    for (l, entry) in entries.iter().enumerate() {
        let at = |what: &str| format!("AP {l} ({}): {what}", entry.name);
        let path = dir.join(&entry.log);
        let file_len = std::fs::metadata(&path)
            .map_err(|e| at(&format!("log: {e}")))?
            .len();
        let log = read_log(&path).map_err(|e| at(&format!("log: {e}")))?;
        // Every byte in one record or one skip, in file order.
        let mut pieces: Vec<(u64, u64)> = log
            .records
            .iter()
            .map(|r| (r.offset, r.encoded_len() as u64))
            .chain(log.skips.iter().map(|s| (s.offset, s.len)))
            .collect();
        pieces.sort_unstable();
        let mut end = 0;
        for (offset, len) in pieces {
            if offset != end || len == 0 {
                return Err(at(&format!(
                    "log piece at {offset} (+{len}) after byte {end}"
                )));
            }
            end += len;
        }
        same(&at("log bytes tiled vs file length"), end, file_len)?;
        let stats = &run.stats.per_ap[l];
        same(&at("log skips"), stats.log_skips, log.skips.len() as u64)?;
        let skipped: u64 = log.skips.iter().map(|s| s.len).sum();
        same(&at("log skipped bytes"), stats.log_skipped_bytes, skipped)?;
        let ap = &run.inputs.aps[l];
        if ap.name != entry.name || stats.name != entry.name {
            return Err(at(&format!("named {:?} / {:?}", ap.name, stats.name)));
        }
        same(
            &at("records decoded vs read"),
            log.records.len() as u64,
            ap.records,
        )?;
        same(
            &at("records vs kept + repeated + after a clock jump"),
            ap.records,
            ap.kept + ap.repeated + ap.after_clock_jump,
        )?;
        same(
            &at("packets placed vs loaded"),
            ap.kept,
            data.aps[l].packets.len() as u64,
        )?;
        if ap.before_imu + ap.after_imu > ap.kept {
            return Err(at("more packets outside the IMU span than kept"));
        }
        same(
            &at("packets placed vs seen by the pipeline"),
            ap.kept,
            stats.packets,
        )?;
        same(
            &at("packets vs fed + acquisition + dropped"),
            stats.packets,
            stats.fed + stats.acquisition + stats.dropped(),
        )?;
        let rows: Vec<PacketStatus> = run
            .packets
            .iter()
            .filter(|r| r.ap == l)
            .map(|r| r.status)
            .collect();
        same(&at("rows vs packets"), rows.len() as u64, stats.packets)?;
        let n = |s: PacketStatus| rows.iter().filter(|&&r| r == s).count() as u64;
        for (status, count) in [
            (PacketStatus::Fed, stats.fed),
            (PacketStatus::Acquisition, stats.acquisition),
            (PacketStatus::NoCrediblePeak, stats.no_credible_peak),
            (PacketStatus::Gated, stats.gated),
            (PacketStatus::OffTrack, stats.off_track),
            (PacketStatus::SideUnknown, stats.side_unknown),
            (PacketStatus::Skipped, stats.skipped),
        ] {
            same(
                &at(&format!("rows {status:?} vs counter")),
                n(status),
                count,
            )?;
        }
    }
    let per_ap: u64 = run.stats.per_ap.iter().map(|s| s.packets).sum();
    same(
        "rows vs packets over all APs",
        run.packets.len() as u64,
        per_ap,
    )
}

/// Every event counted is listed or counted as not listed.
fn check_events(run: &RunOutput) -> Result<(), String> {
    let inputs = &run.inputs;
    let imu = &inputs.imu;
    let per_ap: u64 = inputs
        .aps
        .iter()
        .map(|a| u64::from(a.repeated > 0) + a.clock_jumps_back + a.silences)
        .sum();
    same(
        "events listed + not listed vs counted",
        inputs.events.len() as u64 + inputs.events_not_listed,
        imu.not_finite
            + imu.beyond_range
            + imu.time_not_increasing
            + u64::from(imu.cut_last_line)
            + imu.gaps
            + per_ap,
    )
}

/// The evaluation failed exactly when the truth cannot be read.
fn check_truth(dir: &Path, run: &RunOutput) -> Result<(), String> {
    let failed = matches!(run.evaluation, Evaluation::Failed(_));
    if !dir.join(TRUTH_DIR).is_dir() {
        return match run.evaluation {
            Evaluation::NoTruth => Ok(()),
            ref e => Err(format!("no truth folder, evaluation {e}")),
        };
    }
    match Truth::load(dir) {
        Ok(_) if failed => Err(format!("the truth reads, evaluation {}", run.evaluation)),
        Err(e) if !failed => Err(format!(
            "the truth fails ({e}), evaluation {}",
            run.evaluation
        )),
        _ => Ok(()),
    }
}
