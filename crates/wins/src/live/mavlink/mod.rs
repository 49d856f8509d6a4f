//! MAVLink with the flight controller: the connection ([`link`] over [`udp`] or [`stream`], framed by [`framer`]), the messages read
//! from it ([`inbound`]), the pose sent to it ([`outbound`]), and MAVLink 2 message signing with a
//! key ([`signing`]).

pub mod framer;
pub mod inbound;
pub mod link;
pub mod outbound;
pub mod signing;
pub mod stream;
pub mod udp;
