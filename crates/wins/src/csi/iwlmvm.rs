//! The Intel iwlwifi (iwlmvm) CSI header: the 272 bytes in front of an AX200/AX210's CSI, as
//! FeitCSI writes them before each record and PicoScenes keeps them in its `MVMExtra` segment.
//! Little-endian: the CSI's size @0, the FTM clock @8, receive chains @46, transmit streams @47,
//! subcarriers @52, the two chains' RSSI @60 and @64, the transmitter @68, a microsecond clock @88
//! (as CSIKit reads it), the rate flags @92. FeitCSI documents the layout ("CSI format").

use num_complex::Complex;

use crate::csi::MacAddress;

/// Bytes of the header.
pub const IWL_HEADER_LEN: usize = 272;
/// Most receive chains or transmit streams a header may claim.
const MAX_CHAINS: u8 = 4;
/// Most subcarriers a header may claim (a 320 MHz EHT channel has 3 984 tones).
const MAX_SUBCARRIERS: u32 = 4096;

/// The frame format of bits 8–10 of the rate flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RateFormat {
    /// 802.11b.
    Cck,
    /// 802.11a/g.
    LegacyOfdm,
    /// 802.11n.
    Ht,
    /// 802.11ac.
    Vht,
    /// 802.11ax.
    He,
    /// 802.11be.
    Eht,
    /// Another value.
    Other(u8),
}

impl RateFormat {
    /// Its name as CSIKit prints it (`"HT"`, `"HE"`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::Cck => "CCK",
            Self::LegacyOfdm => "LEGACY_OFDM",
            Self::Ht => "HT",
            Self::Vht => "VHT",
            Self::He => "HE",
            Self::Eht => "EHT",
            Self::Other(_) => "OTHER",
        }
    }
}

/// The header's fields.
#[derive(Clone, Debug, PartialEq)]
pub struct IntelCsiHeader {
    /// Bytes of CSI the header announces.
    pub csi_size: u32,
    /// The FTM clock (3.125 ns ticks, wrapping at 2³²).
    pub ftm_clock: u32,
    /// Receive chains.
    pub num_rx: u8,
    /// Transmit streams.
    pub num_tx: u8,
    /// Subcarriers.
    pub num_subcarriers: u32,
    /// RSSI of chains 1 and 2 (positive numbers, as the header holds them).
    pub rssi: [u32; 2],
    /// The transmitter.
    pub source_mac: MacAddress,
    /// The microsecond clock CSIKit reads @88.
    pub mu_clock: u32,
    /// The raw rate flags.
    pub rate_flags: u32,
}

impl IntelCsiHeader {
    /// The header at the start of `h`, or why there is none: too short, or a shape no card has.
    pub fn parse(h: &[u8]) -> Result<Self, String> {
        let h = h
            .get(..IWL_HEADER_LEN)
            .ok_or_else(|| format!("a header cut by the end of the file ({} bytes)", h.len()))?;
        let u32_at = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
        let (num_rx, num_tx, num_subcarriers) = (h[46], h[47], u32_at(52));
        if !(1..=MAX_CHAINS).contains(&num_rx)
            || !(1..=MAX_CHAINS).contains(&num_tx)
            || !(1..=MAX_SUBCARRIERS).contains(&num_subcarriers)
        {
            return Err(format!(
                "not an Intel CSI header: {num_rx} receive chains, {num_tx} streams, \
                 {num_subcarriers} subcarriers"
            ));
        }
        Ok(Self {
            csi_size: u32_at(0),
            ftm_clock: u32_at(8),
            num_rx,
            num_tx,
            num_subcarriers,
            rssi: [u32_at(60), u32_at(64)],
            source_mac: [h[68], h[69], h[70], h[71], h[72], h[73]],
            mu_clock: u32_at(88),
            rate_flags: u32_at(92),
        })
    }

    /// The header's 272 bytes: its fields where [`Self::parse`] reads them, every other byte
    /// zero.
    pub fn encode(&self) -> [u8; IWL_HEADER_LEN] {
        let mut h = [0u8; IWL_HEADER_LEN];
        let mut put = |at: usize, v: u32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
        put(0, self.csi_size);
        put(8, self.ftm_clock);
        put(52, self.num_subcarriers);
        put(60, self.rssi[0]);
        put(64, self.rssi[1]);
        put(88, self.mu_clock);
        put(92, self.rate_flags);
        h[46] = self.num_rx;
        h[47] = self.num_tx;
        h[68..74].copy_from_slice(&self.source_mac);
        h
    }

    /// The microsecond clock @88, ns (32 bits: it wraps every 71.6 minutes).
    pub fn mu_clock_ns(&self) -> i64 {
        i64::from(self.mu_clock) * 1000
    }

    /// Complex values its shape holds (chains × streams × subcarriers).
    pub fn values(&self) -> usize {
        usize::from(self.num_rx) * usize::from(self.num_tx) * self.num_subcarriers as usize
    }

    /// MCS (bits 0–3).
    pub fn mcs(&self) -> u8 {
        (self.rate_flags & 0xf) as u8
    }

    /// The frame format (bits 8–10).
    pub fn format(&self) -> RateFormat {
        match (self.rate_flags >> 8) & 7 {
            0 => RateFormat::Cck,
            1 => RateFormat::LegacyOfdm,
            2 => RateFormat::Ht,
            3 => RateFormat::Vht,
            4 => RateFormat::He,
            5 => RateFormat::Eht,
            other => RateFormat::Other(other as u8),
        }
    }

    /// Channel width, MHz (`20 << n`, n from bits 11–13).
    pub fn width_mhz(&self) -> u32 {
        20 << ((self.rate_flags >> 11) & 7)
    }

    /// Whether antenna A (bit 14) and B (bit 15) received it.
    pub fn antennas(&self) -> (bool, bool) {
        (
            self.rate_flags & (1 << 14) != 0,
            self.rate_flags & (1 << 15) != 0,
        )
    }

    /// LDPC coding (bit 16).
    pub fn ldpc(&self) -> bool {
        self.rate_flags & (1 << 16) != 0
    }

    /// Spatial streams: 2 with bit 17, else 1.
    pub fn spatial_streams(&self) -> u8 {
        if self.rate_flags & (1 << 17) != 0 {
            2
        } else {
            1
        }
    }

    /// Beamformed (bit 19).
    pub fn beamforming(&self) -> bool {
        self.rate_flags & (1 << 19) != 0
    }

    /// The value of chain `rx`, stream `tx`, subcarrier `sc` in `csi` laid out as the header
    /// says (chain, stream, subcarrier fastest).
    pub fn csi_at(
        &self,
        csi: &[Complex<i16>],
        rx: usize,
        tx: usize,
        sc: usize,
    ) -> Option<Complex<i16>> {
        let (ntx, nsc) = (usize::from(self.num_tx), self.num_subcarriers as usize);
        (tx < ntx && sc < nsc)
            .then(|| csi.get((rx * ntx + tx) * nsc + sc).copied())
            .flatten()
    }
}

/// The CSI values in `data`, 4 bytes each: `int16` real then imaginary, little-endian.
pub fn csi_values(data: &[u8]) -> Vec<Complex<i16>> {
    data.chunks_exact(4)
        .map(|v| {
            Complex::new(
                i16::from_le_bytes([v[0], v[1]]),
                i16::from_le_bytes([v[2], v[3]]),
            )
        })
        .collect()
}
