//! MAVLink with the flight controller: the connection ([`link`]), the messages read from it
//! ([`inbound`]) and the pose sent to it ([`outbound`]).

pub mod inbound;
pub mod link;
pub mod outbound;
pub mod signing;
pub mod udp_in;
