//! Statistics of a capture's CSI beyond thermal noise: what a receiver adds that the AoA stage
//! has to live with, measured the same way on a real capture and on a simulated one, so the two
//! can be set side by side (`wins csi stats`, docs/VALIDATION.md "Simulated CSI against real").
//!
//! Per packet, on the configured stream's CSI `H[m, k]` (antenna `m`, subcarrier `k`):
//!
//! - the **eigenvalue spread** of the AoA stage's own smoothed covariance (the chains' measured
//!   curvature corrected, the timing offset removed, as `wins aoa` does), `λᵢ/λ₁` in dB for the
//!   2nd to 4th eigenvalues: how far under the strongest path the next paths, and then the floor
//!   of model error, sit;
//! - the **amplitude ripple**, the standard deviation over the subcarriers of `20 log₁₀|H[0, k]|`
//!   (frequency selectivity: multipath, and the receiver's own response), and the ripple between
//!   chains, of `20 log₁₀|H[m+1, k]/H[m, k]|`;
//! - the **phase ripple between chains**, the standard deviation over the subcarriers of
//!   `arg(H[m+1, k] H̄[m, k])` about its circular mean (one path gives a constant);
//! - the **timing offset**, from the slope of the unwrapped `arg H[0, k]` over the subcarriers'
//!   frequencies, `τ = −slope/2π`;
//! - the **credible MUSIC peaks** over the whole field of view (as `wins aoa` finds them, one per
//!   alias family), and whether one of them is **another direction**: its phase step between
//!   neighbouring antennas more than [`OTHER_DIRECTION_DEG`] from the strongest peak's, so that
//!   a rule that picks one peak per packet can jump to it.
//!
//! Over the capture: the median of each per-packet figure; the timing offsets' interquartile
//! range; the phase between chains 0 and 1 (its IQR, [`super::capture_check`]'s measure); the
//! curvature's agreement; and the AGC's changes per 100 packets.

use std::f64::consts::TAU;

use num_complex::Complex64;
use serde::Serialize;

use super::{AoaConfig, AoaError, AoaEstimator, AoaWindow, ChainCurvature, raw_csi};
use crate::csi::NUM_SUBCARRIERS;
use crate::csi::intel5300::CsiRecord;
use crate::csi::sanitize::wrap;
use crate::rig::ArrayGeometry;

/// A credible peak whose phase step between neighbouring antennas is further than this from the
/// strongest peak's is another direction, deg (the phase steps of one direction's peaks agree
/// within a few degrees on a static capture).
pub const OTHER_DIRECTION_DEG: f64 = 30.0;

/// The statistics of one capture (module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CaptureStats {
    /// Packets measured (three chains, the configured stream).
    pub packets: usize,
    /// IQR over packets of the phase between chains 0 and 1, deg.
    pub chain_phase_iqr_deg: f64,
    /// The chains' curvature's agreement over packets, |mean unit phasor| (1: angle-free).
    pub curvature_agreement: f64,
    /// Median over packets of `λ₂/λ₁`, `λ₃/λ₁`, `λ₄/λ₁`, dB.
    pub eigenvalue_db: [f64; 3],
    /// Median over packets of the amplitude ripple of chain 0 over the subcarriers, dB.
    pub amplitude_ripple_db: f64,
    /// Median over packets and neighbouring chains of the ripple of their amplitude ratio, dB.
    pub chain_amplitude_ripple_db: f64,
    /// Median over packets and neighbouring chains of their phase's ripple, deg.
    pub chain_phase_ripple_deg: f64,
    /// IQR over packets of the timing offset, ns.
    pub timing_offset_iqr_ns: f64,
    /// AGC changes per 100 packets.
    pub agc_changes_per_100: f64,
    /// Mean over packets of the credible MUSIC peaks over the whole field of view.
    pub peaks_per_packet: f64,
    /// Share of the packets with a credible peak in another direction than the strongest's
    /// ([`OTHER_DIRECTION_DEG`]), %.
    pub other_direction_pct: f64,
}

/// The statistics of `records` (those with the array's antenna count and the configured stream;
/// the rest are left out) with `config`'s smoothing and path count, for an array `geometry` at
/// `center_freq_hz`; `None` when no record is usable. The CSI is taken as the card delivers it
/// (the receiver's response left in: it is one of the things measured), with the chains'
/// curvature measured on the records corrected (as `wins aoa` does without a calibration).
/// Errors: the settings or the array do not make an estimator.
pub fn capture_stats(
    records: &[CsiRecord],
    config: &AoaConfig,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
) -> Result<Option<CaptureStats>, AoaError> {
    let config = AoaConfig {
        remove_receiver_response: false,
        ..config.clone()
    };
    let mut estimator = AoaEstimator::new(&config, geometry, center_freq_hz, None)?;
    let (antennas, tx) = (geometry.num_antennas, config.tx);
    let usable: Vec<(&CsiRecord, Vec<Complex64>)> = records
        .iter()
        .filter_map(|r| raw_csi(r, tx, antennas).ok().map(|csi| (r, csi)))
        .collect();
    if usable.is_empty() {
        return Ok(None);
    }
    let mut curvature = ChainCurvature::default();
    for (_, csi) in &usable {
        curvature.push(csi, antennas);
    }
    let corrected = curvature.corrected(
        estimator.calibration(),
        super::restart_step_rad(center_freq_hz),
        false,
    );
    estimator.set_calibration(corrected.calibration)?;

    let mut eigen: [Vec<f64>; 3] = Default::default();
    let (mut amplitude, mut chain_amplitude, mut chain_phase) =
        (Vec::new(), Vec::new(), Vec::new());
    let (mut pair_phase, mut timing) = (Vec::new(), Vec::new());
    let mut agc_changes = 0usize;
    let (mut peaks, mut other_direction) = (0usize, 0usize);
    let kappa = TAU * geometry.spacing_m * center_freq_hz / crate::rig::array::SPEED_OF_LIGHT_M_S;
    for (i, (r, csi)) in usable.iter().enumerate() {
        if i > 0 && usable[i - 1].0.header.agc != r.header.agc {
            agc_changes += 1;
        }
        let chain = |m: usize| &csi[m * NUM_SUBCARRIERS..(m + 1) * NUM_SUBCARRIERS];
        if let Ok((music, subspace)) = estimator.subspace(r) {
            let top = subspace.eigenvalues.first().copied().unwrap_or(0.0);
            for (j, list) in eigen.iter_mut().enumerate() {
                if let Some(&l) = subspace.eigenvalues.get(j + 1).filter(|_| top > 0.0) {
                    list.push(10.0 * (l.max(top * 1e-12) / top).log10());
                }
            }
            let found = music.peaks(&subspace, AoaWindow::FULL);
            peaks += found.len();
            let step = |aoa_rad: f64| kappa * aoa_rad.sin();
            if let Some(strongest) = found
                .iter()
                .min_by(|a, b| a.residual.total_cmp(&b.residual))
                && found.iter().any(|p| {
                    wrap(step(p.aoa_rad) - step(strongest.aoa_rad)).abs()
                        > OTHER_DIRECTION_DEG.to_radians()
                })
            {
                other_direction += 1;
            }
        }
        if let Some(a) = ripple_db(chain(0).iter().map(|h| h.norm())) {
            amplitude.push(a);
        }
        for m in 0..antennas.saturating_sub(1) {
            let (a, b) = (chain(m), chain(m + 1));
            let ratio = a.iter().zip(b).map(|(a, b)| b.norm() / a.norm());
            if let Some(x) = ripple_db(ratio) {
                chain_amplitude.push(x);
            }
            let phases: Vec<f64> = a.iter().zip(b).map(|(a, b)| (b * a.conj()).arg()).collect();
            chain_phase.push(circular_std(&phases).to_degrees());
            if m == 0 {
                let z: Complex64 = a.iter().zip(b).map(|(a, b)| b * a.conj()).sum();
                pair_phase.push(z.arg());
            }
        }
        let offsets = r.header.rate.bandwidth().subcarrier_offsets_hz();
        if let Some(slope) = phase_slope(chain(0), &offsets) {
            timing.push(-slope / TAU * 1e9);
        }
    }
    Ok(Some(CaptureStats {
        packets: usable.len(),
        chain_phase_iqr_deg: super::capture_check::phase_iqr_rad(&pair_phase).to_degrees(),
        curvature_agreement: curvature.agreement(),
        eigenvalue_db: eigen.map(|mut v| median(&mut v)),
        amplitude_ripple_db: median(&mut amplitude),
        chain_amplitude_ripple_db: median(&mut chain_amplitude),
        chain_phase_ripple_deg: median(&mut chain_phase),
        timing_offset_iqr_ns: iqr(&mut timing),
        agc_changes_per_100: 100.0 * agc_changes as f64 / usable.len() as f64,
        peaks_per_packet: peaks as f64 / usable.len() as f64,
        other_direction_pct: 100.0 * other_direction as f64 / usable.len() as f64,
    }))
}

/// Standard deviation of `20 log₁₀ x` over the values (`None` with a zero or fewer than 2).
fn ripple_db(values: impl Iterator<Item = f64>) -> Option<f64> {
    let db: Vec<f64> = values
        .map(|x| 20.0 * x.log10())
        .filter(|x| x.is_finite())
        .collect();
    if db.len() < 2 {
        return None;
    }
    let mean = db.iter().sum::<f64>() / db.len() as f64;
    Some((db.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (db.len() - 1) as f64).sqrt())
}

/// Standard deviation of angles about their circular mean, rad.
fn circular_std(angles: &[f64]) -> f64 {
    let mean = angles
        .iter()
        .map(|a| Complex64::from_polar(1.0, *a))
        .sum::<Complex64>()
        .arg();
    let n = angles.len().max(1) as f64;
    (angles.iter().map(|a| wrap(a - mean).powi(2)).sum::<f64>() / n).sqrt()
}

/// Least-squares slope of the unwrapped phase of `h` over the frequencies `f_hz`, rad/Hz.
fn phase_slope(h: &[Complex64], f_hz: &[f64]) -> Option<f64> {
    let mut phase = Vec::with_capacity(h.len());
    for (i, x) in h.iter().enumerate() {
        let p = x.arg();
        phase.push(match i {
            0 => p,
            _ => phase[i - 1] + wrap(p - h[i - 1].arg()),
        });
    }
    let n = h.len() as f64;
    let (mf, mp) = (f_hz.iter().sum::<f64>() / n, phase.iter().sum::<f64>() / n);
    let sxx: f64 = f_hz.iter().map(|f| (f - mf).powi(2)).sum();
    let sxy: f64 = f_hz
        .iter()
        .zip(&phase)
        .map(|(f, p)| (f - mf) * (p - mp))
        .sum();
    (sxx > 0.0 && sxy.is_finite()).then(|| sxy / sxx)
}

/// Median (NaN when empty).
fn median(v: &mut [f64]) -> f64 {
    quantile(v, 0.5)
}

/// Interquartile range (NaN when empty).
fn iqr(v: &mut [f64]) -> f64 {
    quantile(v, 0.75) - quantile(v, 0.25)
}

fn quantile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}
