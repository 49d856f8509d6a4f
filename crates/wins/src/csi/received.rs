//! One received packet as the estimator takes it ([`Received`]): an Intel 5300 record, on which
//! the 5300's own model applies (its subcarrier groups, its receiver response, its chains'
//! restart steps), or any other card's packet ([`CsiPacket`]) on its own subcarriers.

use super::intel5300::{BfeeHeader, CsiRecord};
use super::packet::CsiPacket;

/// One packet of an AP's capture.
// Not boxed: most packets are Intel 5300 records, and a box would cost each an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Received {
    /// An Intel 5300 record.
    Intel5300(CsiRecord),
    /// Any other card's packet.
    Card(CsiPacket),
}

impl From<CsiRecord> for Received {
    fn from(record: CsiRecord) -> Self {
        Self::Intel5300(record)
    }
}

impl From<CsiPacket> for Received {
    fn from(packet: CsiPacket) -> Self {
        Self::Card(packet)
    }
}

impl Received {
    /// Its time on the card's clock, ns (the 5300's `timestamp_low` unwrapped across its wraps;
    /// another card's clock as it stores it).
    pub fn nic_time_ns(&self) -> i64 {
        match self {
            Self::Intel5300(r) => r.timestamp.as_nanos(),
            Self::Card(p) => p.clock_ns,
        }
    }

    /// Receive chains.
    pub fn num_rx(&self) -> usize {
        match self {
            Self::Intel5300(r) => usize::from(r.header.nrx),
            Self::Card(p) => p.num_rx(),
        }
    }

    /// Channel width, MHz.
    pub fn bandwidth_mhz(&self) -> u32 {
        match self {
            Self::Intel5300(r) => r.header.rate.bandwidth().mhz(),
            Self::Card(p) => p.bandwidth_mhz,
        }
    }

    /// The Intel 5300 record, if it is one.
    pub fn intel5300(&self) -> Option<&CsiRecord> {
        match self {
            Self::Intel5300(r) => Some(r),
            Self::Card(_) => None,
        }
    }

    /// The Intel 5300 record, if it is one, to change.
    pub fn intel5300_mut(&mut self) -> Option<&mut CsiRecord> {
        match self {
            Self::Intel5300(r) => Some(r),
            Self::Card(_) => None,
        }
    }

    /// What tells a packet logged twice from another at the same time: every field of a 5300
    /// header, exactly; another card's clock, sequence number and transmitter.
    pub fn repeat_key(&self) -> u128 {
        match self {
            Self::Intel5300(r) => header_key(&r.header),
            Self::Card(p) => {
                let mac = p.transmitter.map_or(0u64, |m| {
                    m.iter().fold(0u64, |k, b| (k << 8) | u64::from(*b))
                });
                (u128::from(p.clock_ns as u64) << 64)
                    | (u128::from(p.sequence.unwrap_or(u16::MAX)) << 48)
                    | u128::from(mac)
            }
        }
    }
}

/// Every field of a 5300 header in 128 bits (an exact key, not a hash).
fn header_key(h: &BfeeHeader) -> u128 {
    let bytes = [
        h.nrx,
        h.ntx,
        h.rssi[0],
        h.rssi[1],
        h.rssi[2],
        h.noise_dbm as u8,
        h.agc,
        h.antenna_sel,
    ];
    (u128::from(h.timestamp_low) << 96)
        | (u128::from(h.bfee_count) << 80)
        | (u128::from(h.rate.0) << 64)
        | u128::from(u64::from_le_bytes(bytes))
}
