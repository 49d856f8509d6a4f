//! `rate_n_flags` of the Intel 5300 (iwlwifi `RATE_MCS_*` bits), as the CSI Tool logs its low 16 bits.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::csi::subcarriers::Bandwidth;

const HT_BIT: u16 = 1 << 8;
const CCK_BIT: u16 = 1 << 9;
const GREENFIELD_BIT: u16 = 1 << 10;
const HT40_BIT: u16 = 1 << 11;
const DUPLICATE_BIT: u16 = 1 << 12;
const SHORT_GI_BIT: u16 = 1 << 13;
const ANT_A_BIT: u16 = 1 << 14;
const ANT_B_BIT: u16 = 1 << 15;
const HT_MCS_MASK: u16 = 0x7F;
const LEGACY_RATE_MASK: u16 = 0xFF;

/// The 16-bit `fake_rate_n_flags` of a CSI record. The third antenna bit (C, bit 16) of the driver's
/// 32-bit field does not survive the CSI Tool's truncation to 16 bits.
#[derive(
    Copy, Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct RateFlags(pub u16);

/// Modulation family of a packet.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Modulation {
    /// 802.11n HT, with its MCS index (0–31, 32 = the HT40 duplicate MCS).
    Ht {
        /// MCS index.
        mcs: u8,
    },
    /// 802.11b CCK; the rate code is the rate in 100 kb/s (10, 20, 55, 110).
    Cck {
        /// Rate code.
        code: u8,
    },
    /// 802.11a/g OFDM; the rate code is the PLCP SIGNAL rate (0x0D = 6 Mb/s … 0x03 = 54 Mb/s).
    Ofdm {
        /// PLCP rate code.
        code: u8,
    },
}

impl RateFlags {
    /// Channel bandwidth (bit 11).
    pub fn bandwidth(self) -> Bandwidth {
        if self.0 & HT40_BIT != 0 {
            Bandwidth::Ht40
        } else {
            Bandwidth::Ht20
        }
    }

    /// HT (802.11n) packet (bit 8).
    pub fn is_ht(self) -> bool {
        self.0 & HT_BIT != 0
    }

    /// HT greenfield preamble (bit 10).
    pub fn is_greenfield(self) -> bool {
        self.0 & GREENFIELD_BIT != 0
    }

    /// Duplicate data in both 20 MHz halves of a 40 MHz channel (bit 12).
    pub fn is_duplicate(self) -> bool {
        self.0 & DUPLICATE_BIT != 0
    }

    /// Short guard interval (bit 13).
    pub fn short_gi(self) -> bool {
        self.0 & SHORT_GI_BIT != 0
    }

    /// Transmit antennas A and B (bits 14, 15).
    pub fn antennas_ab(self) -> (bool, bool) {
        (self.0 & ANT_A_BIT != 0, self.0 & ANT_B_BIT != 0)
    }

    /// Modulation and rate.
    pub fn modulation(self) -> Modulation {
        if self.is_ht() {
            Modulation::Ht {
                mcs: (self.0 & HT_MCS_MASK) as u8,
            }
        } else if self.0 & CCK_BIT != 0 {
            Modulation::Cck {
                code: (self.0 & LEGACY_RATE_MASK) as u8,
            }
        } else {
            Modulation::Ofdm {
                code: (self.0 & LEGACY_RATE_MASK) as u8,
            }
        }
    }

    /// Spatial streams of an HT packet (MCS 0–7: 1, 8–15: 2, 16–23: 3, 24–31: 4; MCS 32: 1).
    pub fn spatial_streams(self) -> Option<u8> {
        match self.modulation() {
            Modulation::Ht { mcs } if mcs < 32 => Some(mcs / 8 + 1),
            Modulation::Ht { .. } => Some(1),
            _ => None,
        }
    }
}

impl fmt::Display for RateFlags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.modulation() {
            Modulation::Ht { mcs } => write!(f, "HT{} MCS {mcs}", self.bandwidth().mhz())?,
            Modulation::Cck { code } => write!(f, "CCK {:.1} Mb/s", f64::from(code) / 10.0)?,
            Modulation::Ofdm { code } => write!(f, "OFDM code 0x{code:02X}")?,
        }
        if self.short_gi() {
            f.write_str(" SGI")?;
        }
        if self.is_greenfield() {
            f.write_str(" GF")?;
        }
        if self.is_duplicate() {
            f.write_str(" DUP")?;
        }
        write!(f, " (0x{:04X})", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_the_rates_seen_in_real_logs() {
        // csiread 0x5 sample: HT20 MCS 1.
        let r = RateFlags(257);
        assert_eq!(r.modulation(), Modulation::Ht { mcs: 1 });
        assert_eq!(r.bandwidth(), Bandwidth::Ht20);
        assert_eq!(r.spatial_streams(), Some(1));
        // CSIKit example: 0x50D = HT, greenfield, MCS 13 (2 streams).
        let r = RateFlags(0x50D);
        assert_eq!(r.modulation(), Modulation::Ht { mcs: 13 });
        assert!(r.is_greenfield() && !r.short_gi());
        assert_eq!(r.spatial_streams(), Some(2));
        assert_eq!(r.to_string(), "HT20 MCS 13 GF (0x050D)");
        // HT40, SGI, antenna A.
        let r = RateFlags(HT_BIT | HT40_BIT | SHORT_GI_BIT | ANT_A_BIT | 16);
        assert_eq!(r.bandwidth(), Bandwidth::Ht40);
        assert!(r.short_gi());
        assert_eq!(r.antennas_ab(), (true, false));
        assert_eq!(r.spatial_streams(), Some(3));
        // Legacy.
        assert_eq!(
            RateFlags(CCK_BIT | 110).modulation(),
            Modulation::Cck { code: 110 }
        );
        assert_eq!(
            RateFlags(0x0D).modulation(),
            Modulation::Ofdm { code: 0x0D }
        );
        assert_eq!(RateFlags(0x0D).spatial_streams(), None);
    }
}
