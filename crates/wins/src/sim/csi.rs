//! CSI as a card reports it: multipath channel through the shared steering vector, thermal and
//! implementation noise, the NIC's phase impairments, AGC and quantization. The Intel 5300 (its
//! 30 subcarrier groups, 8 bits, its measured receiver response) is the default; the Atheros
//! CSI Tool's card (56 or 114 tones, 10 bits) and Nexmon on an RT-AC86U's BCM4366c0 (three of its
//! cores, 56 tones of 64 FFT bins, the chip's floating point) are the other rigs it writes
//! ([`SIM_CARDS`]), each with a flat response: no other card's response has been measured.
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
use crate::csi::atheros::AtherosRecord;
use crate::csi::format::CaptureFormat;
use crate::csi::intel5300::{BfeeHeader, CsiRecord, MAX_ENTRIES, RSSI_TO_DBM_OFFSET, RateFlags};
use crate::csi::nexmon::frames::frames;
use crate::csi::nexmon::write::encode_word;
use crate::csi::nexmon::{MAGIC_NEW, NexmonPacket};
use crate::csi::packet::{CsiPacket, from_atheros, from_nexmon, tables};
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

/// One received packet as the simulated card logs it.
// Not boxed: most packets are Intel 5300 records, and a box would cost each an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum SimRecord {
    /// An Intel 5300 record.
    Intel5300(CsiRecord),
    /// An Atheros CSI Tool record.
    Atheros(AtherosRecord),
    /// Nexmon's packets of one frame, one per core.
    Nexmon(Vec<NexmonPacket>),
}

impl SimRecord {
    /// The Intel 5300 record, if it is one.
    pub fn intel5300(&self) -> Option<&CsiRecord> {
        match self {
            Self::Intel5300(r) => Some(r),
            Self::Atheros(_) | Self::Nexmon(_) => None,
        }
    }

    /// Another card's record as the loader reads it (`None` for a 5300 record, or a record that
    /// does not convert, which the simulator never writes).
    pub fn card_packet(&self) -> Option<CsiPacket> {
        match self {
            Self::Intel5300(_) => None,
            Self::Atheros(r) => from_atheros(r).ok(),
            Self::Nexmon(p) => frames(p).first().and_then(|f| from_nexmon(f).ok()),
        }
    }

    /// The count the truth pairs it by: the 5300's `bfee_count`, the other cards' 802.11
    /// sequence number.
    pub fn count(&self) -> u16 {
        match self {
            Self::Intel5300(r) => r.header.bfee_count,
            Self::Atheros(r) => r
                .payload
                .get(22..24)
                .map_or(0, |b| u16::from_le_bytes([b[0], b[1]]) >> 4),
            Self::Nexmon(p) => p.first().map_or(0, NexmonPacket::seq_num),
        }
    }
}

/// The cards the simulator writes, by their capture format.
pub const SIM_CARDS: [CaptureFormat; 3] = [
    CaptureFormat::Intel5300,
    CaptureFormat::Atheros,
    CaptureFormat::Nexmon,
];

/// Bits the Atheros CSI Tool gives each part: its quantizer's RMS is the 5300's times 2^(10−8).
const ATHEROS_EXTRA_BITS: i32 = 2;
/// The Atheros rate code of HT MCS 0.
const ATHEROS_RATE_MCS0: u8 = 0x80;
/// Nexmon's chip id of the BCM4366c0 (the RT-AC86U's).
const NEXMON_CHIP_BCM4366C0: u16 = 0x006a;
/// A Broadcom chanspec's bits of a 5 GHz, 20 MHz channel (its number in the low byte).
const CHANSPEC_5G_20MHZ: u16 = 0xd000;
/// Nexmon's words hold the CSI at this many powers of two above the 5300's 8-bit scale, well
/// inside the range of their floating point ([`crate::csi::nexmon::write::encode_word`]).
const NEXMON_SCALE_POW2: i32 = 24;

/// The receiving card's own address in the simulated Atheros frames (locally administered).
const RECEIVER_MAC: [u8; 6] = [0x02, 0x00, 0x00, 0x00, 0x01, 0x00];

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
        let offsets_hz: Vec<f64> = match radio.card {
            CaptureFormat::Atheros | CaptureFormat::Nexmon => {
                let tones = if radio.bandwidth == crate::csi::Bandwidth::Ht40 {
                    114
                } else {
                    56
                };
                tables::atheros(tones)
                    .unwrap_or_default()
                    .iter()
                    .map(|&k| f64::from(k) * tables::LEGACY_SPACING_HZ)
                    .collect()
            }
            _ => radio.bandwidth.subcarrier_offsets_hz().to_vec(),
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
    ) -> (SimRecord, PacketTruth) {
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
        let (record, clipped) = match self.card {
            CaptureFormat::Atheros => self.atheros_record(&h, powers_dbm, scale, nic_us, count),
            CaptureFormat::Nexmon => self.nexmon_record(&h, powers_dbm, scale, nic_us, count),
            _ => {
                let (record, clipped) = self.intel5300_record(&h, rssi, agc, scale, nic_us, count);
                (SimRecord::Intel5300(record), clipped)
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

    /// The Intel 5300's record: 8 bits per part, its header.
    fn intel5300_record(
        &self,
        h: &[Vec<Complex64>],
        rssi: [u8; 3],
        agc: f64,
        scale: f64,
        nic_us: i64,
        bfee_count: u16,
    ) -> (CsiRecord, u32) {
        let m_count = h.len();
        let mut clipped = 0u32;
        let mut csi = [Complex::<i8>::new(0, 0); MAX_ENTRIES];
        for (m, row) in h.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                let (re, c1) = quantize(v.re * scale);
                let (im, c2) = quantize(v.im * scale);
                clipped += u32::from(c1) + u32::from(c2);
                csi[m * NUM_SUBCARRIERS + k] = Complex::new(re, im);
            }
        }
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
        (CsiRecord::from_parts(0, timestamp, header, csi), clipped)
    }

    /// The Atheros CSI Tool's record: 10 bits per part, per tone then receive chain, the
    /// chains' RSSI in dB above the noise floor, an 802.11 data frame header carrying the
    /// transmitter and `sequence` (modulo 4096).
    fn atheros_record(
        &self,
        h: &[Vec<Complex64>],
        powers_dbm: &[f64],
        scale: f64,
        nic_us: i64,
        sequence: u16,
    ) -> (SimRecord, u32) {
        let scale = scale * f64::from(1 << ATHEROS_EXTRA_BITS);
        let tones = self.freqs_hz.len();
        let mut clipped = 0u32;
        let mut csi = Vec::with_capacity(tones * h.len());
        for k in 0..tones {
            for row in h {
                let (re, c1) = quantize_bits(row[k].re * scale, 10);
                let (im, c2) = quantize_bits(row[k].im * scale, 10);
                clipped += u32::from(c1) + u32::from(c2);
                csi.push(Complex::new(re, im));
            }
        }
        let above_floor =
            |p_dbm: f64| (p_dbm - self.noise_floor_dbm).round().clamp(0.0, 127.0) as u8;
        let mut rssi_chains = [0u8; 3];
        for (r, p) in rssi_chains.iter_mut().zip(powers_dbm) {
            *r = above_floor(*p);
        }
        let total_mw: f64 = powers_dbm.iter().map(|p| db_to_power(*p)).sum();
        let mut payload = vec![0x08, 0x00, 0x00, 0x00];
        payload.extend(RECEIVER_MAC);
        payload.extend(self.transmitter);
        payload.extend(self.transmitter);
        payload.extend(((sequence & 0x0fff) << 4).to_le_bytes());
        let record = AtherosRecord {
            offset: 0,
            timestamp_us: nic_us.max(0) as u64,
            channel_mhz: (self.freqs_hz.iter().sum::<f64>() / tones as f64 / 1e6).round() as u16,
            err_info: 0,
            noise_floor: 0,
            rate: ATHEROS_RATE_MCS0,
            bandwidth: u8::from(tones > 56),
            num_tones: tones as u8,
            nr: h.len() as u8,
            nc: 1,
            rssi: above_floor(power_to_db(total_mw)),
            rssi_chains,
            csi_len: 0,
            csi,
            payload,
        };
        (SimRecord::Atheros(record), clipped)
    }

    /// Nexmon's packets of one frame: one per core, each the newer header and one word per FFT
    /// bin in the chip's floating point (the DC and guard bins zero), the core's RSSI in dBm.
    /// The floating point does not clip.
    fn nexmon_record(
        &self,
        h: &[Vec<Complex64>],
        powers_dbm: &[f64],
        scale: f64,
        nic_us: i64,
        sequence: u16,
    ) -> (SimRecord, u32) {
        let scale = scale * 2f64.powi(NEXMON_SCALE_POW2);
        let tones = self.freqs_hz.len();
        let bins = if tones > 56 { 128 } else { 64 };
        let mut subcarriers: Vec<(i32, usize)> = (0..bins)
            .filter_map(|b| tables::nexmon_bin(b, bins).map(|k| (k, b)))
            .collect();
        subcarriers.sort_unstable();
        let carrier_mhz = self.freqs_hz.iter().sum::<f64>() / tones as f64 / 1e6;
        let channel = ((carrier_mhz - 5000.0) / 5.0).round().clamp(0.0, 255.0) as u16;
        let nic_us = nic_us.max(0);
        let packets = h
            .iter()
            .zip(powers_dbm)
            .enumerate()
            .map(|(core, (row, p_dbm))| {
                let mut words = vec![0u32; bins];
                for (tone, &(_, bin)) in subcarriers.iter().enumerate().take(tones) {
                    words[bin] = encode_word(row[tone] * scale);
                }
                NexmonPacket {
                    index: 0,
                    offset: 0,
                    ts_sec: (nic_us / 1_000_000) as u32,
                    ts_frac: (nic_us % 1_000_000) as u32,
                    time_ns: nic_us * 1000,
                    caplen: 0,
                    wirelen: 0,
                    magic: u32::from(MAGIC_NEW),
                    rssi_dbm: Some(p_dbm.round().clamp(-128.0, 0.0) as i8),
                    frame_control: Some(0x08),
                    transmitter: self.transmitter,
                    seq: (sequence & 0x0fff) << 4,
                    csiconf: (core as u16) << 8,
                    chanspec: CHANSPEC_5G_20MHZ | channel,
                    chip: NEXMON_CHIP_BCM4366C0,
                    words,
                }
            })
            .collect();
        (SimRecord::Nexmon(packets), 0)
    }
}

/// `antenna_sel` mapping chain i to antenna i (2 bits per chain).
fn identity_antenna_sel(chains: usize) -> u8 {
    (0..chains).fold(0u8, |sel, i| sel | ((i as u8) << (2 * i)))
}

fn mean_power(row: &[Complex64]) -> f64 {
    row.iter().map(|v| v.norm_sqr()).sum::<f64>() / row.len() as f64
}

/// Rounds to the nearest signed `bits`-bit value; `true` when it had to clip.
fn quantize_bits(x: f64, bits: u32) -> (i16, bool) {
    let max = f64::from((1i32 << (bits - 1)) - 1);
    let r = x.round();
    if r > max {
        (max as i16, true)
    } else if r < -max - 1.0 {
        ((-max - 1.0) as i16, true)
    } else {
        (r as i16, false)
    }
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
