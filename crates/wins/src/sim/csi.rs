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
            agc_target_rssi_db: radio.agc_target_rssi_db,
            quantization_rms: radio.quantization_rms,
            rate: RateFlags(rate),
            nic_clock_at_imu_zero_us: radio.nic_clock_at_imu_zero_us,
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csi::Bandwidth;
    use crate::rig::array::CHANNEL_64_HZ;
    use crate::sim::rng;
    use std::f64::consts::TAU;

    fn wrap(x: f64) -> f64 {
        (x + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI
    }

    fn single_path(theta_deg: f64, length_m: f64) -> Path {
        let t = theta_deg.to_radians();
        Path {
            length_m,
            toward_source_in_w: Vector3::new(t.cos(), t.sin(), 0.0),
            gain: 1.0,
            order: 0,
            obstructed: false,
        }
    }

    #[test]
    fn single_path_phases_follow_the_steering_vector_and_the_time_of_flight() {
        for bandwidth in [Bandwidth::Ht20, Bandwidth::Ht40] {
            let radio = RadioConfig {
                bandwidth,
                ..RadioConfig::default()
            };
            let g = ArrayGeometry::default();
            let synth = CsiSynth::new(&radio, g, &[0.0; 3], 15.0);
            let offsets = bandwidth.subcarrier_offsets_hz();
            for (theta_deg, length_m) in [(0.0, 3.0), (25.0, 5.0), (-60.0, 7.3), (80.0, 2.0)] {
                let h = synth.channel(
                    &[single_path(theta_deg, length_m)],
                    &UnitQuaternion::identity(),
                );
                let sin_t = f64::sin(f64::to_radians(theta_deg));
                let tau = length_m / SPEED_OF_LIGHT_M_S;
                let expected_amp = db_to_power(19.0).sqrt() * radio.free_space_amplitude(length_m);
                for k in 0..NUM_SUBCARRIERS {
                    let f = CHANNEL_64_HZ + offsets[k];
                    for m in 1..3 {
                        // Inter-antenna phase 2π·d·sin θ/λ at this subcarrier's frequency.
                        let d = (h[m][k] * h[m - 1][k].conj()).arg();
                        let want = TAU * g.spacing_m * sin_t * f / SPEED_OF_LIGHT_M_S;
                        assert!((d - want).abs() < 1e-9, "{theta_deg}: {d} vs {want}");
                    }
                    // Subcarrier phase slope is the ToF: φ_k − φ_0 = −2π(Δf_k − Δf_0)τ.
                    let d = (h[1][k] * h[1][0].conj()).arg();
                    let want = wrap(-TAU * (offsets[k] - offsets[0]) * tau);
                    assert!(wrap(d - want).abs() < 1e-6, "{d} vs {want}");
                    assert!((h[1][k].norm() - expected_amp).abs() < 1e-12 * expected_amp.max(1.0));
                }
            }
        }
    }

    #[test]
    fn reflections_below_the_noise_floor_are_skipped_and_the_direct_path_never() {
        let radio = RadioConfig::default();
        let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &[0.0; 3], 15.0);
        let direct = single_path(10.0, 5.0);
        let unit_power_mw = {
            let h = synth.channel(std::slice::from_ref(&direct), &UnitQuaternion::identity());
            h[0][0].norm_sqr()
        };
        let floor_mw = db_to_power(radio.noise_floor_dbm());
        // A reflection with power 10 dB below the limit, and one 10 dB above it.
        let with_gain = |power_mw: f64| Path {
            gain: (power_mw / unit_power_mw).sqrt(),
            ..single_path(-40.0, 5.0)
        };
        let weak = with_gain(0.1 * NEGLIGIBLE_PATH_POWER_RATIO * floor_mw);
        let strong = with_gain(10.0 * NEGLIGIBLE_PATH_POWER_RATIO * floor_mw);
        let q = UnitQuaternion::identity();
        let alone = synth.channel(std::slice::from_ref(&direct), &q);
        assert_eq!(synth.channel(&[direct, weak], &q), alone);
        assert_ne!(synth.channel(&[direct, strong], &q), alone);
        // A direct path as weak as the skipped reflection is still synthesized.
        let faint = synth.channel(std::slice::from_ref(&weak), &q);
        assert!(faint[0][0].norm_sqr() > 0.0);
    }

    #[test]
    fn packet_carries_exactly_the_impairments_its_truth_reports() {
        let radio = RadioConfig::default();
        let offsets_rad = [0.3, -2.0, 1.1];
        let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &offsets_rad, 15.0);
        let paths = [single_path(20.0, 4.0), {
            let mut p = single_path(-50.0, 9.0);
            p.gain = 0.3;
            p.order = 1;
            p
        }];
        let q = UnitQuaternion::identity();
        let h = synth.channel(&paths, &q);
        let ap = Vector3::new(
            4.0 * 20f64.to_radians().cos(),
            4.0 * 20f64.to_radians().sin(),
            0.0,
        );
        let mut r = rng::stream(5, "test");
        let freq = radio.bandwidth.subcarrier_offsets_hz();
        for n in 0..50 {
            let (rec, truth) = synth.packet(
                &paths,
                &Vector3::zeros(),
                &ap,
                &q,
                Timestamp(n * 20_000_000),
                n as u16,
                &mut r,
            );
            assert!((truth.aoa_rad.to_degrees() - 20.0).abs() < 1e-9);
            assert!((truth.range_m - 4.0).abs() < 1e-12 && truth.in_front);
            assert_eq!(rec.header.nrx, 3);
            assert_eq!(rec.header.bfee_count, n as u16);
            // Undo the reported impairments: what is left is a real positive gain plus noise.
            let mut residual_phase = Vec::new();
            for m in 0..3 {
                for k in 0..NUM_SUBCARRIERS {
                    let c = rec.csi_at(0, m, k).unwrap();
                    let c = Complex64::new(f64::from(c.re), f64::from(c.im));
                    let applied =
                        truth.common_phase_rad + offsets_rad[m] - TAU * freq[k] * truth.sto_s;
                    let z = c * (h[m][k] * Complex64::from_polar(1.0, applied)).conj();
                    residual_phase.push(z.arg());
                }
            }
            let rms = (residual_phase.iter().map(|p| p * p).sum::<f64>() / 90.0).sqrt();
            // 30 dB implementation SNR and 8-bit quantization: a few degrees of phase noise.
            assert!(rms < 0.15, "packet {n}: residual phase rms {rms}");
            // The RSSI fields give back the received power (get_total_rss.m), within rounding.
            let p_true: f64 = (0..3).map(|m| mean_power(&h[m])).sum();
            assert!(
                (rec.total_rss_dbm() - power_to_db(p_true)).abs() < 1.0,
                "{}",
                rec.total_rss_dbm()
            );
            assert!((truth.snr_db - 29.99).abs() < 0.1, "{}", truth.snr_db);
        }
    }

    #[test]
    fn snr_falls_with_distance_once_thermal_noise_matters() {
        let radio = RadioConfig::default();
        let synth = CsiSynth::new(&radio, ArrayGeometry::default(), &[0.0; 3], -10.0);
        let q = UnitQuaternion::identity();
        let mut r = rng::stream(6, "test");
        let snr = |l: f64, r: &mut ChaCha8Rng| {
            let ap = Vector3::new(l, 0.0, 0.0);
            synth
                .packet(
                    &[single_path(0.0, l)],
                    &Vector3::zeros(),
                    &ap,
                    &q,
                    Timestamp(0),
                    0,
                    r,
                )
                .1
                .snr_db
        };
        let (near, far) = (snr(2.0, &mut r), snr(8.0, &mut r));
        // −10 dBm + 4 dBi: −59 dBm at 2 m (thermal SNR 35 dB, 28.8 dB after the 30 dB cap);
        // −71 dBm at 8 m (thermal SNR 23 dB, 22.2 dB).
        assert!(
            (near - 28.8).abs() < 0.5 && (far - 22.2).abs() < 0.5,
            "{near} {far}"
        );
    }

    #[test]
    fn antenna_sel_is_the_identity() {
        assert_eq!(identity_antenna_sel(3), 0b10_01_00);
        assert_eq!(identity_antenna_sel(2), 0b01_00);
        assert_eq!(quantize(200.0), (127, true));
        assert_eq!(quantize(-128.4), (-128, false));
        assert_eq!(quantize(-3.5), (-4, false));
    }
}
