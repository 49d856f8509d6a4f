#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use ::mavlink::dialects::common::{HEARTBEAT_DATA, SYSTEM_TIME_DATA};
use ::mavlink::{MavHeader, MavlinkVersion};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn header(sequence: u8) -> MavHeader {
    MavHeader {
        system_id: 1,
        component_id: 1,
        sequence,
    }
}

fn frame(version: MavlinkVersion, sequence: u8) -> Vec<u8> {
    let message = MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
        time_unix_usec: 1_700_000_000_000_000 + u64::from(sequence),
        time_boot_ms: u32::from(sequence),
    });
    let mut bytes = Vec::new();
    ::mavlink::write_versioned_msg(&mut bytes, version, header(sequence), &message).unwrap();
    bytes
}

/// Every frame handed out, fed `chunk` bytes at a time.
fn frames(framer: &mut Framer, bytes: &[u8], chunk: usize) -> Vec<u8> {
    let mut sequences = Vec::new();
    for piece in bytes.chunks(chunk) {
        framer.push(piece);
        while let Some(f) = framer.next_frame(false) {
            sequences.push(f.sequence());
        }
    }
    while let Some(f) = framer.next_frame(true) {
        sequences.push(f.sequence());
    }
    framer.finish();
    sequences
}

#[test]
fn frames_of_both_versions_come_out_whole_however_the_bytes_are_cut() {
    let mut bytes = Vec::new();
    for s in 0..10 {
        let version = if s % 3 == 0 {
            MavlinkVersion::V1
        } else {
            MavlinkVersion::V2
        };
        bytes.extend(frame(version, s));
    }
    for chunk in [1, 7, 64, 4096] {
        let mut framer = Framer::default();
        assert_eq!(
            frames(&mut framer, &bytes, chunk),
            (0..10).collect::<Vec<_>>()
        );
        assert_eq!(
            framer.counts(),
            FrameCounts {
                frames: 10,
                ..FrameCounts::default()
            },
            "chunk {chunk}"
        );
    }
}

#[test]
fn garbage_and_a_corrupt_frame_are_counted_and_the_next_frames_found() {
    let mut corrupt = frame(MavlinkVersion::V2, 1);
    corrupt[12] ^= 0x40;
    let garbage = [0x55_u8; 37];
    let mut bytes = frame(MavlinkVersion::V2, 0);
    bytes.extend(garbage);
    bytes.extend(&corrupt);
    bytes.extend(frame(MavlinkVersion::V2, 2));
    let mut framer = Framer::default();
    assert_eq!(frames(&mut framer, &bytes, 5), vec![0, 2]);
    let c = framer.counts();
    assert_eq!((c.frames, c.bad_crc, c.unknown_messages), (2, 1, 0));
    // The corrupt frame's bytes are garbage once its CRC fails: every byte accounted for.
    assert_eq!(c.garbage_bytes, (garbage.len() + corrupt.len()) as u64);
}

#[test]
fn a_message_the_dialect_does_not_know_is_skipped_whole() {
    // ArduPilot's AHRS2 (id 178) is not in the common dialect: a frame of it, with a payload
    // full of magic bytes, is skipped whole and not searched.
    let mut unknown = vec![0xFD, 24, 0, 0, 7, 1, 1, 178, 0, 0];
    unknown.extend([0xFD; 24]);
    unknown.extend([0x12, 0x34]);
    let mut bytes = unknown.clone();
    bytes.extend(frame(MavlinkVersion::V2, 3));
    let mut framer = Framer::default();
    assert_eq!(frames(&mut framer, &bytes, 3), vec![3]);
    let c = framer.counts();
    assert_eq!((c.unknown_messages, c.bad_crc, c.garbage_bytes), (1, 0, 0));
    // The same header with no frame after it (a stray magic in noise) hides nothing.
    let mut bytes = unknown[..10].to_vec();
    bytes.extend(frame(MavlinkVersion::V2, 4));
    bytes.extend(frame(MavlinkVersion::V2, 5));
    let mut framer = Framer::default();
    assert_eq!(frames(&mut framer, &bytes, 3), vec![4, 5]);
    assert_eq!(framer.counts().unknown_messages, 0);
}

#[test]
fn a_signed_frame_is_framed_with_its_signature() {
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA::default());
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message_for_signing(header(9), &heartbeat);
    // Whatever the signature's bytes: the frame is 13 bytes longer, and its CRC holds.
    let mut bytes = raw.raw_bytes().to_vec();
    bytes.extend(frame(MavlinkVersion::V2, 4));
    let mut framer = Framer::default();
    assert_eq!(frames(&mut framer, &bytes, 11), vec![9, 4]);
    assert_eq!(framer.counts().garbage_bytes, 0);
}

#[test]
fn a_cut_frame_at_a_datagrams_end_is_garbage_and_hides_no_frame_after_its_magic() {
    // A stray magic claiming 200 bytes, then a whole frame, in one datagram.
    let mut bytes = vec![0xFD, 200, 0, 0, 0, 1, 1, 2, 0, 0];
    bytes.extend(frame(MavlinkVersion::V2, 5));
    let mut framer = Framer::default();
    framer.push(&bytes);
    assert!(
        framer.next_frame(false).is_none(),
        "a stream waits for more"
    );
    assert_eq!(framer.next_frame(true).map(|f| f.sequence()), Some(5));
    assert!(framer.next_frame(true).is_none());
    framer.finish();
    assert_eq!(framer.counts().garbage_bytes, 10);
}

fn raw_len(f: &MAVLinkMessageRaw) -> u64 {
    match f {
        MAVLinkMessageRaw::V1(r) => r.raw_bytes().len() as u64,
        MAVLinkMessageRaw::V2(r) => r.raw_bytes().len() as u64,
    }
}

#[test]
fn random_bytes_never_panic_and_every_byte_is_counted_once() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..200 {
        let n = rng.random_range(0..2000);
        let mut bytes: Vec<u8> = (0..n).map(|_| rng.random()).collect();
        // Magic bytes often, so that headers are read.
        for b in bytes.iter_mut() {
            if rng.random_bool(0.05) {
                *b = MAGIC_V2;
            }
        }
        let good = frame(MavlinkVersion::V2, 6);
        let at = rng.random_range(0..=bytes.len());
        bytes.splice(at..at, good.iter().copied());
        let mut framer = Framer::default();
        let mut framed = 0;
        for piece in bytes.chunks(rng.random_range(1..300)) {
            framer.push(piece);
            while let Some(f) = framer.next_frame(false) {
                framed += raw_len(&f);
            }
        }
        while let Some(f) = framer.next_frame(true) {
            framed += raw_len(&f);
        }
        framer.finish();
        let c = framer.counts();
        // A stray magic hides no frame after it (an unknown message is taken as a frame only
        // when a magic follows it, which a frame's end in the noise may still fake).
        assert!(
            c.frames >= 1 || c.unknown_messages > 0,
            "the frame put in is lost"
        );
        // Unknown messages' bytes are neither framed nor garbage: without any, the two add up.
        if c.unknown_messages == 0 {
            assert_eq!(framed + c.garbage_bytes, bytes.len() as u64);
        }
    }
}
