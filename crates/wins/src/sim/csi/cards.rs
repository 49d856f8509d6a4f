//! What each simulated card logs for a packet ([`Logged`]): the records of the Intel 5300,
//! the Atheros CSI Tool, Nexmon on an RT-AC86U and FeitCSI on an Intel AX210, built from the
//! impaired channel [`CsiSynth::packet`] computes, and the cards the simulator writes
//! ([`crate::sim::radio::SIM_CARDS`]).

use num_complex::{Complex, Complex64};

use super::super::radio::{db_to_power, power_to_db};
use super::CsiSynth;
use crate::csi::NUM_SUBCARRIERS;
use crate::csi::atheros::AtherosRecord;
use crate::csi::feitcsi::FeitRecord;
use crate::csi::intel5300::{BfeeHeader, CsiRecord, MAX_ENTRIES};
use crate::csi::iwlmvm::IntelCsiHeader;
use crate::csi::logged::Logged;
use crate::csi::nexmon::write::encode_word;
use crate::csi::nexmon::{MAGIC_NEW, NexmonPacket};
use crate::csi::packet::tables;
use crate::time::Timestamp;

/// One packet's channel as the card measured it, what every card's record is made from.
#[derive(Clone, Copy, Debug)]
pub(super) struct Measured<'a> {
    /// The channel per chain and subcarrier, with the noise and the receiver's impairments.
    pub h: &'a [Vec<Complex64>],
    /// Each chain's power, dBm.
    pub powers_dbm: &'a [f64],
    /// From the channel to the 5300's 8-bit steps, the AGC applied (other cards scale it on).
    pub scale: f64,
    /// The card's microsecond clock.
    pub nic_us: i64,
}

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

/// The AX210's values hold the CSI at this many powers of two above the 5300's 8-bit scale (its
/// reports are 16-bit integers).
const FEITCSI_SCALE_POW2: i32 = 5;
/// The iwlmvm rate flags of an HT frame received on antennas A and B.
const IWL_RATE_HT_AB: u32 = (2 << 8) | (1 << 14) | (1 << 15);
/// The iwlmvm rate flags' code of a 40 MHz channel (bits 11–13).
const IWL_RATE_40MHZ: u32 = 1 << 11;

/// The receiving card's own address in the simulated Atheros frames (locally administered).
const RECEIVER_MAC: [u8; 6] = [0x02, 0x00, 0x00, 0x00, 0x01, 0x00];

impl CsiSynth {
    /// The Intel 5300's record: 8 bits per part, its header.
    pub(super) fn intel5300_record(
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
    pub(super) fn atheros_record(&self, m: &Measured<'_>, sequence: u16) -> (Logged, u32) {
        let Measured {
            h,
            powers_dbm,
            scale,
            nic_us,
        } = *m;
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
        (Logged::Atheros(record), clipped)
    }

    /// Nexmon's packets of one frame: one per core, each the newer header and one word per FFT
    /// bin in the chip's floating point (the DC and guard bins zero), the core's RSSI in dBm.
    /// The floating point does not clip.
    pub(super) fn nexmon_record(&self, m: &Measured<'_>, sequence: u16) -> (Logged, u32) {
        let Measured {
            h,
            powers_dbm,
            scale,
            nic_us,
        } = *m;
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
        (Logged::Nexmon(packets), 0)
    }

    /// The Intel AX210's FeitCSI record: its two chains over 56 tones (HT20; 114 at 40 MHz) as
    /// 16-bit integers, chain then tone, the chains' RSSI as the positive numbers the header
    /// holds; the second chain's sign flipped when `flip` (the card does so from packet to
    /// packet: `../shared/data/feitcsi/README.md`, "Known quirks").
    pub(super) fn feitcsi_record(&self, m: &Measured<'_>, flip: bool) -> (Logged, u32) {
        let Measured {
            h,
            powers_dbm,
            scale,
            nic_us,
        } = *m;
        let scale = scale * 2f64.powi(FEITCSI_SCALE_POW2);
        let tones = self.freqs_hz.len();
        let mut clipped = 0u32;
        let mut csi = Vec::with_capacity(tones * h.len());
        for (m, row) in h.iter().enumerate() {
            let sign = if flip && m == 1 { -scale } else { scale };
            for v in row {
                let (re, c1) = quantize_bits(v.re * sign, 16);
                let (im, c2) = quantize_bits(v.im * sign, 16);
                clipped += u32::from(c1) + u32::from(c2);
                csi.push(Complex::new(re, im));
            }
        }
        let mut rssi = [0u32; 2];
        for (r, p) in rssi.iter_mut().zip(powers_dbm) {
            *r = (-p).round().clamp(0.0, 255.0) as u32;
        }
        let width = if tones > 56 { IWL_RATE_40MHZ } else { 0 };
        let record = FeitRecord {
            offset: 0,
            header: IntelCsiHeader {
                csi_size: (csi.len() * 4) as u32,
                // The FTM clock's 3.125 ns ticks, and the microsecond clock, both 32 bits.
                ftm_clock: (nic_us.wrapping_mul(320)).rem_euclid(1 << 32) as u32,
                num_rx: h.len() as u8,
                num_tx: 1,
                num_subcarriers: tones as u32,
                rssi,
                source_mac: self.transmitter,
                mu_clock: nic_us.rem_euclid(1 << 32) as u32,
                rate_flags: IWL_RATE_HT_AB | width,
            },
            csi,
        };
        (Logged::FeitCsi(record), clipped)
    }
}

/// `antenna_sel` mapping chain i to antenna i (2 bits per chain).
pub(super) fn identity_antenna_sel(chains: usize) -> u8 {
    (0..chains).fold(0u8, |sel, i| sel | ((i as u8) << (2 * i)))
}

/// Rounds to the nearest signed `bits`-bit value; `true` when it had to clip.
pub(super) fn quantize_bits(x: f64, bits: u32) -> (i16, bool) {
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
pub(super) fn quantize(x: f64) -> (i8, bool) {
    let r = x.round();
    if r > f64::from(i8::MAX) {
        (i8::MAX, true)
    } else if r < f64::from(i8::MIN) {
        (i8::MIN, true)
    } else {
        (r as i8, false)
    }
}
