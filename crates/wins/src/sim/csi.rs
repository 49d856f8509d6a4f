//! CSI as a card reports it: multipath channel through the shared steering vector, thermal and
//! implementation noise, the NIC's phase impairments, AGC and quantization. The Intel 5300 (its
//! 30 subcarrier groups, 8 bits, its measured receiver response) is the default; the Atheros
//! CSI Tool's card (56 or 114 tones, 10 bits), Nexmon on an RT-AC86U's BCM4366c0 (three of its
//! cores, 56 tones of 64 FFT bins, the chip's floating point) and an Intel AX210 with FeitCSI (two
//! chains, 16 bits, the second's sign flipping) are the other rigs it writes
//! ([`super::radio::SIM_CARDS`], their records in `sim/csi/cards.rs`), each with a flat response: no
//! other card's response has been measured.
//!
//! For path `p` (length `L_p`, delay `τ_p = L_p/c`, cone angle `θ_p` at the array, amplitude
//! `g_p·λ/(4πL_p)·√(P_tx·G_tx·G_rx)`), antenna `m` and subcarrier `k` at `f_k = f_c + Δf_k`:
//!
//! ```text
//! H[m,k] = Σ_p a_p · exp(−j2π f_k τ_p) · exp(+j2π f_k y_m sin θ_p / c)          (steering.rs)
//! CSI[m,k] = Q( s_agc · (H[m,k] + n[m,k]) · exp(j(φ_pkt + φ_m − 2π Δf_k τ_sto)) )
//! ```
//!
//! with `n ~ CN(0, N₀B + P_m/SNR_impl)`, a per-packet common phase `φ_pkt`, a fixed per-chain
//! offset `φ_m`, a per-packet sampling-time offset `τ_sto` (linear phase in `Δf_k` only), the AGC
//! gain `s_agc` set in whole dB from the strongest chain, and `Q` rounding to 8 bits with clipping.
//! Before the phase impairments the receiver's own response over the band multiplies signal and
//! noise alike, per chain and subcarrier (`R_m[k]`, measured on real captures: `response`).

use nalgebra::{UnitQuaternion, Vector3};
use num_complex::Complex64;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::radio::{RadioConfig, db_to_power, free_space_amplitude, power_to_db};
use super::room::Path;
use crate::aoa::steering::{sin_aoa, tof_phase_rad};
use crate::csi::NUM_SUBCARRIERS;
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{RSSI_TO_DBM_OFFSET, RateFlags};
use crate::csi::logged::Logged;
use crate::csi::packet::tables;
use crate::rig::ArrayGeometry;
use crate::rig::array::SPEED_OF_LIGHT_M_S;
use crate::time::Timestamp;

/// Receive chains the Intel 5300 has.
pub const MAX_ANTENNAS: usize = 3;
/// `rate_n_flags` bit of an HT (802.11n) rate; the simulator sends HT MCS 0.
const RATE_HT: u16 = 0x0100;
/// `rate_n_flags` bit of a 40 MHz channel.
const RATE_HT40: u16 = 0x0800;

/// What the simulator knows about one received packet (written to `truth/`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PacketTruth {
    /// Direct-path angle of arrival in the array frame, rad (the cone angle, steering.rs).
    pub aoa_rad: f64,
    /// Elevation of the AP above the array's `a_x a_y` plane, rad (what the cone angle mixes in).
    pub elevation_rad: f64,
    /// Whether the AP is in front of the array (`û · x̂_a > 0`); behind, AoA alone is ambiguous.
    pub in_front: bool,
    /// Direct-path time of flight, s.
    pub tof_s: f64,
    /// Distance from the array centre to the AP, m.
    pub range_m: f64,
    /// Whether the obstacle attenuates the direct path.
    pub direct_obstructed: bool,
    /// Per-subcarrier SNR averaged over the chains, dB (signal of all paths over thermal plus
    /// implementation noise).
    pub snr_db: f64,
    /// Direct-path power over the power of all reflections, dB (Rician K factor).
    pub k_factor_db: f64,
    /// Sampling-time offset of this packet, s.
    pub sto_s: f64,
    /// Common phase of this packet, rad.
    pub common_phase_rad: f64,
    /// CSI components clipped by the 8-bit quantizer.
    pub clipped: u32,
}

/// A reflected path whose power per subcarrier is below this fraction of the thermal noise
/// floor is left out of the channel (−20 dB: it would change the noise-like error by under 1 %
/// of the noise power). In a large room most high-order images are this weak, so the cost of a
/// packet stays bounded by the paths that matter. The direct path is always kept.
pub const NEGLIGIBLE_PATH_POWER_RATIO: f64 = 0.01;

/// Turns propagation paths into a card's records for one AP.
#[derive(Clone, Debug)]
pub struct CsiSynth {
    card: CaptureFormat,
    transmitter: [u8; 6],
    geometry: ArrayGeometry,
    freqs_hz: Vec<f64>,
    offsets_hz: Vec<f64>,
    chain_phase_rad: [f64; MAX_ANTENNAS],
    tx_amplitude: f64,
    wavelength_m: f64,
    noise_floor_mw: f64,
    noise_floor_dbm: f64,
    impl_snr: f64,
    sto_max_s: f64,
    response: Option<[[Complex64; NUM_SUBCARRIERS]; MAX_ANTENNAS]>,
    agc_target_rssi_db: f64,
    quantization_rms: f64,
    rate: RateFlags,
    nic_clock_at_imu_zero_us: u64,
}

impl CsiSynth {
    /// A synthesizer for an AP transmitting at `tx_power_dbm`; `chain_phase_rad` has one entry
    /// per antenna (at most 3).
    pub fn new(
        radio: &RadioConfig,
        geometry: ArrayGeometry,
        chain_phase_rad: &[f64],
        tx_power_dbm: f64,
    ) -> Self {
        // Other cards report every tone of their channel (HT20 56, HT40 114), in their tables.
        let tones = if radio.bandwidth == crate::csi::Bandwidth::Ht40 {
            114
        } else {
            56
        };
        let table = match radio.card {
            CaptureFormat::Atheros | CaptureFormat::Nexmon => tables::atheros(tones),
            CaptureFormat::FeitCsi => tables::intel_ax(tones),
            _ => None,
        };
        let offsets_hz: Vec<f64> = match table {
            Some(t) => t
                .iter()
                .map(|&k| f64::from(k) * tables::LEGACY_SPACING_HZ)
                .collect(),
            None => radio.bandwidth.subcarrier_offsets_hz().to_vec(),
        };
        let mut chain = [0.0; MAX_ANTENNAS];
        for (c, v) in chain.iter_mut().zip(chain_phase_rad) {
            *c = *v;
        }
        let rate = match radio.bandwidth {
            crate::csi::Bandwidth::Ht20 => RATE_HT,
            crate::csi::Bandwidth::Ht40 => RATE_HT | RATE_HT40,
        };
        Self {
            card: radio.card,
            transmitter: [0x02, 0, 0, 0, 0, 1],
            geometry,
            freqs_hz: offsets_hz
                .iter()
                .map(|o| radio.center_freq_hz + o)
                .collect(),
            offsets_hz,
            chain_phase_rad: chain,
            tx_amplitude: db_to_power(
                tx_power_dbm + radio.tx_antenna_gain_dbi + radio.rx_antenna_gain_dbi,
            )
            .sqrt(),
            wavelength_m: radio.wavelength_m(),
            noise_floor_mw: db_to_power(radio.noise_floor_dbm()),
            noise_floor_dbm: radio.noise_floor_dbm(),
            impl_snr: db_to_power(radio.implementation_snr_db),
            sto_max_s: radio.sto_max_s,
            response: None,
            agc_target_rssi_db: radio.agc_target_rssi_db,
            quantization_rms: radio.quantization_rms,
            rate: RateFlags(rate),
            nic_clock_at_imu_zero_us: radio.nic_clock_at_imu_zero_us,
        }
    }

    /// The same synthesizer with the receiver's response per chain and subcarrier (one card's,
    /// [`crate::sim::ReceiverResponse::factors`]; `None`: flat). It is the Intel 5300's: another
    /// card stays flat.
    pub fn with_response(
        mut self,
        response: Option<[[Complex64; NUM_SUBCARRIERS]; MAX_ANTENNAS]>,
    ) -> Self {
        self.response = response.filter(|_| self.card == CaptureFormat::Intel5300);
        self
    }

    /// The same synthesizer sending from `mac` (written in the frames of formats that keep it).
    pub fn with_transmitter(mut self, mac: [u8; 6]) -> Self {
        self.transmitter = mac;
        self
    }

    /// The noise-free channel `H[m][k]` (√mW) seen by an array whose orientation is
    /// `world_from_array`, for `paths` arriving at its centre; `paths[0]` is the direct path.
    /// Reflections weaker than [`NEGLIGIBLE_PATH_POWER_RATIO`] × the noise floor are skipped.
    pub fn channel(
        &self,
        paths: &[Path],
        world_from_array: &UnitQuaternion<f64>,
    ) -> Vec<Vec<Complex64>> {
        let m_count = self.geometry.num_antennas.min(MAX_ANTENNAS);
        let mut h = vec![vec![Complex64::new(0.0, 0.0); self.freqs_hz.len()]; m_count];
        let negligible_mw = NEGLIGIBLE_PATH_POWER_RATIO * self.noise_floor_mw;
        for (i, path) in paths.iter().enumerate() {
            let amplitude = self.tx_amplitude * path.gain * self.free_space(path.length_m);
            if i > 0 && amplitude * amplitude < negligible_mw {
                continue;
            }
            let tau_s = path.length_m / SPEED_OF_LIGHT_M_S;
            let s = sin_aoa(&world_from_array.inverse_transform_vector(&path.toward_source_in_w));
            for (k, &f) in self.freqs_hz.iter().enumerate() {
                let tof_phase = tof_phase_rad(f, tau_s);
                for (m, row) in h.iter_mut().enumerate().take(m_count) {
                    let phase = tof_phase + self.geometry.antenna_phase_rad(m, f, s);
                    row[k] += Complex64::from_polar(amplitude, phase);
                }
            }
        }
        h
    }

    fn free_space(&self, length_m: f64) -> f64 {
        free_space_amplitude(self.wavelength_m, length_m)
    }

    /// One received packet: the card's record and what the simulator knows about it.
    /// `paths[0]` must be the direct path; `p_array_in_w`/`world_from_array` place the array.
    #[allow(clippy::too_many_arguments)]
    pub fn packet(
        &self,
        paths: &[Path],
        p_array_in_w: &Vector3<f64>,
        p_ap_in_w: &Vector3<f64>,
        world_from_array: &UnitQuaternion<f64>,
        t: Timestamp,
        count: u16,
        rng: &mut ChaCha8Rng,
    ) -> (Logged, PacketTruth) {
        let m_count = self.geometry.num_antennas.clamp(1, MAX_ANTENNAS);
        let mut h = self.channel(paths, world_from_array);

        // Noise: thermal plus a floor proportional to each chain's signal power.
        let mut snr_sum = 0.0;
        for row in h.iter_mut().take(m_count) {
            let p_sig = mean_power(row);
            let var = self.noise_floor_mw + p_sig / self.impl_snr;
            snr_sum += p_sig / var;
            let sd = (var / 2.0).sqrt();
            for v in row.iter_mut() {
                let (re, im): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                *v += Complex64::new(re * sd, im * sd);
            }
        }

        // The receiver's response over the band (response.rs), on the signal and the noise.
        if let Some(response) = &self.response {
            for (row, factors) in h.iter_mut().zip(response).take(m_count) {
                for (v, f) in row.iter_mut().zip(factors) {
                    *v *= f;
                }
            }
        }

        // The NIC's phase impairments.
        let common_phase_rad = rng.random::<f64>() * std::f64::consts::TAU;
        let sto_s = rng.random::<f64>() * self.sto_max_s;
        for (m, row) in h.iter_mut().enumerate().take(m_count) {
            for (k, v) in row.iter_mut().enumerate() {
                let phase = common_phase_rad + self.chain_phase_rad[m]
                    - std::f64::consts::TAU * self.offsets_hz[k] * sto_s;
                *v *= Complex64::from_polar(1.0, phase);
            }
        }

        // AGC in whole dB from the strongest chain, RSSI per chain, quantization.
        let powers_dbm: Vec<f64> = h.iter().map(|r| power_to_db(mean_power(r))).collect();
        let powers_dbm = &powers_dbm[..m_count];
        let strongest = powers_dbm.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let agc = (self.agc_target_rssi_db - RSSI_TO_DBM_OFFSET - strongest)
            .round()
            .clamp(0.0, 127.0);
        let mut rssi = [0u8; 3];
        for (r, p) in rssi.iter_mut().zip(powers_dbm) {
            *r = (p + RSSI_TO_DBM_OFFSET + agc).round().clamp(1.0, 255.0) as u8;
        }
        let target_mw = db_to_power(self.agc_target_rssi_db - RSSI_TO_DBM_OFFSET - agc);
        let scale = self.quantization_rms / target_mw.sqrt();
        let nic_us = self.nic_clock_at_imu_zero_us as i64 + t.as_nanos().div_euclid(1000);
        let measured = Measured {
            h: &h,
            powers_dbm,
            scale,
            nic_us,
        };
        let (record, clipped) = match self.card {
            CaptureFormat::Atheros => self.atheros_record(&measured, count),
            CaptureFormat::Nexmon => self.nexmon_record(&measured, count),
            CaptureFormat::FeitCsi => {
                let flip = rng.random::<bool>();
                self.feitcsi_record(&measured, flip)
            }
            _ => {
                let (record, clipped) = self.intel5300_record(&h, rssi, agc, scale, nic_us, count);
                (Logged::Intel5300(record), clipped)
            }
        };

        let toward_ap_in_w = p_ap_in_w - p_array_in_w;
        let u_a = world_from_array.inverse_transform_vector(&toward_ap_in_w);
        let range_m = toward_ap_in_w.norm();
        let direct_power = paths
            .first()
            .map_or(0.0, |p| (p.gain * self.free_space(p.length_m)).powi(2));
        let reflected_power: f64 = paths
            .iter()
            .skip(1)
            .map(|p| (p.gain * self.free_space(p.length_m)).powi(2))
            .sum();
        let truth = PacketTruth {
            aoa_rad: sin_aoa(&u_a).asin(),
            elevation_rad: (u_a.z / range_m.max(1e-12)).clamp(-1.0, 1.0).asin(),
            in_front: u_a.x > 0.0,
            tof_s: range_m / SPEED_OF_LIGHT_M_S,
            range_m,
            direct_obstructed: paths.first().is_some_and(|p| p.obstructed),
            snr_db: power_to_db(snr_sum / m_count as f64),
            k_factor_db: power_to_db(direct_power / reflected_power.max(f64::MIN_POSITIVE)),
            sto_s,
            common_phase_rad,
            clipped,
        };
        (record, truth)
    }
}

fn mean_power(row: &[Complex64]) -> f64 {
    row.iter().map(|v| v.norm_sqr()).sum::<f64>() / row.len() as f64
}

mod cards;
mod response;
#[cfg(test)]
mod tests;

use cards::Measured;
