//! Channel state information: types shared by every CSI source, the Intel 5300 log format, the
//! Nexmon capture format, FeitCSI files (Intel AX200/AX210), and sanitization (SpotFi Algorithm 1).

pub mod capture;
pub mod feitcsi;
pub mod intel5300;
pub mod nexmon;
pub mod sanitize;
pub(crate) mod subcarriers;

pub use subcarriers::{Bandwidth, NUM_SUBCARRIERS, SUBCARRIER_SPACING_HZ};
