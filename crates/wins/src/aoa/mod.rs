//! Angle of arrival: per-packet (AoA, ToF) by MUSIC on the smoothed CSI (SpotFi), the direct path
//! over a group of packets (SpotFi clustering), and the IMU-guided per-packet PAoA of WINS.
//!
//! Per packet, in this order: chain calibration ([`crate::rig::ChainCalibration`]; measured by [`measure_chains`]), ToF sanitization
//! (`crate::csi::sanitize`), smoothing (`smoothing`), signal subspace (`subspace`), spectrum
//! and peaks ([`music`]). The steering vector is [`steering`]'s, shared with the simulator.

pub mod capture_check;
pub mod capture_stats;
pub mod chain_curvature;
pub(crate) mod estimator;
pub(crate) mod group;
pub mod measure_chains;
pub mod music;
pub(crate) mod packet;
pub(crate) mod paoa;
pub(crate) mod peak;
pub(crate) mod received;
pub mod reference;
pub(crate) mod smoothing;
pub mod spotfi;
pub mod steering;
pub(crate) mod subspace;
mod top_eigen;

pub use chain_curvature::{ChainCurvature, Correction, curvature_of, restart_step_rad};
pub use estimator::{AoaConfig, AoaError, AoaEstimator, raw_csi, received_csi};
pub use group::GroupResult;
pub use measure_chains::{
    CalibrateError, CalibrateReport, calibrate, calibrate_packets, calibrate_packets_with,
    calibrate_with,
};
pub use music::{AoaWindow, Music, MusicConfig, MusicError, Spectrum};
pub use packet::{PacketAoa, chains_flip_sign};
pub use paoa::{AoaPrediction, PaoaResult};
pub use peak::Peak;
pub use received::ReceivedAoa;
pub use subspace::PathCount;
