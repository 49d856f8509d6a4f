//! Estimating the receive chains' phase offsets from a capture at a known angle.
//!
//! A circular mean of the inter-antenna phase is biased by multipath: in a static capture the
//! reflections add the same error to every packet. Instead each packet's *direct-path array
//! response* is measured without assuming any array model, by the rank-reduction idea (RARE,
//! Pesavento et al. 2002): MUSIC without antenna smoothing (`M_s = M`, every antenna in each
//! window; smoothing over subcarriers only, and no forward–backward averaging, both of which
//! assume a calibrated array). For an unknown response `v` the steering vector is `v ⊗ b(τ)`, and
//! the best `v` at ToF τ is the top eigenvector of the `M × M` matrix `G(τ)` of [`super::music`]
//! (its eigenvalue over `M·W` is the in-subspace fraction). The lowest-ToF credible minimum of
//! `1 − λ_max(G(τ))/W` (for a unit-norm `v`) is the direct path; its eigenvector is `v ∝ diag(e^{jψ})·a(θ_known)`,
//! so `ψ_m − ψ_0 = arg(v_m·v̄_0) − arg(a_m·ā_0)`. Packets are combined by a circular mean.
//! Reflections separated from the direct path in ToF do not bias it; a moving capture averages
//! out the rest.

use nalgebra::DMatrix;
use num_complex::Complex64;

use super::estimator::{AoaConfig, AoaError, received_csi};
use super::music::{Music, MusicConfig};
use crate::aoa::packet::chains_flip_sign;
use crate::csi::intel5300::CsiRecord;
use crate::csi::packet::CsiPacket;
use crate::csi::sanitize::sanitize;
use crate::rig::ArrayGeometry;
use crate::rig::{CalibrationSetup, ChainCalibration};

/// What went into a calibration.
#[derive(Debug, Default)]
pub struct CalibrateReport {
    /// Packets whose direct-path response was used.
    pub used: usize,
    /// Packets skipped: their index in the input and why.
    pub skipped: Vec<(usize, String)>,
    /// Bandwidths of the packets used, sorted.
    pub bandwidths: Vec<crate::csi::Bandwidth>,
}

/// Why no calibration came out.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// No packet gave a direct-path response.
    #[error("no usable packet ({skipped} skipped; first reason: {first})")]
    NoPackets {
        /// Packets skipped.
        skipped: usize,
        /// The first skip reason.
        first: String,
    },
    /// The known angle is not in [−90°, 90°].
    #[error("known AoA {0} rad outside [−π/2, π/2]")]
    Angle(f64),
    /// The estimator settings do not fit.
    #[error(transparent)]
    Aoa(#[from] AoaError),
}

/// Chain offsets from `records` captured with the AP at `known_aoa_rad` (a per-packet angle can
/// be given instead with [`calibrate_with`]).
pub fn calibrate<'a>(
    records: impl IntoIterator<Item = &'a CsiRecord>,
    known_aoa_rad: f64,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    config: &AoaConfig,
) -> Result<(ChainCalibration, CalibrateReport), CalibrateError> {
    calibrate_with(
        records.into_iter().map(|r| (r, known_aoa_rad)),
        geometry,
        center_freq_hz,
        config,
    )
}

/// Chain offsets from `(record, true AoA)` pairs, e.g. a moving capture with a reference system
/// (or the simulator's truth).
pub fn calibrate_with<'a>(
    packets: impl IntoIterator<Item = (&'a CsiRecord, f64)>,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    config: &AoaConfig,
) -> Result<(ChainCalibration, CalibrateReport), CalibrateError> {
    let m = geometry.num_antennas;
    let unsmoothed = MusicConfig {
        antennas_per_window: m,
        forward_backward: false,
        ..config.music.clone()
    };
    let musics = [crate::csi::Bandwidth::Ht20, crate::csi::Bandwidth::Ht40].map(|bw| {
        let w = match bw {
            crate::csi::Bandwidth::Ht20 => config.music.subcarriers_per_window_ht20,
            crate::csi::Bandwidth::Ht40 => config.music.subcarriers_per_window_ht40,
        };
        Music::new(
            &unsmoothed,
            geometry,
            center_freq_hz,
            &bw.subcarrier_offsets_hz(),
            w,
        )
    });
    let [ht20, ht40] = musics;
    let (ht20, ht40) = (ht20.map_err(AoaError::from)?, ht40.map_err(AoaError::from)?);
    let mut acc = Accumulator::new(m, false);
    for (i, (record, aoa)) in packets.into_iter().enumerate() {
        check_angle(aoa)?;
        let bw = record.header.rate.bandwidth();
        let music = match bw {
            crate::csi::Bandwidth::Ht20 => &ht20,
            crate::csi::Bandwidth::Ht40 => &ht40,
        };
        let response = received_csi(record, config.tx, m, config.remove_receiver_response)
            .map_err(|e| e.to_string())
            .and_then(|csi| direct_response(csi, &bw.subcarrier_offsets_hz(), music, m));
        match response {
            Ok(v) => acc.add(&v, &geometry.steering(center_freq_hz, aoa.sin()), Some(bw)),
            Err(reason) => acc.report.skipped.push((i, reason)),
        }
    }
    acc.finish(geometry, center_freq_hz)
}

/// Chain offsets from packets of any card ([`CsiPacket`]) captured with the AP at
/// `known_aoa_rad`, MUSIC run over each packet's own subcarriers. On a card whose second chain
/// flips sign from packet to packet ([`crate::aoa::packet::chains_flip_sign`]) the offsets are
/// measured modulo π: each packet's phase is doubled before the mean and halved after, so the
/// flips do not smear it (and the calibrated angles keep their twins).
pub fn calibrate_packets(
    packets: &[CsiPacket],
    known_aoa_rad: f64,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    config: &AoaConfig,
) -> Result<(ChainCalibration, CalibrateReport), CalibrateError> {
    calibrate_packets_with(
        packets.iter().map(|p| (p, known_aoa_rad)),
        geometry,
        center_freq_hz,
        config,
    )
}

/// [`calibrate_packets`] from `(packet, true AoA)` pairs, e.g. a moving capture with a reference
/// system (or the simulator's truth).
pub fn calibrate_packets_with<'a>(
    packets: impl IntoIterator<Item = (&'a CsiPacket, f64)>,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    config: &AoaConfig,
) -> Result<(ChainCalibration, CalibrateReport), CalibrateError> {
    let m = geometry.num_antennas;
    let unsmoothed = MusicConfig {
        antennas_per_window: m,
        forward_backward: false,
        ..config.music.clone()
    };
    let mut packets = packets.into_iter().peekable();
    let fold = packets.peek().is_some_and(|(p, _)| chains_flip_sign(p));
    let mut acc = Accumulator::new(m, fold);
    let mut musics: Vec<(Vec<i32>, Music)> = Vec::new();
    for (i, (p, aoa)) in packets.enumerate() {
        check_angle(aoa)?;
        let expected = geometry.steering(center_freq_hz, aoa.sin());
        let Some(csi) = p.antenna_rows(config.tx).filter(|_| p.num_rx() == m) else {
            acc.report.skipped.push((
                i,
                format!("{} chains or no stream {}", p.num_rx(), config.tx),
            ));
            continue;
        };
        let offsets = p.offsets_hz();
        if !musics.iter().any(|(s, _)| *s == p.subcarriers) {
            let w = if p.bandwidth_mhz <= 20 {
                config.music.subcarriers_per_window_ht20
            } else {
                config.music.subcarriers_per_window_ht40
            };
            let music = Music::new(&unsmoothed, geometry, center_freq_hz, &offsets, w)
                .map_err(AoaError::from)?;
            musics.push((p.subcarriers.clone(), music));
        }
        let Some((_, music)) = musics.iter().find(|(s, _)| *s == p.subcarriers) else {
            continue;
        };
        let bw = match p.bandwidth_mhz {
            20 => Some(crate::csi::Bandwidth::Ht20),
            40 => Some(crate::csi::Bandwidth::Ht40),
            _ => None,
        };
        match direct_response(csi, &offsets, music, m) {
            Ok(v) => acc.add(&v, &expected, bw),
            Err(reason) => acc.report.skipped.push((i, reason)),
        }
    }
    acc.finish(geometry, center_freq_hz)
}

/// An angle a calibration can be made at: within [−90°, 90°].
fn check_angle(aoa: f64) -> Result<(), CalibrateError> {
    if aoa.is_nan() || aoa.abs() > std::f64::consts::FRAC_PI_2 {
        return Err(CalibrateError::Angle(aoa));
    }
    Ok(())
}

/// The packets' direct-path responses summed into per-chain offsets.
struct Accumulator {
    sums: Vec<Complex64>,
    report: CalibrateReport,
    /// Offsets modulo π (phases doubled before the mean).
    fold: bool,
    /// With `fold`, each packet's unit phasor per chain, to choose the branch of the halved
    /// mean that most packets sit on.
    units: Vec<Vec<Complex64>>,
}

impl Accumulator {
    fn new(m: usize, fold: bool) -> Self {
        Self {
            sums: vec![Complex64::new(0.0, 0.0); m],
            report: CalibrateReport::default(),
            fold,
            units: vec![Vec::new(); m],
        }
    }

    /// Adds one packet's response `v` against the array's expected response.
    fn add(&mut self, v: &[Complex64], expected: &[Complex64], bw: Option<crate::csi::Bandwidth>) {
        let reference = v[0] * expected[0].conj();
        for (k, sum) in self.sums.iter_mut().enumerate() {
            let z = v[k] * expected[k].conj() * reference.conj();
            if z.norm() > 0.0 {
                let unit = z / z.norm();
                *sum += if self.fold { unit * unit } else { unit };
                if self.fold {
                    self.units[k].push(unit);
                }
            }
        }
        self.report.used += 1;
        if let Some(bw) = bw.filter(|b| !self.report.bandwidths.contains(b)) {
            self.report.bandwidths.push(bw);
            self.report.bandwidths.sort();
        }
    }

    fn finish(
        self,
        geometry: ArrayGeometry,
        center_freq_hz: f64,
    ) -> Result<(ChainCalibration, CalibrateReport), CalibrateError> {
        let report = self.report;
        if report.used == 0 {
            return Err(CalibrateError::NoPackets {
                skipped: report.skipped.len(),
                first: report
                    .skipped
                    .first()
                    .map(|s| s.1.clone())
                    .unwrap_or_else(|| "no packets given".into()),
            });
        }
        let n = report.used as f64;
        let k = if self.fold { 2.0 } else { 1.0 };
        // Folded, `arg/2` and `arg/2 + π` fit equally: take the one most packets are nearer.
        let offsets = self
            .sums
            .iter()
            .zip(&self.units)
            .map(|(s, units)| {
                let half = s.arg() / k;
                let near = units
                    .iter()
                    .filter(|u| (*u * Complex64::from_polar(1.0, -half)).re >= 0.0)
                    .count();
                if near * 2 >= units.len() {
                    half
                } else {
                    crate::csi::sanitize::wrap(half + std::f64::consts::PI)
                }
            })
            .collect();
        let calibration = ChainCalibration {
            phase_offsets_rad: offsets,
            source: String::new(),
            spread_rad: self
                .sums
                .iter()
                .map(|s| (-2.0 * (s.norm() / n).clamp(1e-12, 1.0).ln()).sqrt() / k)
                .collect(),
            packets: report.used,
            made_for: Some(CalibrationSetup {
                center_freq_hz,
                spacing_m: geometry.spacing_m,
                bandwidths: report.bandwidths.clone(),
            }),
        };
        Ok((calibration, report))
    }
}

/// The direct path's array response of one packet's CSI `csi` (row-major by antenna, on
/// subcarriers at `offsets_hz`; see the module docs), or why there is none.
fn direct_response(
    mut csi: Vec<Complex64>,
    offsets_hz: &[f64],
    music: &Music,
    m: usize,
) -> Result<Vec<Complex64>, String> {
    sanitize(&mut csi, m, offsets_hz).map_err(|e| e.to_string())?;
    let subspace = music.subspace(&csi).map_err(|e| e.to_string())?;
    let w_len = music.layout().subcarriers_per_window() as f64;
    // The Gram matrix of the signal subspace against the ToF `tof`'s phasors.
    let gram = |tof: f64| -> DMatrix<Complex64> {
        let mut g = vec![Complex64::new(0.0, 0.0); m * m];
        music.gram_from(&subspace.basis, &music.tof_phasors(tof), &mut g);
        DMatrix::from_row_slice(m, m, &g)
    };
    // A unit-norm v: ‖v ⊗ b‖² = W; the residual of the best v is 1 − λ_max / W. The scan and
    // the refinement need only λ_max (no eigenvectors), the direct path's vector is formed once.
    let residual_of = |lambda: f64| (1.0 - lambda / w_len).clamp(1e-12, 1.0);
    let residual_at = |tof: f64| -> f64 {
        let lambda = gram(tof)
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .max_by(f64::total_cmp)
            .unwrap_or(0.0);
        residual_of(lambda)
    };
    let top = |tof: f64| -> (f64, Vec<Complex64>) {
        let eig = gram(tof).symmetric_eigen();
        let (i, &lambda) = eig
            .eigenvalues
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        (
            residual_of(lambda),
            eig.eigenvectors.column(i).iter().copied().collect(),
        )
    };
    let grid = music.tof_grid();
    let residual: Vec<f64> = grid.iter().map(|&t| residual_at(t)).collect();
    let minima: Vec<usize> = (1..grid.len().saturating_sub(1))
        .filter(|&i| residual[i] < residual[i - 1] && residual[i] <= residual[i + 1])
        .collect();
    let strongest = minima
        .iter()
        .map(|&i| residual[i])
        .fold(f64::INFINITY, f64::min);
    let cfg = music.config();
    let floor = strongest * 10f64.powf(cfg.max_below_strongest_db / 10.0);
    let Some(&first) = minima
        .iter()
        .find(|&&i| residual[i] <= cfg.max_residual && residual[i] <= floor)
    else {
        return Err("no credible direct path".into());
    };
    // Golden-section refinement of τ between the neighbouring grid points.
    let (mut lo, mut hi) = (grid[first - 1], grid[first + 1]);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..30 {
        let (a, b) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
        if residual_at(a) < residual_at(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    Ok(top(0.5 * (lo + hi)).1)
}
