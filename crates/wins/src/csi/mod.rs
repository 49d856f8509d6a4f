//! Channel state information: types shared by every CSI source, the Intel 5300 log format, the
//! Nexmon capture format, FeitCSI files (Intel AX200/AX210), and sanitization (SpotFi Algorithm 1).

pub mod atheros;
pub mod capture;
pub mod feitcsi;
pub mod format;
pub mod intel5300;
pub mod iwlmvm;
pub mod logged;
pub mod nexmon;
pub mod packet;
pub mod picoscenes;
pub mod received;
pub mod report;
pub mod sanitize;
pub(crate) mod subcarriers;

pub use received::Received;
pub use subcarriers::{Bandwidth, NUM_SUBCARRIERS, SUBCARRIER_SPACING_HZ};

/// A transmitter's 48-bit MAC address, as sent on the air.
pub type MacAddress = [u8; 6];
