//! Per-packet AoA for any card: MUSIC over the packet's own subcarriers and receive chains
//! ([`crate::csi::packet::CsiPacket`]), with the steps of [`super::AoaEstimator`] that do not
//! depend on the Intel 5300 (chain calibration, ToF sanitization, smoothing, subspace, peaks).
//! The 5300's measured receiver response is not divided out: other cards' responses have not
//! been measured. One MUSIC is built per subcarrier set the packets bring and kept.
//!
//! At most `M_s − 1` paths are counted, `M_s` the antennas of a smoothing window. A window of
//! `W` subcarriers `Δf` apart separates times of flight only `1/(W·Δf)` apart (400 ns for 8
//! tones at 312.5 kHz), far more than a room's delay spread, so the paths of a packet are, to
//! MUSIC, at one time of flight, and only the window's antennas separate them: `M_s` paths there
//! span every steering vector of the window, and the spectrum is a ridge over all angles. Seen
//! on the real captures (`tests/it/packets_real.rs`): on an AX200 (2 antennas) a ridge of six
//! "paths" 30° wide where one path gives the raw CSI's angle to 1°; on a BCM4366c0 (3 cores) a
//! per-packet spread of 39.9° with 2 paths and 10.1° with 1, against the raw CSI's 16.9°.

use num_complex::Complex64;

use super::estimator::{AoaConfig, AoaError, check_calibration};
use super::music::{AoaWindow, Music, MusicError};
use super::peak::Peak;
use crate::csi::format::CaptureFormat;
use crate::csi::packet::CsiPacket;
use crate::csi::sanitize::sanitize;
use crate::rig::{ArrayGeometry, ChainCalibration};

/// Widest channel, MHz, whose packets are smoothed over the 20 MHz window size.
const NARROW_MHZ: u32 = 20;

/// Per-packet AoA for one array and channel, from [`CsiPacket`]s of any card.
#[derive(Clone, Debug)]
pub struct PacketAoa {
    config: AoaConfig,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    calibration: ChainCalibration,
    /// MUSIC per (subcarriers, spacing) seen.
    music: Vec<(Vec<i32>, u64, Music)>,
}

impl PacketAoa {
    /// An estimator for `geometry` on a channel centred at `center_freq_hz` (without a
    /// calibration the chains are assumed to add no phase).
    pub fn new(
        config: &AoaConfig,
        geometry: ArrayGeometry,
        center_freq_hz: f64,
        calibration: Option<ChainCalibration>,
    ) -> Result<Self, AoaError> {
        config
            .problems("aoa")
            .into_result()
            .map_err(MusicError::Config)?;
        geometry
            .validate(center_freq_hz)
            .map_err(MusicError::from)?;
        let calibration =
            calibration.unwrap_or_else(|| ChainCalibration::identity(geometry.num_antennas));
        check_calibration(&calibration, geometry, center_freq_hz)?;
        Ok(Self {
            config: config.clone(),
            geometry,
            center_freq_hz,
            calibration,
            music: Vec::new(),
        })
    }

    /// Replaces the chain offsets (checked as in [`Self::new`]).
    pub fn set_calibration(&mut self, calibration: ChainCalibration) -> Result<(), AoaError> {
        check_calibration(&calibration, self.geometry, self.center_freq_hz)?;
        self.calibration = calibration;
        Ok(())
    }

    /// The packet's CSI of the configured stream, calibrated and sanitized, row-major by
    /// antenna.
    pub fn prepare(&self, packet: &CsiPacket) -> Result<Vec<Complex64>, AoaError> {
        let n = self.geometry.num_antennas;
        if packet.num_rx() != n {
            return Err(AoaError::Chains {
                nrx: packet.num_rx(),
                antennas: n,
            });
        }
        let mut csi = packet.antenna_rows(self.config.tx).ok_or(AoaError::Tx {
            tx: self.config.tx,
            ntx: packet.num_tx,
        })?;
        self.calibration.apply(&mut csi, n)?;
        sanitize(&mut csi, n, &packet.offsets_hz())?;
        Ok(csi)
    }

    /// The MUSIC for the packet's subcarriers, built the first time they are seen.
    fn music_for(&mut self, packet: &CsiPacket) -> Result<&Music, AoaError> {
        let spacing = packet.spacing_hz.to_bits();
        let found = self
            .music
            .iter()
            .position(|(s, sp, _)| *sp == spacing && *s == packet.subcarriers);
        let index = match found {
            Some(i) => i,
            None => {
                let mut m = self.config.music.clone();
                m.paths.max_paths = m.paths.max_paths.min(m.antennas_per_window - 1).max(1);
                let window = if packet.bandwidth_mhz <= NARROW_MHZ {
                    m.subcarriers_per_window_ht20
                } else {
                    m.subcarriers_per_window_ht40
                };
                let music = Music::new(
                    &m,
                    self.geometry,
                    self.center_freq_hz,
                    &packet.offsets_hz(),
                    window,
                )?;
                self.music
                    .push((packet.subcarriers.clone(), spacing, music));
                self.music.len() - 1
            }
        };
        Ok(&self.music[index].2)
    }

    /// Every credible peak of a packet inside `window`, lowest ToF first.
    pub fn peaks(&mut self, packet: &CsiPacket, window: AoaWindow) -> Result<Vec<Peak>, AoaError> {
        let csi = self.prepare(packet)?;
        let music = self.music_for(packet)?;
        let subspace = music.subspace(&csi)?;
        Ok(music.peaks(&subspace, window))
    }

    /// [`Self::peaks`], and on a card whose second chain flips sign from packet to packet
    /// ([`chains_flip_sign`], two chains) also the peaks with that chain's sign turned: the
    /// packet cannot tell which sign it has, so both angles stand, as an array's aliases do, and
    /// the window around a prediction chooses. Lowest ToF first.
    pub fn peaks_either_sign(
        &mut self,
        packet: &CsiPacket,
        window: AoaWindow,
    ) -> Result<Vec<Peak>, AoaError> {
        let n = self.geometry.num_antennas;
        if !(chains_flip_sign(packet) && n == 2) {
            return self.peaks(packet, window);
        }
        let csi = self.prepare(packet)?;
        let mut turned = csi.clone();
        let row = turned.len() / n;
        for v in &mut turned[row..] {
            *v = -*v;
        }
        let music = self.music_for(packet)?;
        let mut peaks = music.peaks(&music.subspace(&csi)?, window);
        peaks.extend(music.peaks(&music.subspace(&turned)?, window));
        peaks.sort_by(|a, b| a.tof_s.total_cmp(&b.tof_s));
        Ok(peaks)
    }

    /// The other angles `packet` could equally have given for `aoa_rad`: the array's aliases
    /// when it is wider than λ/2, and on a card whose second chain flips sign from packet to
    /// packet ([`chains_flip_sign`], two chains) the angles whose phase step differs by π, with
    /// their aliases. Ascending.
    pub fn aliases_rad(&self, packet: &CsiPacket, aoa_rad: f64) -> Vec<f64> {
        let period = self.geometry.alias_period(self.center_freq_hz);
        let s = aoa_rad.sin();
        let mut sines: Vec<f64> = Vec::new();
        let flips = chains_flip_sign(packet) && self.geometry.num_antennas == 2;
        let step = if flips { period / 2.0 } else { period };
        if step.is_finite() && step > 0.0 {
            let k_max = (2.0 / step).ceil() as i64;
            sines.extend(
                (-k_max..=k_max)
                    .filter(|&k| k != 0)
                    .map(|k| s + k as f64 * step)
                    .filter(|v| v.abs() <= 1.0),
            );
        }
        let mut out: Vec<f64> = sines.into_iter().map(f64::asin).collect();
        out.sort_by(f64::total_cmp);
        out
    }

    /// The direct path of one packet by full-range MUSIC: its lowest-ToF credible peak.
    pub fn direct_path(&mut self, packet: &CsiPacket) -> Result<Option<Peak>, AoaError> {
        Ok(self.peaks(packet, AoaWindow::FULL)?.first().copied())
    }
}

/// Whether `packet`'s card flips the sign of its chains after the first from packet to packet:
/// the Intel AX200/AX210, whose FeitCSI and PicoScenes captures both show the phase between its
/// two chains jumping by π between packets (`../shared/data/feitcsi/README.md`; measured again in
/// `tests/it/packets_real.rs`).
pub fn chains_flip_sign(packet: &CsiPacket) -> bool {
    matches!(
        packet.format,
        CaptureFormat::FeitCsi | CaptureFormat::PicoScenes
    )
}
