//! One packet from record to peaks: select a transmit stream, divide out the receiver's response
//! over the band ([`crate::csi::intel5300::receiver_response`]), remove the chain offsets
//! ([`ChainCalibration`]), sanitize the ToF ([`crate::csi::sanitize`]), then MUSIC with the
//! layout of the record's bandwidth.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::music::{AoaWindow, Music, MusicConfig, MusicError};
use super::peak::Peak;
use super::spotfi::SpotfiConfig;
use super::subspace::Subspace;
use crate::check::{Problems, join};
use crate::csi::intel5300::{CsiRecord, Perm, receiver_response};
use crate::csi::sanitize::{SanitizeError, sanitize};
use crate::csi::{Bandwidth, NUM_SUBCARRIERS};
use crate::rig::ArrayGeometry;
use crate::rig::{CalibrationError, ChainCalibration};

/// Settings of the AoA stage (the `[aoa]` table of a configuration).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AoaConfig {
    /// MUSIC.
    pub music: MusicConfig,
    /// PAoA searches the predicted AoA ± this, degrees (paper: 20°).
    pub paoa_half_width_deg: f64,
    /// SpotFi's direct-path clustering.
    pub spotfi: SpotfiConfig,
    /// Transmit stream whose CSI is used (0-based).
    pub tx: usize,
    /// Divide each chain's CSI by the Intel 5300's measured response over the band
    /// ([`crate::csi::intel5300::receiver_response`]) before anything else: its bow in phase
    /// bends every path's phase over the subcarriers, which the smoothing takes for paths.
    /// Default false: on two of the eight real lgtm captures it makes the per-packet angle jump
    /// between peaks (docs/VALIDATION.md, "Simulated CSI against real").
    pub remove_receiver_response: bool,
}

impl AoaConfig {
    /// Every setting of the stage in its range, under `prefix` (`music`, `spotfi` below it).
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = self.music.problems(&join(prefix, "music"));
        p.extend(self.spotfi.problems(&join(prefix, "spotfi")));
        let w = self.paoa_half_width_deg;
        p.require(
            w.is_finite() && w > 0.0 && w <= 90.0,
            prefix,
            "paoa_half_width_deg",
            format!("{w} is not in (0, 90]"),
        );
        p.require(
            self.tx <= 2,
            prefix,
            "tx",
            format!("{} is not a stream 0–2", self.tx),
        );
        p
    }
}

impl Default for AoaConfig {
    fn default() -> Self {
        Self {
            music: MusicConfig::default(),
            paoa_half_width_deg: 20.0,
            spotfi: SpotfiConfig::default(),
            tx: 0,
            remove_receiver_response: false,
        }
    }
}

/// Why a packet yields no AoA (every case is counted by the callers, never dropped silently).
#[derive(Debug, thiserror::Error)]
pub enum AoaError {
    /// The record has a different number of receive chains than the array has antennas.
    #[error("record has {nrx} receive chains, the array has {antennas} antennas")]
    Chains {
        /// Chains in the record.
        nrx: usize,
        /// Antennas of the configured array.
        antennas: usize,
    },
    /// The antenna permutation is not valid, so the chains' antennas are unknown.
    #[error("antenna selection {0:?} is not a permutation: chain order unknown")]
    Permutation([u8; 3]),
    /// The configured transmit stream is not in the record.
    #[error("transmit stream {tx} not in a record with {ntx}")]
    Tx {
        /// Stream asked for.
        tx: usize,
        /// Streams in the record.
        ntx: usize,
    },
    /// Sanitization failed.
    #[error("sanitize: {0}")]
    Sanitize(#[from] SanitizeError),
    /// MUSIC failed (zero CSI, bad configuration).
    #[error(transparent)]
    Music(#[from] MusicError),
    /// The calibration does not fit the array.
    #[error(transparent)]
    Calibration(#[from] CalibrationError),
}

/// Per-packet AoA estimation for one array and channel.
#[derive(Clone, Debug)]
pub struct AoaEstimator {
    config: AoaConfig,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
    calibration: ChainCalibration,
    ht20: Music,
    ht40: Music,
}

impl AoaEstimator {
    /// An estimator for `geometry` on a channel centred at `center_freq_hz`. Without a calibration
    /// the chains are assumed to add no phase (fine for the simulator's `ideal` cases only).
    pub fn new(
        config: &AoaConfig,
        geometry: ArrayGeometry,
        center_freq_hz: f64,
        calibration: Option<ChainCalibration>,
    ) -> Result<Self, AoaError> {
        let calibration =
            calibration.unwrap_or_else(|| ChainCalibration::identity(geometry.num_antennas));
        check_calibration(&calibration, geometry, center_freq_hz)?;
        config
            .problems("aoa")
            .into_result()
            .map_err(MusicError::Config)?;
        let music = |bw: Bandwidth, w| {
            Music::new(
                &config.music,
                geometry,
                center_freq_hz,
                &bw.subcarrier_offsets_hz(),
                w,
            )
        };
        Ok(Self {
            ht20: music(Bandwidth::Ht20, config.music.subcarriers_per_window_ht20)?,
            ht40: music(Bandwidth::Ht40, config.music.subcarriers_per_window_ht40)?,
            config: config.clone(),
            geometry,
            center_freq_hz,
            calibration,
        })
    }

    /// The settings.
    pub fn config(&self) -> &AoaConfig {
        &self.config
    }

    /// The calibration applied.
    pub fn calibration(&self) -> &ChainCalibration {
        &self.calibration
    }

    /// Replaces the chain offsets (e.g. after measuring their curvature in flight,
    /// [`super::ChainCurvature`]); the checks of [`AoaEstimator::new`] still apply.
    pub fn set_calibration(&mut self, calibration: ChainCalibration) -> Result<(), AoaError> {
        check_calibration(&calibration, self.geometry, self.center_freq_hz)?;
        self.calibration = calibration;
        Ok(())
    }

    /// The array.
    pub fn geometry(&self) -> ArrayGeometry {
        self.geometry
    }

    /// The channel's centre frequency, Hz.
    pub fn center_freq_hz(&self) -> f64 {
        self.center_freq_hz
    }

    /// The other angles with the same phases as `aoa_rad` on this array (empty up to λ/2).
    pub fn aliases_rad(&self, aoa_rad: f64) -> Vec<f64> {
        self.geometry.aliases_rad(aoa_rad, self.center_freq_hz)
    }

    /// The array's steering ambiguity at this carrier, if it is wider than λ/2.
    pub fn ambiguity(&self) -> Option<crate::rig::Ambiguity> {
        self.geometry.ambiguity(self.center_freq_hz)
    }

    /// MUSIC for a bandwidth.
    pub fn music(&self, bandwidth: Bandwidth) -> &Music {
        match bandwidth {
            Bandwidth::Ht20 => &self.ht20,
            Bandwidth::Ht40 => &self.ht40,
        }
    }

    /// The record's CSI of the configured stream, calibrated and sanitized, row-major
    /// (antenna `m`'s subcarrier `k` at `m·30 + k`).
    pub fn prepare(&self, record: &CsiRecord) -> Result<Vec<Complex64>, AoaError> {
        let mut csi = self.received_csi(record)?;
        self.calibration
            .check_bandwidth(record.header.rate.bandwidth())?;
        self.calibration
            .apply(&mut csi, self.geometry.num_antennas)?;
        sanitize(
            &mut csi,
            self.geometry.num_antennas,
            &record.header.rate.bandwidth().subcarrier_offsets_hz(),
        )?;
        Ok(csi)
    }

    /// The record's CSI of the configured stream as the antennas received it: the raw CSI with
    /// the receiver's response divided out ([`AoaConfig::remove_receiver_response`]), before the
    /// chain offsets and the timing offset are removed.
    pub fn received_csi(&self, record: &CsiRecord) -> Result<Vec<Complex64>, AoaError> {
        received_csi(
            record,
            self.config.tx,
            self.geometry.num_antennas,
            self.config.remove_receiver_response,
        )
    }

    /// The signal subspace of a record, with the MUSIC that fits its bandwidth.
    pub fn subspace(&self, record: &CsiRecord) -> Result<(&Music, Subspace), AoaError> {
        let csi = self.prepare(record)?;
        let music = self.music(record.header.rate.bandwidth());
        Ok((music, music.subspace(&csi)?))
    }

    /// Every credible peak of a record inside `window`, lowest ToF first.
    pub fn peaks(&self, record: &CsiRecord, window: AoaWindow) -> Result<Vec<Peak>, AoaError> {
        let (music, subspace) = self.subspace(record)?;
        Ok(music.peaks(&subspace, window))
    }

    /// The direct path of one packet by full-range MUSIC: its lowest-ToF credible peak, or `None`
    /// when no peak is credible.
    pub fn direct_path(&self, record: &CsiRecord) -> Result<Option<Peak>, AoaError> {
        Ok(self.peaks(record, AoaWindow::FULL)?.first().copied())
    }
}

/// [`raw_csi`] with, when `remove_response`, each chain divided by the Intel 5300's measured
/// response over the band ([`receiver_response`]; a fourth antenna and beyond, which no 5300
/// has, are left as they are).
pub fn received_csi(
    record: &CsiRecord,
    tx: usize,
    num_antennas: usize,
    remove_response: bool,
) -> Result<Vec<Complex64>, AoaError> {
    let mut csi = raw_csi(record, tx, num_antennas)?;
    if remove_response {
        for (row, factors) in csi
            .chunks_exact_mut(NUM_SUBCARRIERS)
            .zip(receiver_response())
        {
            for (v, f) in row.iter_mut().zip(factors) {
                *v /= f;
            }
        }
    }
    Ok(csi)
}

/// A calibration fits when it has one offset per antenna and was made for this carrier and
/// spacing (or does not say what for).
pub(crate) fn check_calibration(
    calibration: &ChainCalibration,
    geometry: ArrayGeometry,
    center_freq_hz: f64,
) -> Result<(), AoaError> {
    if calibration.phase_offsets_rad.len() != geometry.num_antennas {
        return Err(CalibrationError::Mismatch {
            given: calibration.phase_offsets_rad.len(),
            antennas: geometry.num_antennas,
        }
        .into());
    }
    calibration.check_setup(center_freq_hz, geometry.spacing_m)?;
    Ok(())
}

/// The CSI of transmit stream `tx` as complex doubles, row-major over `num_antennas` antennas.
/// The raw integers are used: MUSIC does not need the absolute scale, and a record without RSSI
/// still has a usable phase.
pub fn raw_csi(
    record: &CsiRecord,
    tx: usize,
    num_antennas: usize,
) -> Result<Vec<Complex64>, AoaError> {
    let (nrx, ntx) = (
        usize::from(record.header.nrx),
        usize::from(record.header.ntx),
    );
    if nrx != num_antennas {
        return Err(AoaError::Chains {
            nrx,
            antennas: num_antennas,
        });
    }
    if let Perm::Invalid(p) = record.perm {
        return Err(AoaError::Permutation(p));
    }
    if tx >= ntx {
        return Err(AoaError::Tx { tx, ntx });
    }
    let start = tx * nrx * NUM_SUBCARRIERS;
    Ok(record.csi()[start..start + nrx * NUM_SUBCARRIERS]
        .iter()
        .map(|c| Complex64::new(f64::from(c.re), f64::from(c.im)))
        .collect())
}
