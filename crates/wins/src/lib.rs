//! # wins: WiFi-inertial pose estimation for micro aerial vehicles
//!
//! A Rust implementation of WINS (Zhang, Wang, Jiang, IEEE TIE): a drone with an IMU and a
//! 3-antenna WiFi card estimates its position and attitude from ordinary packets of access points at
//! unknown positions, with no cameras and no set-up in the building.
//!
//! ```text
//!  CSI packets (per AP) ─► chain calibration, sanitize ─► MUSIC (AoA, ToF) ─► PAoA per packet ─┐
//!                                       ▲ predicted AoA ± 20° (previous angle turned by gyro) │
//!  IMU 200 Hz ─► preintegration ────────┴─────────────────────────────────────────────────────┤
//!                                                                                             ▼
//!        nonlinear sliding window: attitude, p, v, IMU biases per keyframe, APs in 3-D, baro
//!        offset (started at rest and by the paper's linear window; marginalized with FEJ)
//!                                                                                             │
//!                  pose + covariance per frame, propagated at IMU rate ◄──────────────────────┘
//! ```
//!
//! ## Using it
//!
//! The front door is [`run_dataset`]: a dataset folder (the layout of [`dataset`], written by a
//! real rig or by the simulator) and a [`Config`] in, a [`RunOutput`] out: the trajectory, the
//! APs, one row per packet, counters, and with a `truth/` folder the metrics. Live drivers push
//! samples and packets into a [`Pipeline`] instead. [`prelude`] brings the names below.
//!
//! ```
//! use wins::prelude::*;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A 20 s simulated flight of the paper's set-up, written as a dataset folder.
//! let mut scenario = Scenario::built_in("paper-circle")?;
//! scenario.duration_s = 20.0;
//! let dir = std::env::temp_dir().join(format!("wins-doc-{}", std::process::id()));
//! let flight = simulate(&scenario, &mut |_| {})?;
//! write_dataset(&dir, &scenario, &flight)?;
//!
//! // WINS on it, from the files, as on a real recording.
//! let run = run_dataset(&dir, &Config::default())?;
//! let stats = &run.stats.per_ap[0];
//! assert_eq!(stats.packets, stats.fed + stats.acquisition + stats.dropped());
//! if let Some(metrics) = &run.metrics {
//!     print!("{}", metrics.report());
//! }
//! run.write(&dir.join("run"))?;
//! assert!(dir.join("run/trajectory.tum").is_file());
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok(())
//! # }
//! ```
//!
//! The stages, bottom up: [`time`], [`so3`], [`check`] (settings' problems), [`chi2`] (quantiles); [`rig`] (what
//! describes the hardware), [`csi`] (the Intel 5300 CSI Tool log reader, streaming decoder and
//! writer), [`imu`] (preintegration); [`dataset`] (the on-disk layout); [`aoa`] (sanitization,
//! MUSIC over AoA and ToF, SpotFi, the IMU-guided PAoA; [`aoa::steering`] is the one steering
//! vector), [`eval`] (trajectory and AP errors, evo-compatible); [`fusion`] (the default
//! 6-DoF nonlinear window in [`fusion::nonlinear`], the paper's method as the comparison in
//! [`fusion::paper`], and what both share: poses out, counters, errors, the arrow solver and its
//! one factor interface); [`sim`] (flights, IMU and multipath CSI written as datasets);
//! [`config`] (the settings tree: every stage's section under one [`Config`], loaded and checked
//! at once); [`pipeline`] (WINS end to end as a push API: per-AP tracks, frames, the receive
//! chains' offsets resolved in flight); [`run`] (batch runs: a dataset replayed through the
//! pipeline and its run folder written, the front door [`run_dataset`], the one writer of
//! `trajectory.tum`); [`live`] (`wins live`: the NIC and flight controller around the pipeline);
//! [`sweep`] (many runs over scenarios and seeds). The settings tree, the pipeline, batch runs
//! and live runs import one another only in that order.
//!
//! ## Conventions (stated once, used everywhere)
//!
//! - **Frames**: `w` world (z up, gravity-aligned once gravity is solved); `b` body = IMU frame;
//!   `b0` the first PAoA frame, the estimator's reference; `a` the antenna-array frame, fixed to `b`
//!   by a configured extrinsic.
//! - **Names carry frames**: `p_b_in_w`, `v_b_in_b`, `g_in_b`, and transforms as
//!   `world_from_body` (target-from-source). Inside a maths-heavy function `R_w_b` is fine.
//! - **Quaternions are Hamilton** (nalgebra `UnitQuaternion`), with one perturbation side declared
//!   where perturbations are used.
//! - **Time is integer nanoseconds** ([`time::Timestamp`]). The Intel 5300's 32-bit microsecond
//!   `timestamp_low` wraps every ~71.6 min and is unwrapped once, at the reader.
//! - **Units are SI.** Non-SI or ambiguous quantities carry a suffix: `rssi_dbm`, `freq_hz`,
//!   `aoa_rad`.
//! - **IMU noise** is given as continuous densities (rad/s/√Hz, m/s²/√Hz; random walks per √s) and
//!   discretized with the sample period (σ_d = σ_c/√Δt for white noise).
//! - **Gravity** in the estimator's model is the *upward* specific force at rest, (0, 0, +9.8) in the
//!   body frame when level (paper `eqn:linear_update`).
//! - **Angle of arrival**: antennas on the array's `a_y` axis at `y_m = (m − (M−1)/2)·d`, normal
//!   `a_x`; with û the unit vector toward the AP, sin θ = û · ŷ_a, and a plane wave reaches antenna
//!   `m` with phase exp(+j·2π·f·y_m·sin θ / c) relative to the array centre. One module owns this
//!   steering vector; the simulator and the estimator both call it.
//! - **Errors**: the library never prints and never panics on bad input; it returns typed errors,
//!   or skips and counts what it cannot use, with offsets.

#![warn(missing_docs)]

pub mod aoa;
pub mod check;
pub mod chi2;
pub mod config;
pub mod csi;
pub mod dataset;
pub mod eval;
pub mod figures;
pub mod fusion;
pub mod imu;
pub mod io_safety;
pub mod live;
pub mod pipeline;
pub mod rig;
pub mod run;
pub mod sim;
pub mod so3;
pub mod sweep;
pub mod time;

pub use config::{Config, ConfigError};
pub use pipeline::{Pipeline, PipelineError};
pub use run::replay::RunOutput;
pub use run::{RunError, RunOptions, run_dataset, run_dataset_into, run_dataset_with};

/// The names most programs need: `use wins::prelude::*;`.
pub mod prelude {
    pub use crate::config::Config;
    pub use crate::dataset::Dataset;
    pub use crate::eval::Metrics;
    pub use crate::pipeline::Pipeline;
    pub use crate::rig::Rig;
    pub use crate::run::replay::RunOutput;
    pub use crate::run::{RunError, RunOptions, run_dataset, run_dataset_with};
    pub use crate::sim::{Scenario, simulate, write_dataset};
}
