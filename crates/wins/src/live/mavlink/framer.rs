//! MAVLink frames out of bytes (a TCP connection, a serial line, a datagram), every byte
//! accounted for.
//!
//! A frame starts with its magic byte (`0xFD` MAVLink 2, `0xFE` MAVLink 1), whose header gives
//! its length (MAVLink 2: 10 header bytes, the payload, 2 checksum bytes, and 13 signature bytes
//! when the incompatibility flags say signed). A frame whose message the common dialect knows
//! is checked by its CRC (with the message's CRC extra); one that fails is counted
//! ([`FrameCounts::bad_crc`]) and the search goes on from the next byte, since its magic may
//! have been a byte of garbage. A frame of a message the dialect does not know (ArduPilot's own
//! messages, say) cannot be checked: when the next frame's magic follows right after it, it is
//! skipped whole ([`FrameCounts::unknown_messages`]), since searching inside its payload would
//! count its bytes as garbage; otherwise its magic was garbage (frames follow one another), and
//! the search goes on from the next byte, so a stray magic never hides the frames after it. Bytes outside any frame are
//! [`FrameCounts::garbage_bytes`]. The mavlink crate's own readers skip all of these silently.

use ::mavlink::dialects::common::MavMessage;
use ::mavlink::{MAVLinkMessageRaw, MAVLinkV1MessageRaw, MAVLinkV2MessageRaw, Message};
use serde::Serialize;

const MAGIC_V1: u8 = 0xFE;
const MAGIC_V2: u8 = 0xFD;
/// Magic to message id, MAVLink 1.
const HEADER_V1: usize = 6;
/// Magic to message id, MAVLink 2.
const HEADER_V2: usize = 10;
const CHECKSUM: usize = 2;
const SIGNATURE: usize = 13;
/// The MAVLink 2 incompatibility flag of a signed frame (the only one defined).
const SIGNED: u8 = 0x01;
/// The buffer is compacted when its consumed front is longer than this.
const COMPACT_AT: usize = 4096;

/// What a byte stream held, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameCounts {
    /// Frames whose CRC holds, handed out.
    pub frames: u64,
    /// Bytes outside any frame (noise on a serial line, a wrong baud rate, stray data).
    pub garbage_bytes: u64,
    /// Frames of a known message whose CRC fails (a corrupted frame, or garbage that looked
    /// like a frame's start).
    pub bad_crc: u64,
    /// Frames of messages the common dialect does not know, skipped unchecked.
    pub unknown_messages: u64,
}

impl FrameCounts {
    /// The sum of two counts.
    pub fn plus(self, o: Self) -> Self {
        Self {
            frames: self.frames + o.frames,
            garbage_bytes: self.garbage_bytes + o.garbage_bytes,
            bad_crc: self.bad_crc + o.bad_crc,
            unknown_messages: self.unknown_messages + o.unknown_messages,
        }
    }
}

/// What the bytes at the search's position are.
enum Candidate {
    /// Not enough bytes yet to tell.
    Incomplete,
    /// Not a frame's start (a MAVLink 2 header with flags no receiver may accept).
    NotAFrame,
    /// A whole frame of `len` bytes of message `id`.
    Frame { len: usize, id: u32, v2: bool },
}

/// Bytes in, frames out (module doc).
#[derive(Debug, Default)]
pub struct Framer {
    buffer: Vec<u8>,
    /// Where the search stands in `buffer`.
    at: usize,
    counts: FrameCounts,
}

impl Framer {
    /// What has been counted so far.
    pub fn counts(&self) -> FrameCounts {
        self.counts
    }

    /// Appends bytes read.
    pub fn push(&mut self, bytes: &[u8]) {
        if self.at > COMPACT_AT || self.at == self.buffer.len() {
            self.buffer.drain(..self.at);
            self.at = 0;
        }
        self.buffer.extend_from_slice(bytes);
    }

    /// The next frame whose CRC holds; `None` when the bytes so far hold no more. With `end`
    /// (the end of a datagram, or of a closed stream) no more bytes will follow: a frame cut
    /// short is garbage, and the search goes on past its magic.
    pub fn next_frame(&mut self, end: bool) -> Option<MAVLinkMessageRaw> {
        loop {
            let rest = self.buffer.get(self.at..).unwrap_or_default();
            let Some(start) = rest.iter().position(|&b| b == MAGIC_V1 || b == MAGIC_V2) else {
                self.skip(rest.len());
                return None;
            };
            self.skip(start);
            let rest = self.buffer.get(self.at..).unwrap_or_default();
            match candidate(rest) {
                Candidate::Incomplete if end => self.skip(1),
                Candidate::Incomplete => return None,
                Candidate::NotAFrame => self.skip(1),
                Candidate::Frame { len, id, v2 } => {
                    if MavMessage::default_message_from_id(id).is_none() {
                        // Taken as a frame only when the next frame starts right after it.
                        match rest.get(len) {
                            None if !end => return None,
                            Some(b) if *b != MAGIC_V1 && *b != MAGIC_V2 => self.skip(1),
                            _ => {
                                self.counts.unknown_messages += 1;
                                self.at += len;
                            }
                        }
                        continue;
                    }
                    let bytes = rest.get(..len).unwrap_or_default();
                    match checked(bytes, v2) {
                        Some(frame) => {
                            self.counts.frames += 1;
                            self.at += len;
                            return Some(frame);
                        }
                        None => {
                            self.counts.bad_crc += 1;
                            self.skip(1);
                        }
                    }
                }
            }
        }
    }

    /// Bytes left unframed when no more will come and [`Self::next_frame`]`(true)` has
    /// handed out the last frame (a closed stream): counted as garbage and dropped.
    pub fn finish(&mut self) {
        self.skip(self.buffer.len().saturating_sub(self.at));
        self.buffer.clear();
        self.at = 0;
    }

    /// Counts `n` bytes at the search's position as garbage and passes them.
    fn skip(&mut self, n: usize) {
        self.counts.garbage_bytes += n as u64;
        self.at += n;
    }
}

/// Reads the header at the start of `bytes` (which starts with a magic byte).
fn candidate(bytes: &[u8]) -> Candidate {
    let v2 = bytes.first() == Some(&MAGIC_V2);
    let header = if v2 { HEADER_V2 } else { HEADER_V1 };
    let Some(h) = bytes.get(..header) else {
        return Candidate::Incomplete;
    };
    let payload = usize::from(h[1]);
    let (len, id) = if v2 {
        let flags = h[2];
        if flags & !SIGNED != 0 {
            return Candidate::NotAFrame;
        }
        let signature = if flags & SIGNED != 0 { SIGNATURE } else { 0 };
        let id = u32::from_le_bytes([h[7], h[8], h[9], 0]);
        (header + payload + CHECKSUM + signature, id)
    } else {
        (header + payload + CHECKSUM, u32::from(h[5]))
    };
    if bytes.len() < len {
        return Candidate::Incomplete;
    }
    Candidate::Frame { len, id, v2 }
}

/// The frame `bytes` when its CRC holds.
fn checked(bytes: &[u8], v2: bool) -> Option<MAVLinkMessageRaw> {
    if v2 {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.as_mut_slice()
            .get_mut(..bytes.len())?
            .copy_from_slice(bytes);
        raw.has_valid_crc::<MavMessage>()
            .then_some(MAVLinkMessageRaw::V2(raw))
    } else {
        let mut raw = MAVLinkV1MessageRaw::new();
        raw.as_mut_slice()
            .get_mut(..bytes.len())?
            .copy_from_slice(bytes);
        raw.has_valid_crc::<MavMessage>()
            .then_some(MAVLinkMessageRaw::V1(raw))
    }
}

#[cfg(test)]
mod tests;
