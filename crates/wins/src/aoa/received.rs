//! Per-packet AoA of any [`Received`] packet ([`ReceivedAoa`]): the Intel 5300's records through
//! [`AoaEstimator`] (its subcarrier groups, its receiver response), every other card's packets
//! through [`PacketAoa`] on their own subcarriers, both signs of a flipping chain kept
//! ([`PacketAoa::peaks_either_sign`]). One calibration for both.

use super::estimator::{AoaConfig, AoaError, AoaEstimator};
use super::group::{GroupResult, spotfi_over};
use super::music::AoaWindow;
use super::packet::PacketAoa;
use super::paoa::{AoaPrediction, PaoaResult};
use super::peak::Peak;
use crate::csi::Received;
use crate::rig::{ArrayGeometry, ChainCalibration};

/// SpotFi and PAoA over packets of any card, for one array and channel.
#[derive(Clone, Debug)]
pub struct ReceivedAoa {
    intel5300: AoaEstimator,
    cards: PacketAoa,
}

impl ReceivedAoa {
    /// The AoA stage for `geometry` on a channel centred at `center_freq_hz` (without a
    /// calibration the chains are assumed to add no phase).
    pub fn new(
        config: &AoaConfig,
        geometry: ArrayGeometry,
        center_freq_hz: f64,
        calibration: Option<ChainCalibration>,
    ) -> Result<Self, AoaError> {
        let intel5300 = AoaEstimator::new(config, geometry, center_freq_hz, calibration)?;
        let cards = PacketAoa::new(
            config,
            geometry,
            center_freq_hz,
            Some(intel5300.calibration().clone()),
        )?;
        Ok(Self { intel5300, cards })
    }

    /// The calibration applied.
    pub fn calibration(&self) -> &ChainCalibration {
        self.intel5300.calibration()
    }

    /// Replaces the chain offsets ([`AoaEstimator::set_calibration`]).
    pub fn set_calibration(&mut self, calibration: ChainCalibration) -> Result<(), AoaError> {
        self.intel5300.set_calibration(calibration.clone())?;
        self.cards.set_calibration(calibration)
    }

    /// Every credible peak of a packet inside `window`, lowest ToF first.
    pub fn peaks(&mut self, packet: &Received, window: AoaWindow) -> Result<Vec<Peak>, AoaError> {
        match packet {
            Received::Intel5300(r) => self.intel5300.peaks(r, window),
            Received::Card(p) => self.cards.peaks_either_sign(p, window),
        }
    }

    /// SpotFi's direct path over `packets` ([`AoaEstimator::spotfi`]).
    pub fn spotfi<'a>(&mut self, packets: impl IntoIterator<Item = &'a Received>) -> GroupResult {
        let config = self.intel5300.config().spotfi.clone();
        spotfi_over(packets, &config, |p| self.peaks(p, AoaWindow::FULL))
    }

    /// PAoA of one packet given the prediction ([`AoaEstimator::paoa`]).
    pub fn paoa(
        &mut self,
        packet: &Received,
        prediction: &AoaPrediction,
    ) -> Result<PaoaResult, AoaError> {
        let half_width_deg = self.intel5300.config().paoa_half_width_deg;
        PaoaResult::search(prediction, half_width_deg, |w| self.peaks(packet, w))
    }
}
