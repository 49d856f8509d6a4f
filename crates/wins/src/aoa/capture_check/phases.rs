//! The findings on the chains' phases: how steady the phase between neighbouring chains is
//! within the capture, and the chains' curvature against a stored calibration.

use super::measure::{Measurements, spread};
use super::{CheckOptions, Finding, Verdict, finding, pct};
use crate::aoa::{curvature_of, restart_step_rad};
use crate::csi::sanitize::wrap;

/// A static capture's neighbouring chains keep their phase within a few degrees (the public
/// lgtm captures: under 2° IQR), deg.
pub(super) const STABLE_IQR_DEG: f64 = 10.0;
/// Packets whose chain phase is a whole step (90° or 180°) from the rest, above this share: the
/// phases stepped.
pub(super) const STEPPED_SHARE: f64 = 0.02;
/// Curvature within this of a multiple of the restart step is that multiple, deg.
const STEP_TOLERANCE_DEG: f64 = 45.0;
/// The curvature is angle-free for one path only: reflections bias each packet's by tens of
/// degrees, and its spread shows them (the agreement `R`, |mean unit phasor|: 1.00 on the
/// static lgtm captures at 1 m, 0.24 on a simulated hover in a room, whose mean is 127° off the
/// lab calibration's). Under this agreement it is not compared with a calibration.
const MIN_AGREEMENT: f64 = 0.7;
/// The largest standard error of its circular mean, `√(−2 ln R) / √N` over `N` packets, deg.
const MAX_CURVATURE_SE_DEG: f64 = 10.0;

pub(super) fn chain_phases(m: &Measurements) -> Finding {
    let spreads = [spread(&m.pair_phases_rad[0]), spread(&m.pair_phases_rad[1])];
    let [Some(a), Some(b)] = spreads else {
        return finding(
            "chain phases",
            Verdict::Unknown,
            "no packet with three chains and signal on each".into(),
            None,
        );
    };
    let deg = f64::to_degrees;
    let measured = format!(
        "B − A {:.1}° (IQR {:.1}°), C − B {:.1}° (IQR {:.1}°)",
        deg(a.mean_rad),
        deg(a.iqr_rad),
        deg(b.mean_rad),
        deg(b.iqr_rad)
    );
    let iqr = deg(a.iqr_rad.max(b.iqr_rad));
    let stepped = a.stepped.max(b.stepped);
    if iqr <= STABLE_IQR_DEG && stepped > STEPPED_SHARE {
        let first = a
            .first_step
            .into_iter()
            .chain(b.first_step)
            .min()
            .unwrap_or(0);
        let size = if a.quarter_steps || b.quarter_steps {
            "by multiples of 90°"
        } else {
            "by 180°"
        };
        return finding(
            "chain phases",
            Verdict::Bad,
            format!("{measured}; on {} of the packets they are off {size}, from packet {first} on", pct(stepped)),
            Some("the chains' phase offsets step within the capture (at 2.4 GHz the 5300 can step by 90° from packet to packet; at 5 GHz a restart steps them by 180°): AoA from these packets aliases; record on a 5 GHz channel and do not restart the NIC between calibration and flight".into()),
        );
    }
    steady_or_moving(measured, iqr)
}

/// The chain-phase finding of phases that do not step: stable when their IQR is within
/// [`STABLE_IQR_DEG`], else moving (which only a static capture says is wrong).
pub(super) fn steady_or_moving(measured: String, iqr_deg: f64) -> Finding {
    if iqr_deg <= STABLE_IQR_DEG {
        return finding(
            "chain phases",
            Verdict::Good,
            format!("{measured}: stable within the capture"),
            None,
        );
    }
    finding(
        "chain phases",
        Verdict::Unknown,
        format!("{measured}: they move within the capture"),
        Some("in flight they should (they follow the angle); on a static capture they should stay within a few degrees: a moving reflector nearby, or a loose antenna".into()),
    )
}

pub(super) fn calibration(m: &Measurements, options: &CheckOptions) -> Finding {
    let measured = m.curvature.curvature_rad();
    let agreement = m.curvature.agreement();
    let packets = m.curvature.packets.max(1) as f64;
    let se_deg =
        ((-2.0 * agreement.max(f64::MIN_POSITIVE).ln()).sqrt() / packets.sqrt()).to_degrees();
    let steady = agreement >= MIN_AGREEMENT && se_deg <= MAX_CURVATURE_SE_DEG;
    let Some(measured) = measured.filter(|_| steady) else {
        return finding(
            "calibration",
            Verdict::Unknown,
            format!(
                "the chains' curvature φA − 2φB + φC is not steady enough to compare (agreement \
                 {agreement:.2} over {} packets)",
                m.curvature.packets
            ),
            Some(
                "reflections, motion or a weak chain scatter it: check the calibration on a \
                  static capture with a clear line of sight to the AP; `wins run` resolves the \
                  chains in flight"
                    .into(),
            ),
        );
    };
    let curvature = format!(
        "curvature φA − 2φB + φC {:.1}° ± {se_deg:.1}° (agreement {agreement:.2})",
        measured.to_degrees()
    );
    let Some(given) = options.calibration.as_ref().and_then(curvature_of) else {
        return finding(
            "calibration",
            Verdict::Unknown,
            format!("{curvature}; no calibration given"),
            Some("with --calibration, the check says whether the chains moved since; `wins run` resolves them in flight, `wins aoa` needs a calibration (`wins calibrate`)".into()),
        );
    };
    let step = restart_step_rad(options.center_freq_hz.unwrap_or(5.32e9));
    let moved = wrap(measured - given);
    let steps = (moved / step).round();
    let off = (moved - steps * step).abs().to_degrees();
    let measured_text = format!(
        "{curvature} against the calibration's {:.1}°: moved by {:.1}°",
        given.to_degrees(),
        moved.to_degrees()
    );
    if off > STEP_TOLERANCE_DEG {
        return finding(
            "calibration",
            Verdict::Warning,
            measured_text,
            Some("not a whole restart step: a different array, channel or antenna order than the calibration's, or strong multipath; calibrate on this set-up".into()),
        );
    }
    if steps == 0.0 {
        return finding(
            "calibration",
            Verdict::Good,
            format!(
                "{measured_text}: the calibration holds (a step on chain B alone would not show here)"
            ),
            None,
        );
    }
    finding(
        "calibration",
        Verdict::Warning,
        format!("{measured_text}: {} restart step(s) of {:.0}°", steps.abs(), step.to_degrees()),
        Some("the NIC restarted since the calibration and a chain's offset moved by the restart step: `wins run` resolves it in flight; for `wins aoa`, calibrate again".into()),
    )
}
