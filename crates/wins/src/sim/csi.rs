//! CSI as the Intel 5300 reports it: multipath channel through the shared steering vector, thermal
//! and implementation noise, the NIC's phase impairments, AGC and 8-bit quantization.
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
use num_complex::{Complex, Complex64};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::radio::{RadioConfig, db_to_power, free_space_amplitude, power_to_db};
use super::room::Path;
use crate::aoa::steering::{sin_aoa, tof_phase_rad};
use crate::csi::NUM_SUBCARRIERS;
use crate::csi::intel5300::{BfeeHeader, CsiRecord, MAX_ENTRIES, RSSI_TO_DBM_OFFSET, RateFlags};
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

/// Turns propagation paths into Intel 5300 records for one AP.
#[derive(Clone, Debug)]
pub struct CsiSynth {
    geometry: ArrayGeometry,
    freqs_hz: [f64; NUM_SUBCARRIERS],
    offsets_hz: [f64; NUM_SUBCARRIERS],
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
        let offsets_hz = radio.bandwidth.subcarrier_offsets_hz();
        let mut chain = [0.0; MAX_ANTENNAS];
        for (c, v) in chain.iter_mut().zip(chain_phase_rad) {
            *c = *v;
        }
        let rate = match radio.bandwidth {
            crate::csi::Bandwidth::Ht20 => RATE_HT,
            crate::csi::Bandwidth::Ht40 => RATE_HT | RATE_HT40,
        };
        Self {
            geometry,
            freqs_hz: offsets_hz.map(|o| radio.center_freq_hz + o),
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
    /// [`crate::sim::ReceiverResponse::factors`]; `None`: flat).
    pub fn with_response(
        mut self,
        response: Option<[[Complex64; NUM_SUBCARRIERS]; MAX_ANTENNAS]>,
    ) -> Self {
        self.response = response;
        self
    }

    /// The noise-free channel `H[m][k]` (√mW) seen by an array whose orientation is
    /// `world_from_array`, for `paths` arriving at its centre; `paths[0]` is the direct path.
    /// Reflections weaker than [`NEGLIGIBLE_PATH_POWER_RATIO`] × the noise floor are skipped.
    pub fn channel(
        &self,
        paths: &[Path],
        world_from_array: &UnitQuaternion<f64>,
    ) -> [[Complex64; NUM_SUBCARRIERS]; MAX_ANTENNAS] {
        let mut h = [[Complex64::new(0.0, 0.0); NUM_SUBCARRIERS]; MAX_ANTENNAS];
        let m_count = self.geometry.num_antennas.min(MAX_ANTENNAS);
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

    /// One received packet: the Intel 5300 record and what the simulator knows about it.
    /// `paths[0]` must be the direct path; `p_array_in_w`/`world_from_array` place the array.
    #[allow(clippy::too_many_arguments)]
    pub fn packet(
        &self,
        paths: &[Path],
        p_array_in_w: &Vector3<f64>,
        p_ap_in_w: &Vector3<f64>,
        world_from_array: &UnitQuaternion<f64>,
        t: Timestamp,
        bfee_count: u16,
        rng: &mut ChaCha8Rng,
    ) -> (CsiRecord, PacketTruth) {
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

        // AGC in whole dB from the strongest chain, RSSI per chain, 8-bit quantization.
        let powers_dbm = h.map(|r| power_to_db(mean_power(&r)));
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
        let mut clipped = 0u32;
        let mut csi = [Complex::<i8>::new(0, 0); MAX_ENTRIES];
        for (m, row) in h.iter().enumerate().take(m_count) {
            for (k, v) in row.iter().enumerate() {
                let (re, c1) = quantize(v.re * scale);
                let (im, c2) = quantize(v.im * scale);
                clipped += u32::from(c1) + u32::from(c2);
                csi[m * NUM_SUBCARRIERS + k] = Complex::new(re, im);
            }
        }

        let nic_us = self.nic_clock_at_imu_zero_us as i64 + t.as_nanos().div_euclid(1000);
        let header = BfeeHeader {
            timestamp_low: nic_us.rem_euclid(1 << 32) as u32,
            bfee_count,
            nrx: m_count as u8,
            ntx: 1,
            rssi,
            noise_dbm: self.noise_floor_dbm.round().clamp(-126.0, 0.0) as i8,
            agc: agc as u8,
            antenna_sel: identity_antenna_sel(m_count),
            rate: self.rate,
        };
        let timestamp = Timestamp::from_micros(nic_us);
        // 1–3 chains and one stream: always a valid shape, so no `CsiRecord::new` error to carry.
        let record = CsiRecord::from_parts(0, timestamp, header, csi);

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

/// `antenna_sel` mapping chain i to antenna i (2 bits per chain).
fn identity_antenna_sel(chains: usize) -> u8 {
    (0..chains).fold(0u8, |sel, i| sel | ((i as u8) << (2 * i)))
}

fn mean_power(row: &[Complex64; NUM_SUBCARRIERS]) -> f64 {
    row.iter().map(|v| v.norm_sqr()).sum::<f64>() / NUM_SUBCARRIERS as f64
}

/// Rounds to the nearest signed 8-bit value; `true` when it had to clip.
fn quantize(x: f64) -> (i8, bool) {
    let r = x.round();
    if r > f64::from(i8::MAX) {
        (i8::MAX, true)
    } else if r < f64::from(i8::MIN) {
        (i8::MIN, true)
    } else {
        (r as i8, false)
    }
}

mod response;
#[cfg(test)]
mod tests;
