//! A dataset through the pipeline (a [`crate::pipeline::ChainResolver`] over
//! [`crate::pipeline::Pipeline`]s): its inputs merged by time ([`crate::dataset::events`]), as a
//! live driver would push them, whether the dataset is held in memory or read as it is consumed.

use super::drive::{Collected, Flight, RunSink, drive};
use crate::config::Config;
use crate::dataset::checks::InputReport;
use crate::dataset::events::{DatasetEvent, Events};
use crate::dataset::stream::DatasetStream;
use crate::dataset::{BaroSample, Dataset, DatasetError, Manifest};
use crate::rig::ChainCalibration;
use crate::rig::ImuNoise;
use crate::rig::Rig;
use crate::time::Timestamp;

pub use super::run_output::{ApEstimate, Evaluation, ReplayError, RunOutput};

/// The rig of a dataset: its manifest, with the IMU noise and calibration overridable.
pub fn rig_of(
    dataset: &Dataset,
    imu_noise: Option<ImuNoise>,
    calibration: Option<ChainCalibration>,
) -> Result<Rig, ReplayError> {
    rig_of_manifest(
        &dataset.manifest,
        dataset.calibration.as_ref(),
        imu_noise,
        calibration,
    )
}

/// The rig of a manifest and its calibration, with the IMU noise and calibration overridable.
pub fn rig_of_manifest(
    m: &Manifest,
    own_calibration: Option<&ChainCalibration>,
    imu_noise: Option<ImuNoise>,
    calibration: Option<ChainCalibration>,
) -> Result<Rig, ReplayError> {
    Ok(Rig {
        card: m.array.card,
        geometry: m.array.geometry,
        body_from_array: m.array.body_from_array(),
        center_freq_hz: m.channel.center_freq_hz,
        calibration: calibration.or_else(|| own_calibration.cloned()),
        imu_noise: imu_noise
            .or_else(|| m.imu.noise.clone())
            .ok_or(ReplayError::NoImuNoise)?,
        ap_names: m.aps.iter().map(|a| a.name.clone()).collect(),
    })
}

/// Replays `dataset` (in memory) through a pipeline for `rig`; the frames and packet rows are
/// kept in the output. The same run as [`replay_stream`] of the files it was loaded from.
pub fn replay(dataset: &Dataset, rig: Rig, config: &Config) -> Result<RunOutput, ReplayError> {
    let (Some(first), Some(last)) = (dataset.imu.first(), dataset.imu.last()) else {
        return Err(ReplayError::NoImu);
    };
    let inputs = Inputs {
        imu_span: (first.t, last.t),
        baro: &dataset.baro,
        report: &dataset.inputs,
    };
    let mut sink = Collected::default();
    let mut run = replay_events(
        &inputs,
        |with_baro| Ok(dataset.events(with_baro)),
        rig,
        config,
        &mut sink,
    )?;
    run.frames = sink.frames;
    run.sent = sink.sent;
    run.packets = sink.packets;
    Ok(run)
}

/// Replays a checked dataset read as it is consumed ([`DatasetStream`]) through a pipeline for
/// `rig`: the frames and packet rows go to `sink` as they are produced (the output's `frames`
/// and `packets` stay empty).
pub fn replay_stream(
    stream: &DatasetStream,
    rig: Rig,
    config: &Config,
    sink: &mut dyn RunSink,
) -> Result<RunOutput, ReplayError> {
    let inputs = Inputs {
        imu_span: stream.imu_span,
        baro: &stream.baro,
        report: &stream.inputs,
    };
    replay_events(
        &inputs,
        |with_baro| stream.events(with_baro),
        rig,
        config,
        sink,
    )
}

/// What a replay knows of a dataset before its events.
struct Inputs<'a> {
    /// The first and last IMU sample kept.
    imu_span: (Timestamp, Timestamp),
    /// Its barometer readings.
    baro: &'a [BaroSample],
    /// The input checks' report.
    report: &'a InputReport,
}

/// The replay of a dataset's events (`events(with_baro)`) into `sink`, with the input checks'
/// warnings and the log readers' skips in the output.
fn replay_events<'a>(
    inputs: &Inputs<'_>,
    events: impl FnOnce(bool) -> Result<Events<'a>, DatasetError>,
    rig: Rig,
    config: &Config,
    sink: &mut dyn RunSink,
) -> Result<RunOutput, ReplayError> {
    let (first, last) = inputs.imu_span;
    let (baro, mut warnings) = baro_in_use(inputs.baro, inputs.report, config);
    let mut events = events(!baro.is_empty()).map_err(Box::new)?;
    let flight = Flight {
        flight_s: last.secs_since(first),
        has_baro: !baro.is_empty(),
        inputs: inputs.report,
    };
    let mut run = drive(config, rig, &flight, sink, |pipeline| {
        Ok(match events.next_event().map_err(Box::new)? {
            None => None,
            Some(DatasetEvent::Csi { ap, packet }) => {
                Some(pipeline.push_csi(ap, packet.t, &packet.record)?)
            }
            Some(DatasetEvent::Baro(b)) => Some(pipeline.push_baro(b.t, b.altitude_m)?),
            Some(DatasetEvent::Imu(s)) => Some(pipeline.push_imu(&s)?),
        })
    })?;
    set_skips(&mut run, &events.skips());
    warnings.append(&mut run.warnings);
    run.warnings = warnings;
    Ok(run)
}

/// The barometer's samples the run uses, and the input checks' warnings (with one more when the
/// settings leave the barometer out).
fn baro_in_use<'a>(
    baro: &'a [BaroSample],
    inputs: &InputReport,
    config: &Config,
) -> (&'a [BaroSample], Vec<String>) {
    let mut warnings = inputs.warnings.clone();
    if config.pipeline.use_barometer || baro.is_empty() {
        return (baro, warnings);
    }
    warnings.push(format!(
        "the barometer's {} samples were not used (pipeline.use_barometer = false)",
        baro.len()
    ));
    (&[], warnings)
}

/// Every AP's log skips `(stretches, bytes)` into the run's statistics.
fn set_skips(run: &mut RunOutput, skips: &[(u64, u64)]) {
    for (s, &(count, bytes)) in run.stats.per_ap.iter_mut().zip(skips) {
        s.log_skips = count;
        s.log_skipped_bytes = bytes;
    }
}
