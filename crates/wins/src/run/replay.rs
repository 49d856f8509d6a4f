//! A dataset directory through the pipeline (a [`crate::pipeline::ChainResolver`] over
//! [`crate::pipeline::Pipeline`]s): IMU
//! samples and every AP's packets merged by time (a packet before the IMU samples after it), as a
//! live driver would push them.

use super::drive::{Collected, Flight, RunSink, drive};
use crate::config::Config;
use crate::dataset::checks::InputReport;
use crate::dataset::stream::{DatasetEvent, DatasetStream};
use crate::dataset::{BaroSample, Dataset, Manifest};
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
/// kept in the output.
pub fn replay(dataset: &Dataset, rig: Rig, config: &Config) -> Result<RunOutput, ReplayError> {
    let (Some(first), Some(last)) = (dataset.imu.first(), dataset.imu.last()) else {
        return Err(ReplayError::NoImu);
    };
    let (baro, mut warnings) = baro_in_use(&dataset.baro, &dataset.inputs, config);
    // (time, 0 = packet / 1 = barometer / 2 = IMU, AP, index): packets and barometer samples
    // before IMU samples at the same time.
    let mut events: Vec<(Timestamp, u8, usize, usize)> = dataset
        .imu
        .iter()
        .enumerate()
        .map(|(i, s)| (s.t, 2, 0, i))
        .collect();
    events.extend(baro.iter().enumerate().map(|(i, b)| (b.t, 1, 0, i)));
    for (l, ap) in dataset.aps.iter().enumerate() {
        events.extend(ap.packets.iter().enumerate().map(|(i, p)| (p.t, 0, l, i)));
    }
    events.sort_unstable();
    let mut events = events.into_iter();
    let mut sink = Collected::default();
    let skips: Vec<(u64, u64)> = dataset
        .aps
        .iter()
        .map(|ap| (ap.skips.len() as u64, ap.skips.iter().map(|k| k.len).sum()))
        .collect();
    let flight = Flight {
        flight_s: last.t.secs_since(first.t),
        has_baro: !baro.is_empty(),
        inputs: &dataset.inputs,
    };
    let mut run = drive(config, rig, &flight, &mut sink, |pipeline| {
        let Some((_, kind, l, i)) = events.next() else {
            return Ok(None);
        };
        Ok(Some(if kind == 0 {
            let p = &dataset.aps[l].packets[i];
            pipeline.push_csi(l, p.t, &p.record)?
        } else if kind == 1 {
            pipeline.push_baro(baro[i].t, baro[i].altitude_m)?
        } else {
            pipeline.push_imu(&dataset.imu[i])?
        }))
    })?;
    set_skips(&mut run, &skips);
    run.frames = sink.frames;
    run.packets = sink.packets;
    warnings.append(&mut run.warnings);
    run.warnings = warnings;
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
    let (first, last) = stream.imu_span;
    let (baro, mut warnings) = baro_in_use(&stream.baro, &stream.inputs, config);
    let mut events = stream.events(!baro.is_empty()).map_err(Box::new)?;
    let flight = Flight {
        flight_s: last.secs_since(first),
        has_baro: !baro.is_empty(),
        inputs: &stream.inputs,
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
