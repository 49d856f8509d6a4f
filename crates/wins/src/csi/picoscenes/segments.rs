//! The bodies of the PicoScenes segments wins reads, by version: `RxSBasic` v3, `MVMExtra` v1
//! and `CSI` v4, laid out as the vendor's parsing core (wifisensing/RXS-Parsing-Core,
//! `RxSBasicSegment.cxx`, `MVMExtraSegment.cxx`, `CSISegment.cxx`) writes them, little-endian.
//! Any other version is refused by name, since a field read at the wrong place parses silently
//! wrong.

use num_complex::Complex;

use crate::csi::iwlmvm::{IWL_HEADER_LEN, IntelCsiHeader, csi_values};

/// The segment versions this reader knows, by segment name.
pub const KNOWN_VERSIONS: [(&str, u16); 3] = [("RxSBasic", 3), ("MVMExtra", 1), ("CSI", 4)];

/// Little-endian field reader over a segment's body that says where the body ended too soon.
struct Fields<'a> {
    body: &'a [u8],
    at: usize,
    segment: &'static str,
}

impl<'a> Fields<'a> {
    fn new(body: &'a [u8], segment: &'static str) -> Self {
        Self {
            body,
            at: 0,
            segment,
        }
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let bytes = self
            .body
            .get(self.at..self.at + N)
            .and_then(|b| <[u8; N]>::try_from(b).ok())
            .ok_or_else(|| {
                format!(
                    "a {} segment of {} bytes, too short for its fields",
                    self.segment,
                    self.body.len()
                )
            })?;
        self.at += N;
        Ok(bytes)
    }

    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take::<1>()?[0])
    }

    fn i8(&mut self) -> Result<i8, String> {
        Ok(i8::from_le_bytes(self.take()?))
    }

    fn u16(&mut self) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take()?))
    }

    fn i16(&mut self) -> Result<i16, String> {
        Ok(i16::from_le_bytes(self.take()?))
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take()?))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take()?))
    }

    /// The bytes not read yet.
    fn rest(&self) -> &'a [u8] {
        &self.body[self.at.min(self.body.len())..]
    }
}

/// The receiver's basic report (`RxSBasic` v3).
#[derive(Clone, Debug, PartialEq)]
pub struct RxsBasic {
    /// The card (0x2000: Intel AX200).
    pub device_type: u16,
    /// The card's timestamp (0 in some frames).
    pub tstamp: u64,
    /// Channel centre, MHz.
    pub center_freq_mhz: i16,
    /// Control channel, MHz.
    pub control_freq_mhz: i16,
    /// Channel width, MHz.
    pub cbw_mhz: u16,
    /// 0: non-HT, 1: HT, 2: VHT, 3: HE-SU, …
    pub packet_format: u8,
    /// The frame's width, MHz.
    pub pkt_cbw_mhz: u16,
    /// Guard interval, ns.
    pub guard_interval_ns: u16,
    /// MCS.
    pub mcs: u8,
    /// Space-time streams.
    pub num_sts: u8,
    /// Extension spatial streams.
    pub num_ess: u8,
    /// Receive chains.
    pub num_rx: u8,
    /// Users (MU frames).
    pub num_user: u8,
    /// This user's index.
    pub user_index: u8,
    /// Noise floor, dBm (−128: none).
    pub noise_floor: i8,
    /// RSSI, dBm.
    pub rssi: i8,
    /// Per chain RSSI, dBm (−128: none).
    pub rssi_chains: [i8; 3],
}

impl RxsBasic {
    /// The body of an `RxSBasic` v3 segment.
    pub fn parse_v3(body: &[u8]) -> Result<Self, String> {
        let mut f = Fields::new(body, "RxSBasic");
        Ok(Self {
            device_type: f.u16()?,
            tstamp: f.u64()?,
            center_freq_mhz: f.i16()?,
            control_freq_mhz: f.i16()?,
            cbw_mhz: f.u16()?,
            packet_format: f.u8()?,
            pkt_cbw_mhz: f.u16()?,
            guard_interval_ns: f.u16()?,
            mcs: f.u8()?,
            num_sts: f.u8()?,
            num_ess: f.u8()?,
            num_rx: f.u8()?,
            num_user: f.u8()?,
            user_index: f.u8()?,
            noise_floor: f.i8()?,
            rssi: f.i8()?,
            rssi_chains: [f.i8()?, f.i8()?, f.i8()?],
        })
    }
}

/// The Intel CSI header of an `MVMExtra` v1 segment: a `u16` length (272), then the header.
pub fn parse_mvm_extra_v1(body: &[u8]) -> Result<IntelCsiHeader, String> {
    let mut f = Fields::new(body, "MVMExtra");
    let len = usize::from(f.u16()?);
    if len != IWL_HEADER_LEN {
        return Err(format!(
            "an MVMExtra segment whose Intel header is {len} bytes, not {IWL_HEADER_LEN}"
        ));
    }
    IntelCsiHeader::parse(f.rest())
}

/// A `CSI` segment (v4): its header and values.
#[derive(Clone, Debug, PartialEq)]
pub struct PicoCsi {
    /// The card (0x2000: Intel AX200).
    pub device_type: u16,
    /// The card's firmware version.
    pub firmware_version: u8,
    /// As in [`RxsBasic::packet_format`].
    pub packet_format: i8,
    /// Channel width, MHz.
    pub cbw_mhz: u16,
    /// Carrier frequency, Hz.
    pub carrier_freq_hz: u64,
    /// Sampling rate, Hz.
    pub sampling_rate_hz: u64,
    /// Subcarrier spacing, Hz.
    pub subcarrier_bandwidth_hz: u32,
    /// Tones per chain and stream.
    pub num_tone: u16,
    /// Space-time streams.
    pub num_sts: u8,
    /// Receive chains.
    pub num_rx: u8,
    /// Extension spatial streams.
    pub num_ess: u8,
    /// CSI matrices (1).
    pub num_csi: u16,
    /// Antenna selection bits.
    pub ant_sel: u8,
    /// Offset of the first tone's index from the format's table (0 here).
    pub subcarrier_index_offset: i16,
    /// The values, receive chain, stream, tone (fastest), each read real then imaginary as
    /// CSIKit and FeitCSI read them (the vendor's parser reads imaginary first).
    pub values: Vec<Complex<i16>>,
}

impl PicoCsi {
    /// The body of a `CSI` v4 segment.
    pub fn parse_v4(body: &[u8]) -> Result<Self, String> {
        let mut f = Fields::new(body, "CSI");
        let mut csi = Self {
            device_type: f.u16()?,
            firmware_version: f.u8()?,
            packet_format: f.i8()?,
            cbw_mhz: f.u16()?,
            carrier_freq_hz: f.u64()?,
            sampling_rate_hz: f.u64()?,
            subcarrier_bandwidth_hz: f.u32()?,
            num_tone: f.u16()?,
            num_sts: f.u8()?,
            num_rx: f.u8()?,
            num_ess: f.u8()?,
            num_csi: f.u16()?,
            ant_sel: f.u8()?,
            subcarrier_index_offset: f.i16()?,
            values: Vec::new(),
        };
        let buffer = f.u32()? as usize;
        let values = usize::from(csi.num_rx) * usize::from(csi.num_sts) * usize::from(csi.num_tone);
        let data = f.rest();
        if buffer != values * 4 || data.len() != buffer {
            return Err(format!(
                "a CSI segment of {} × {} × {} values with a {buffer}-byte buffer and {} bytes \
                 left (4 bytes per value)",
                csi.num_rx,
                csi.num_sts,
                csi.num_tone,
                data.len()
            ));
        }
        csi.values = csi_values(data);
        Ok(csi)
    }

    /// The value of chain `rx`, stream `sts`, tone `tone`.
    pub fn at(&self, rx: usize, sts: usize, tone: usize) -> Option<Complex<i16>> {
        let (nsts, ntone) = (usize::from(self.num_sts), usize::from(self.num_tone));
        (sts < nsts && tone < ntone)
            .then(|| self.values.get((rx * nsts + sts) * ntone + tone).copied())
            .flatten()
    }
}
