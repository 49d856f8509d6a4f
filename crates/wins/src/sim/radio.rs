//! The radio side of a scenario: channel, link budget, the NIC's impairments and packet timing.

use serde::{Deserialize, Serialize};

use super::ConfigError;
use crate::csi::Bandwidth;
use crate::csi::format::CaptureFormat;
use crate::rig::array::{CHANNEL_64_HZ, SPEED_OF_LIGHT_M_S};

/// Thermal noise power spectral density at 290 K, dBm/Hz.
pub const THERMAL_NOISE_DBM_HZ: f64 = -173.977;

/// Radio parameters shared by every AP of a scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioConfig {
    /// The receiving card, by the format its tool writes: `intel5300` (default), `atheros` (the
    /// Atheros CSI Tool's 56 tones, or 114 at 40 MHz, 10 bits per part) or `nexmon` (an
    /// RT-AC86U's BCM4366c0, three cores, 56 tones of 64 FFT bins in the chip's floating point);
    /// or `feitcsi` (an Intel AX210 with FeitCSI: two chains, 56 tones, 16 bits, its second
    /// chain's sign flipping from packet to packet as the real card's does); the other cards with
    /// a flat receiver response.
    #[serde(skip_serializing_if = "is_intel5300")]
    pub card: CaptureFormat,
    /// Carrier frequency, Hz. Default 5.32 GHz (channel 64, the paper's).
    pub center_freq_hz: f64,
    /// Channel width: `ht20` or `ht40` (sets the 30 reported subcarrier indices). Default `ht20`
    /// (channel 64 as a 20 MHz channel; an HT40− channel on 60+64 is centred at 5.31 GHz).
    pub bandwidth: Bandwidth,
    /// Transmit power of every AP unless the AP overrides it, dBm. Default 15.
    pub tx_power_dbm: f64,
    /// Antenna gain at the AP and at each receive antenna, dBi. Default 2 each.
    pub tx_antenna_gain_dbi: f64,
    /// Receive antenna gain, dBi.
    pub rx_antenna_gain_dbi: f64,
    /// Receiver noise figure, dB. Default 7.
    pub noise_figure_db: f64,
    /// Ceiling on the per-subcarrier SNR from hardware impairments (phase noise, I/Q imbalance,
    /// channel-estimation error), dB. The 5300's CSI rarely looks cleaner than ~30 dB even next to
    /// the AP. Default 30.
    pub implementation_snr_db: f64,
    /// Per-packet sampling-time offset (packet detection delay) is uniform in
    /// [0, `sto_max_s`]; it adds a linear phase across subcarriers. Default 25.5 ns: the real
    /// static captures' offsets (the slope of each packet's phase over the subcarriers) have an
    /// interquartile range of 12.6–12.9 ns, which 25.5 ns gives (docs/VALIDATION.md, "Simulated
    /// CSI against real").
    pub sto_max_s: f64,
    /// The receiver's response over the band, per chain and subcarrier: `intel5300` (measured on
    /// real captures: a 10 dB roll-off to the band's edge and a ±35° bow in phase,
    /// [`ReceiverResponse`]) or `flat`. Default `intel5300`.
    pub receiver_response: ReceiverResponse,
    /// Fixed phase offset of each receive chain (A, B, C), degrees. Empty = drawn uniformly in
    /// [−180°, 180°) from the scenario seed (then written to `truth/`). Default empty.
    pub chain_phase_offsets_deg: Vec<f64>,
    /// The NIC restarted between its lab calibration and the flight, as an Intel 5300 does at
    /// every power-up: each chain's offset moves by a random multiple of π at 5 GHz (π/2 at
    /// 2.4 GHz, [`crate::aoa::restart_step_rad`]), drawn from the scenario seed, so the shipped
    /// `calibration.toml` (made before the restart) is off by those steps. Default false.
    pub nic_restart: bool,
    /// The dataset ships the NIC's lab calibration (`calibration.toml`, made before any
    /// restart); `false`: none, as for a rig that was never calibrated. Default true.
    pub lab_calibration: bool,
    /// The AGC aims the strongest chain's RSSI at this value, dB (real logs show 30–40).
    /// Default 35.
    pub agc_target_rssi_db: f64,
    /// RMS magnitude, in 8-bit quantization steps, of a chain whose power is at the AGC target.
    /// Real logs peak around ±50 on the strongest chain. Default 25.
    pub quantization_rms: f64,
    /// Packets per second from each AP unless the AP overrides it. Default 50.
    pub packet_rate_hz: f64,
    /// Standard deviation of the packet timing jitter around the nominal period, s (clipped to
    /// ±40% of the period so packets stay in order). Default 2 ms.
    pub timing_jitter_s: f64,
    /// Probability that a packet is lost (no CSI). Default 0.05.
    pub loss_probability: f64,
    /// Reading of the NIC's free-running microsecond clock when the IMU clock reads 0. Default
    /// 1 234 567 890 µs; set it near 2³² to make `timestamp_low` wrap during the flight.
    pub nic_clock_at_imu_zero_us: u64,
}

/// The cards the simulator writes, by their capture format.
pub const SIM_CARDS: [CaptureFormat; 4] = [
    CaptureFormat::Intel5300,
    CaptureFormat::Atheros,
    CaptureFormat::Nexmon,
    CaptureFormat::FeitCsi,
];

/// The receive chains of `card` when it has fewer than the simulator's three (the AX210's 2).
pub fn card_chains(card: CaptureFormat) -> Option<usize> {
    (card == CaptureFormat::FeitCsi).then_some(2)
}

fn is_intel5300(card: &CaptureFormat) -> bool {
    *card == CaptureFormat::Intel5300
}

impl Default for RadioConfig {
    fn default() -> Self {
        Self {
            card: CaptureFormat::Intel5300,
            center_freq_hz: CHANNEL_64_HZ,
            bandwidth: Bandwidth::Ht20,
            tx_power_dbm: 15.0,
            tx_antenna_gain_dbi: 2.0,
            rx_antenna_gain_dbi: 2.0,
            noise_figure_db: 7.0,
            implementation_snr_db: 30.0,
            sto_max_s: 25.5e-9,
            receiver_response: ReceiverResponse::Intel5300,
            chain_phase_offsets_deg: Vec::new(),
            nic_restart: false,
            lab_calibration: true,
            agc_target_rssi_db: 35.0,
            quantization_rms: 25.0,
            packet_rate_hz: 50.0,
            timing_jitter_s: 0.002,
            loss_probability: 0.05,
            nic_clock_at_imu_zero_us: 1_234_567_890,
        }
    }
}

impl RadioConfig {
    /// Checks every field.
    pub fn validate(&self, field: &str, num_antennas: usize) -> Result<(), ConfigError> {
        let bad = |name: &str, why: String| Err(ConfigError::new(format!("{field}.{name}"), why));
        let in_range = |v: f64, lo: f64, hi: f64| v.is_finite() && v >= lo && v <= hi;
        if let Some(n) = card_chains(self.card).filter(|&n| num_antennas > n) {
            return bad(
                "card",
                format!(
                    "{} has {n} receive chains, the array {num_antennas} antennas",
                    self.card
                ),
            );
        }
        if !SIM_CARDS.contains(&self.card) {
            let names: Vec<&str> = SIM_CARDS.iter().map(|c| c.name()).collect();
            return bad(
                "card",
                format!(
                    "the simulator writes the logs of these cards only: {} (not {})",
                    names.join(", "),
                    self.card
                ),
            );
        }
        if !in_range(self.center_freq_hz, 1e9, 100e9) {
            return bad(
                "center_freq_hz",
                format!("{} is not in [1, 100] GHz", self.center_freq_hz),
            );
        }
        for (name, v) in [
            ("tx_power_dbm", self.tx_power_dbm),
            ("tx_antenna_gain_dbi", self.tx_antenna_gain_dbi),
            ("rx_antenna_gain_dbi", self.rx_antenna_gain_dbi),
            ("noise_figure_db", self.noise_figure_db),
            ("implementation_snr_db", self.implementation_snr_db),
            ("agc_target_rssi_db", self.agc_target_rssi_db),
        ] {
            if !in_range(v, -100.0, 100.0) {
                return bad(name, format!("{v} is not in [-100, 100]"));
            }
        }
        if !in_range(self.sto_max_s, 0.0, 1e-6) {
            return bad(
                "sto_max_s",
                format!("{} is not in [0, 1 µs]", self.sto_max_s),
            );
        }
        if !self.chain_phase_offsets_deg.is_empty()
            && self.chain_phase_offsets_deg.len() != num_antennas
        {
            return bad(
                "chain_phase_offsets_deg",
                format!(
                    "{} offsets for {num_antennas} antennas (give one per chain, or none to draw them)",
                    self.chain_phase_offsets_deg.len()
                ),
            );
        }
        if self.chain_phase_offsets_deg.iter().any(|v| !v.is_finite()) {
            return bad("chain_phase_offsets_deg", "not all finite".into());
        }
        if !in_range(self.quantization_rms, 0.5, 90.0) {
            return bad(
                "quantization_rms",
                format!("{} is not in [0.5, 90]", self.quantization_rms),
            );
        }
        if !in_range(self.packet_rate_hz, 0.1, 2000.0) {
            return bad(
                "packet_rate_hz",
                format!("{} is not in [0.1, 2000] Hz", self.packet_rate_hz),
            );
        }
        if !in_range(self.timing_jitter_s, 0.0, 1.0) {
            return bad(
                "timing_jitter_s",
                format!("{} is not in [0, 1] s", self.timing_jitter_s),
            );
        }
        if !in_range(self.loss_probability, 0.0, 0.99) {
            return bad(
                "loss_probability",
                format!("{} is not in [0, 0.99]", self.loss_probability),
            );
        }
        if self.nic_clock_at_imu_zero_us > u64::from(u32::MAX) {
            return bad(
                "nic_clock_at_imu_zero_us",
                format!(
                    "{} does not fit the 32-bit clock",
                    self.nic_clock_at_imu_zero_us
                ),
            );
        }
        Ok(())
    }

    /// Carrier wavelength, m.
    pub fn wavelength_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_S / self.center_freq_hz
    }

    /// Noise bandwidth, Hz (20 or 40 MHz).
    pub fn noise_bandwidth_hz(&self) -> f64 {
        f64::from(self.bandwidth.mhz()) * 1e6
    }

    /// Thermal noise power at the receiver input over the channel, dBm:
    /// −174 dBm/Hz + 10·log10(B) + NF.
    pub fn noise_floor_dbm(&self) -> f64 {
        THERMAL_NOISE_DBM_HZ + 10.0 * self.noise_bandwidth_hz().log10() + self.noise_figure_db
    }

    /// Free-space amplitude factor λ/(4πL) of a path of length `length_m` at the carrier.
    pub fn free_space_amplitude(&self, length_m: f64) -> f64 {
        free_space_amplitude(self.wavelength_m(), length_m)
    }
}

/// Free-space (Friis) amplitude factor λ/(4πL) of a path of length `length_m` (L ≥ 1 mm).
pub fn free_space_amplitude(wavelength_m: f64, length_m: f64) -> f64 {
    wavelength_m / (4.0 * std::f64::consts::PI * length_m.max(1e-3))
}

/// Decibels to linear power.
pub fn db_to_power(db: f64) -> f64 {
    10f64.powf(db / 10.0)
}

/// Linear power to decibels.
pub fn power_to_db(p: f64) -> f64 {
    10.0 * p.log10()
}

/// The receiver response a simulated NIC applies (TOML `[radio] receiver_response`); its factors:
/// `sim::csi`'s `ReceiverResponse::factors`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReceiverResponse {
    /// The Intel 5300's, measured on real captures, each card off it by its own smooth
    /// deviation drawn from the scenario's seed. The default.
    #[default]
    Intel5300,
    /// None: every subcarrier and chain alike (an ideal receiver).
    Flat,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_budget_numbers() {
        let r = RadioConfig::default();
        // 20 MHz, NF 7 dB: −174 + 73 + 7 ≈ −94 dBm.
        assert!(
            (r.noise_floor_dbm() - (-93.97)).abs() < 0.01,
            "{}",
            r.noise_floor_dbm()
        );
        // FSPL at 5.32 GHz and 5 m: 20·log10(4π·5 m/λ) = 60.95 dB.
        let fspl_db = -20.0 * r.free_space_amplitude(5.0).log10();
        assert!((fspl_db - 60.946).abs() < 0.001, "{fspl_db}");
        assert!(r.validate("radio", 3).is_ok());
        let bad = RadioConfig {
            chain_phase_offsets_deg: vec![0.0, 1.0],
            ..RadioConfig::default()
        };
        assert_eq!(
            bad.validate("radio", 3).unwrap_err().field,
            "radio.chain_phase_offsets_deg"
        );
    }
}
