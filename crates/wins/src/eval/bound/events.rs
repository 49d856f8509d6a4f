//! The packets and barometer samples of a flight, at the poses they follow.

use super::BoundInput;
use crate::time::Timestamp;

/// What happens at a pose.
#[derive(Clone, Copy, Debug)]
pub(super) enum Event {
    /// A received packet of AP `i`.
    Packet(usize),
    /// A barometer sample.
    Baro,
}

/// Every packet and barometer sample, at the last pose not after it, in pose order (those
/// outside the poses' span dropped).
pub(super) fn events_by_pose(input: &BoundInput) -> Vec<(usize, Event)> {
    let times: Vec<Timestamp> = input.poses.iter().map(|p| p.t).collect();
    let last = times[times.len() - 1];
    let at = |t: Timestamp| -> Option<usize> {
        (t >= times[0] && t <= last).then(|| times.partition_point(|&x| x <= t) - 1)
    };
    let mut out: Vec<(usize, Event)> = Vec::new();
    for (a, list) in input.packets.iter().enumerate() {
        out.extend(
            list.iter()
                .filter_map(|&t| at(t).map(|i| (i, Event::Packet(a)))),
        );
    }
    out.extend(
        input
            .baro
            .iter()
            .filter_map(|&t| at(t).map(|i| (i, Event::Baro))),
    );
    out.sort_by_key(|(i, _)| *i);
    out
}
