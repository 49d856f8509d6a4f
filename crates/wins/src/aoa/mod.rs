//! Angle of arrival. So far: the array steering vector that the simulator and (later) the MUSIC
//! estimator share, so their sign conventions cannot drift apart.

pub mod steering;

pub use steering::{ArrayGeometry, SPEED_OF_LIGHT_M_S};
