//! Channel state information: types shared by every CSI source, and the Intel 5300 log format.

pub mod intel5300;
pub mod subcarriers;

pub use subcarriers::{Bandwidth, NUM_SUBCARRIERS, SUBCARRIER_SPACING_HZ};
