//! # wins: WiFi-inertial pose estimation for micro aerial vehicles
//!
//! A Rust implementation of WINS (Zhang, Wang, Jiang, IEEE TIE): a drone with an IMU and a
//! 3-antenna WiFi card estimates its position and attitude from ordinary packets of access points at
//! unknown positions, with no cameras and no set-up in the building.
//!
//! ```text
//!  CSI packets (per AP) ──► sanitize ─► AoA/ToF MUSIC ──► PAoA (per packet) ──┐
//!                               ▲ predicted AoA ± 20°                         │
//!  IMU 200 Hz ──► preintegrate ─┴─► attitude (rotation averaging) ────────────┤
//!                                                                             ▼
//!                                         linear sliding-window estimator (30 frames)
//!                                         states: p, v, g per frame + AP positions
//!                                                                             │
//!                                      pose at PAoA rate, propagated at IMU rate ◄┘
//! ```
//!
//! Built so far: [`csi`] (the Intel 5300 CSI Tool log reader, streaming decoder and writer),
//! [`sim`] (flights, IMU and multipath Intel 5300 CSI, written as datasets), [`dataset`] (the
//! on-disk layout shared by real and simulated recordings), [`aoa`] (chain calibration, MUSIC over
//! AoA and ToF, SpotFi's direct path, the IMU-guided per-packet PAoA; [`aoa::steering`] is the one
//! steering vector), [`eval`] (trajectory and AP errors, evo-compatible), [`imu`] and [`time`].
//! The fusion stages arrive with later work.
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
pub mod csi;
pub mod dataset;
pub mod eval;
pub mod fusion;
pub mod imu;
pub mod pipeline;
pub mod sim;
pub mod so3;
pub mod time;
