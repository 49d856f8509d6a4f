//! Angle of arrival: per-packet (AoA, ToF) by MUSIC on the smoothed CSI (SpotFi), the direct path
//! over a group of packets (SpotFi clustering), and the IMU-guided per-packet PAoA of WINS.
//!
//! Per packet, in this order: chain calibration ([`calibration`]), ToF sanitization
//! ([`crate::csi::sanitize`]), smoothing ([`smoothing`]), signal subspace ([`subspace`]), spectrum
//! and peaks ([`music`]). The steering vector is [`steering`]'s, shared with the simulator.

pub mod calibrate;
pub mod calibration;
pub mod estimator;
pub mod group;
pub mod log;
pub mod music;
pub mod paoa;
pub mod peak;
pub mod reference;
pub mod smoothing;
pub mod spotfi;
pub mod steering;
pub mod subspace;
mod top_eigen;

pub use calibrate::{CalibrateError, CalibrateReport, calibrate, calibrate_with};
pub use calibration::ChainCalibration;
pub use estimator::{AoaConfig, AoaError, AoaEstimator};
pub use group::GroupResult;
pub use log::{
    AoaLogError, AoaLogSummary, AoaMode, PacketAoa, PacketStatus, TruthPairs, estimate_log,
    read_aoa_config, truth_pairs,
};
pub use music::{AoaWindow, Music, MusicConfig, MusicError, Spectrum};
pub use paoa::{AoaPrediction, PaoaResult};
pub use peak::Peak;
pub use steering::{ArrayGeometry, SPEED_OF_LIGHT_M_S};
