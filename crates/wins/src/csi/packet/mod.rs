//! One CSI type for every card: per packet, the complex CSI over (subcarrier, receive chain,
//! transmit stream) with the subcarriers it belongs to, the carrier, the clock, RSSI per chain,
//! the transmitter and the sequence number, whichever reader it came from. Each reader keeps its
//! own record type, field for field as its format holds it; [`read_packets`] turns any capture
//! into these packets.
//!
//! A packet whose subcarriers cannot be named (a tone count no table has, a card PicoScenes drove
//! that is not an Intel AX) is skipped and counted with its reason, never guessed.

mod convert;
pub mod export;
pub mod tables;

pub use convert::{from_atheros, from_feitcsi, from_nexmon};

use std::collections::BTreeMap;
use std::path::Path;

use num_complex::Complex64;

use super::MacAddress;
use super::capture::CaptureError;
use super::format::CaptureFormat;

/// One packet's CSI, from any card.
#[derive(Clone, Debug, PartialEq)]
pub struct CsiPacket {
    /// The format it was read from.
    pub format: CaptureFormat,
    /// Byte offset of its record (its first packet's, for a Nexmon frame).
    pub offset: u64,
    /// Its time on the clock the format carries, ns, as stored (a card's counter may wrap): the
    /// 5300's `timestamp_low`, the AX200's µs clock, the Atheros timestamp, the pcap's time.
    pub clock_ns: i64,
    /// Carrier (channel centre) frequency, Hz, when the file says.
    pub carrier_hz: Option<f64>,
    /// Channel width, MHz.
    pub bandwidth_mhz: u32,
    /// Subcarrier spacing, Hz.
    pub spacing_hz: f64,
    /// The subcarrier index of each row, ascending except where the card reports otherwise
    /// (the 5300's groups are in report order).
    pub subcarriers: Vec<i32>,
    /// The receive chain (core) of each receive row.
    pub chains: Vec<u8>,
    /// Transmit streams.
    pub num_tx: usize,
    /// The CSI, subcarrier, then receive row, then transmit stream (fastest).
    pub csi: Vec<Complex64>,
    /// RSSI per receive row as the card reports it (`None` where it does not).
    pub rssi: Vec<Option<f64>>,
    /// The transmitter, when the format carries it.
    pub transmitter: Option<MacAddress>,
    /// The 802.11 sequence number, when the format carries it.
    pub sequence: Option<u16>,
}

impl CsiPacket {
    /// Receive rows.
    pub fn num_rx(&self) -> usize {
        self.chains.len()
    }

    /// The value at subcarrier row `sc`, receive row `rx`, stream `tx`.
    pub fn at(&self, sc: usize, rx: usize, tx: usize) -> Option<Complex64> {
        (rx < self.num_rx() && tx < self.num_tx)
            .then(|| {
                self.csi
                    .get((sc * self.num_rx() + rx) * self.num_tx + tx)
                    .copied()
            })
            .flatten()
    }

    /// Each subcarrier's offset from the carrier, Hz.
    pub fn offsets_hz(&self) -> Vec<f64> {
        self.subcarriers
            .iter()
            .map(|&k| f64::from(k) * self.spacing_hz)
            .collect()
    }

    /// The CSI of stream `tx` row-major by receive row (row `m` holds chain `m`'s subcarriers),
    /// the layout the AoA takes; `None` when there is no such stream.
    /// `None` also when the CSI does not hold subcarriers × chains × streams values.
    pub fn antenna_rows(&self, tx: usize) -> Option<Vec<Complex64>> {
        let (nrx, nsc) = (self.num_rx(), self.subcarriers.len());
        if tx >= self.num_tx || self.csi.len() != nsc * nrx * self.num_tx {
            return None;
        }
        (0..nrx)
            .flat_map(|rx| (0..nsc).map(move |sc| (sc, rx)))
            .map(|(sc, rx)| self.csi.get((sc * nrx + rx) * self.num_tx + tx).copied())
            .collect()
    }
}

/// A capture's packets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CsiPackets {
    /// The packets, in file order.
    pub packets: Vec<CsiPacket>,
    /// Records read but not made packets, per reason.
    pub skipped: BTreeMap<String, u64>,
    /// What the reader could not read, in words (`None`: all of it was read).
    pub lost: Option<String>,
}

impl CsiPackets {
    fn skip(&mut self, why: String) {
        *self.skipped.entry(why).or_default() += 1;
    }
}

/// The packets of the capture at `path`, in `format` or else the one its first bytes say (a
/// file none recognizes is read as an Intel 5300 log).
pub fn read_packets(
    path: &Path,
    format: Option<CaptureFormat>,
) -> Result<(CaptureFormat, CsiPackets), CaptureError> {
    let format = CaptureFormat::resolve(path, format).map_err(|source| CaptureError::Io {
        path: path.display().to_string(),
        source,
    })?;
    Ok((format, convert::packets(path, format)?))
}
