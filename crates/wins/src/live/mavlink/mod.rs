//! MAVLink with the flight controller: the connection ([`link`], [`udp_in`]), the messages read
//! from it ([`inbound`]), the pose sent to it ([`outbound`]), and MAVLink 2 message signing with a
//! key ([`signing`]).

pub mod inbound;
pub mod link;
pub mod outbound;
pub mod signing;
pub mod udp_in;
