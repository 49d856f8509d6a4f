//! The library half of a live run: the flight controller's MAVLink link (IMU and barometer in, pose
//! out) and the relation of the sensors' clocks to the host's.
//!
//! A driver owns the sockets and the loop; everything here is a value in, a value out, so it is
//! tested without hardware.

pub mod clock;
pub mod mavlink;
