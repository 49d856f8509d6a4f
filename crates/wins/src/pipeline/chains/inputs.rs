//! The inputs the hypotheses share: queued while the curvature is measured, fed to every
//! pipeline, and what each releases.

use super::super::Pipeline;
use super::Released;
use crate::csi::Received;
use crate::imu::ImuSample;
use crate::time::Timestamp;

/// One input of a pipeline's push API.
#[derive(Clone)]
pub(super) enum Input {
    Imu(ImuSample),
    Baro(Timestamp, f64),
    Csi(usize, Timestamp, Box<Received>),
}

/// One input into one pipeline; a sample the estimator refuses is counted, not an error.
pub(super) fn feed(p: &mut Pipeline, input: &Input) -> Released {
    let mut out = Released::default();
    match input {
        Input::Imu(s) => match p.push_imu(s) {
            Ok(step) => out.frames = step.frames,
            Err(_) => out.imu_refused = 1,
        },
        // A refused barometer sample is counted by the estimator.
        Input::Baro(t, h) => {
            let _ = p.push_baro(*t, *h);
        }
        Input::Csi(ap, t, record) => out.packets.push(p.push_csi(*ap, *t, record)),
    }
    out
}

/// Adds what `from` released to `to`.
pub(super) fn append(to: &mut Released, from: Released) {
    to.frames.extend(from.frames);
    to.packets.extend(from.packets);
    to.imu_refused += from.imu_refused;
}
