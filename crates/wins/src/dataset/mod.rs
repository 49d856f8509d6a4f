//! Recordings on disk: the layout a real rig and the simulator both write, and its loader.
//!
//! ```text
//! DIR/dataset.toml     manifest: array geometry, body_from_array, channel, IMU file, one entry per
//!                      AP with its .dat log and the NIC-to-IMU clock offset
//! DIR/imu.csv          EuRoC-style: #timestamp [ns], gyro xyz [rad s^-1], accel xyz [m s^-2]
//! DIR/<ap>.dat         Intel 5300 CSI Tool log, one per AP
//! DIR/baro.csv         optional: t_ns,altitude_m from the flight controller's barometer
//! DIR/truth/           what only a simulator (or motion capture) knows; the estimator never reads it
//!   poses.tum          body poses, TUM format: t[s] x y z qx qy qz qw (world_from_body); the only
//!                      required file (motion capture has nothing else), the rest are optional
//!   aps.csv            name,x_m,y_m,z_m
//!   packets_<ap>.csv   per packet slot: true direct-path AoA, ToF, range, SNR, …
//!   imu_biases.csv     true gyro and accelerometer biases at each IMU sample
//!   baro.csv           with a barometer: t_ns,height_m,offset_m,drift_m behind each reading
//!   truth.toml         NIC per-chain phase offsets, seed, scenario name
//!   scenario.toml      the scenario that produced the dataset
//! ```

mod ap_reader;
pub mod baro_csv;
pub mod checks;
pub mod events;
pub mod imu_csv;
pub mod incremental;
pub(crate) mod load;
pub(crate) mod manifest;
pub mod stream;
pub mod truth;

pub use baro_csv::BaroSample;
pub use load::{ApLog, CsiPacket, Dataset, DatasetError};
pub use manifest::{
    ApEntry, ArrayEntry, BaroEntry, ChannelEntry, ImuEntry, Manifest, format_mac, parse_mac,
};
