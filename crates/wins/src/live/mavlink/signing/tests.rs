use ::mavlink::dialects::common::{HEARTBEAT_DATA, MavAutopilot, MavModeFlag, MavState, MavType};
use ::mavlink::{MAVLinkV1MessageRaw, MavlinkReader, MavlinkVersion};

use super::*;

fn key(seed: u8) -> MavlinkKey {
    MavlinkKey::from_bytes(std::array::from_fn(|i| seed.wrapping_add(i as u8)))
}

fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_PX4,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

fn header(sequence: u8) -> MavHeader {
    MavHeader {
        system_id: 1,
        component_id: 1,
        sequence,
    }
}

fn v2(frame: MAVLinkV2MessageRaw) -> MAVLinkMessageRaw {
    MAVLinkMessageRaw::V2(frame)
}

/// Reads the one frame in `bytes` as the link does (CRC checked, signature not).
fn read(bytes: &[u8]) -> MAVLinkMessageRaw {
    MavlinkReader::new(bytes)
        .read_any_raw_message::<MavMessage>()
        .expect("one CRC-valid frame")
}

/// A HEARTBEAT signed by pymavlink 2.4.50 (`mav.signing`: key 00 01 … 1f, link id 0, timestamp
/// 300 000 000 000, sequence 7, from system 1 component 1).
const PYMAVLINK_HEARTBEAT: &str =
    "fd09010007010100000000000000020c00040312f70000b864d94500d18d9306062e";
const PYMAVLINK_TIMESTAMP: u64 = 300_000_000_000;

fn unhex(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn the_key_file_forms_are_read_and_nothing_else() {
    let raw: [u8; 32] = std::array::from_fn(|i| (i as u8).wrapping_mul(37) ^ 0x80);
    let want = MavlinkKey::from_bytes(raw);
    assert_eq!(MavlinkKey::parse(&raw).unwrap(), want);
    let mut px4 = raw.to_vec();
    px4.extend(123_456_789_u64.to_le_bytes());
    assert_eq!(MavlinkKey::parse(&px4).unwrap(), want, "PX4's 40-byte file");
    let hex: String = raw.iter().map(|b| format!("{b:02x}")).collect();
    for text in [
        hex.clone(),
        format!("{hex}\n"),
        format!("  {}\r\n", hex.to_uppercase()),
    ] {
        assert_eq!(
            MavlinkKey::parse(text.as_bytes()).unwrap(),
            want,
            "{text:?}"
        );
    }

    let cases: [(&[u8], &str); 6] = [
        (&raw[..31], "31 bytes"),
        (&[0xFF; 33], "33 bytes"),
        (b"", "0 bytes"),
        (b"correct horse battery staple\n", "28 characters of text"),
        (&[b'g'; 64], "not all hex digits"),
        (&[b'a'; 63], "63 characters of text"),
    ];
    for (content, needle) in cases {
        let error = MavlinkKey::parse(content).unwrap_err();
        assert!(error.contains(needle), "{error}");
        assert!(
            !error.contains("horse"),
            "the content is never shown: {error}"
        );
    }
    assert_eq!(format!("{want:?}"), "MavlinkKey(..)");
}

#[test]
fn key_file_errors_name_the_file_and_the_forms_never_the_key() {
    let dir = std::env::temp_dir().join(format!("wins-signing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing.key");
    let error = MavlinkKey::read(&missing).unwrap_err().to_string();
    assert!(
        error.contains("cannot read") && error.contains("missing.key"),
        "{error}"
    );

    let short = dir.join("short.key");
    let secret = "00112233445566778899aabbccddeeff00112233445566778899aabbccddee";
    std::fs::write(&short, secret).unwrap();
    let error = MavlinkKey::read(&short).unwrap_err().to_string();
    assert!(
        error.contains("short.key") && error.contains("62 characters"),
        "{error}"
    );
    assert!(
        error.contains("64 hex digits") && error.contains("PX4"),
        "{error}"
    );
    assert!(!error.contains("0011223344"), "{error}");

    let good = dir.join("good.key");
    std::fs::write(&good, [7_u8; 32]).unwrap();
    assert_eq!(
        MavlinkKey::read(&good).unwrap(),
        MavlinkKey::from_bytes([7; 32])
    );
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&good, std::fs::Permissions::from_mode(0o644)).unwrap();
        let warning = key_file_warning(&good).expect("a warning");
        assert!(
            warning.contains("644") && warning.contains("chmod 600"),
            "{warning}"
        );
        std::fs::set_permissions(&good, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert_eq!(key_file_warning(&good), None);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn we_sign_as_pymavlink_does() {
    let signer = Signer::new(MavlinkKey::from_bytes(std::array::from_fn(|i| i as u8)));
    let frame = signer.sign_at(header(7), &heartbeat(), PYMAVLINK_TIMESTAMP);
    assert_eq!(frame.raw_bytes(), unhex(PYMAVLINK_HEARTBEAT).as_slice());
}

#[test]
fn a_frame_signed_with_the_key_is_taken_once() {
    let (sender, receiver) = (Signer::new(key(1)), Signer::new(key(1)));
    let bytes = sender.sign(header(0), &heartbeat()).raw_bytes().to_vec();
    let (h, message) = receiver.accept(&read(&bytes)).expect("taken").unwrap();
    assert_eq!((h.system_id, h.component_id), (1, 1));
    assert_eq!(message, heartbeat());
    assert_eq!(receiver.check(&read(&bytes)), Err(Refusal::Replayed));
    // The next one of the stream is taken.
    let next = sender.sign(header(1), &heartbeat());
    assert_eq!(receiver.check(&v2(next)), Ok(()));
    let counts = receiver.counts();
    assert_eq!(
        (counts.accepted, counts.replayed, counts.refused()),
        (2, 1, 1)
    );
    assert_eq!(sender.counts().signed_out, 2);
}

#[test]
fn unsigned_wrongly_signed_and_altered_frames_are_refused_and_counted() {
    let receiver = Signer::new(key(1));
    let mut unsigned = Vec::new();
    ::mavlink::write_versioned_msg(&mut unsigned, MavlinkVersion::V2, header(0), &heartbeat())
        .unwrap();
    assert_eq!(receiver.check(&read(&unsigned)), Err(Refusal::Unsigned));
    let mut v1 = MAVLinkV1MessageRaw::new();
    v1.serialize_message(header(0), &heartbeat());
    assert_eq!(
        receiver.check(&MAVLinkMessageRaw::V1(v1)),
        Err(Refusal::Unsigned)
    );

    let other = Signer::new(key(2)).sign(header(0), &heartbeat());
    assert_eq!(receiver.check(&v2(other)), Err(Refusal::BadSignature));

    let mut altered = Signer::new(key(1)).sign(header(0), &heartbeat());
    let payload_at = 10; // after the 10-byte header: custom_mode's first byte
    if let Some(b) = altered.as_mut_slice().get_mut(payload_at) {
        *b ^= 1;
    }
    assert_eq!(receiver.check(&v2(altered)), Err(Refusal::BadSignature));
    let mut later = Signer::new(key(1)).sign(header(0), &heartbeat());
    let t = later.signature_timestamp() + 1000;
    later
        .signature_timestamp_bytes_mut()
        .copy_from_slice(&t.to_le_bytes()[..6]);
    assert_eq!(
        receiver.check(&v2(later)),
        Err(Refusal::BadSignature),
        "the timestamp is signed"
    );

    let counts = receiver.counts();
    assert_eq!(
        (
            counts.unsigned,
            counts.bad_signature,
            counts.accepted,
            counts.refused()
        ),
        (2, 3, 0, 5)
    );
}

#[test]
fn a_new_stream_more_than_a_minute_behind_is_stale_and_a_bad_signature_moves_nothing() {
    let (sender, receiver) = (Signer::new(key(1)), Signer::new(key(1)));
    let now = timestamp_now();
    let old = sender.sign_at(header(0), &heartbeat(), now - 2 * NEW_STREAM_WINDOW);
    assert_eq!(receiver.check(&v2(old)), Err(Refusal::Stale));
    let recent = sender.sign_at(header(1), &heartbeat(), now - NEW_STREAM_WINDOW / 2);
    assert_eq!(receiver.check(&v2(recent)), Ok(()));

    // A forged frame far in the future does not move the stream: the next valid one is taken.
    let far = Signer::new(key(9)).sign_at(header(2), &heartbeat(), now + 1_000_000_000);
    assert_eq!(receiver.check(&v2(far)), Err(Refusal::BadSignature));
    let next = sender.sign_at(header(3), &heartbeat(), now);
    assert_eq!(receiver.check(&v2(next)), Ok(()));
    assert_eq!(receiver.counts().stale, 1);
}

#[test]
fn our_timestamps_follow_the_clock_increase_and_stay_ahead_of_what_we_took() {
    let signer = Signer::new(key(1));
    let before = timestamp_now();
    let first = signer.sign(header(0), &heartbeat()).signature_timestamp();
    let second = signer.sign(header(1), &heartbeat()).signature_timestamp();
    assert!(
        first >= before && first <= timestamp_now() + 1,
        "{before} {first}"
    );
    assert!(second > first);
    // 2015-01-01 is the origin: today is years after it, in 10 µs units.
    assert!(first > 10 * 365 * 86_400 * 100_000, "{first}");

    // A valid message from a flight controller whose clock is an hour ahead pulls ours along.
    let ahead = timestamp_now() + 3600 * 100_000;
    let fc = Signer::new(key(1)).sign_at(header(0), &heartbeat(), ahead);
    assert_eq!(signer.check(&v2(fc)), Ok(()));
    let third = signer.sign(header(2), &heartbeat()).signature_timestamp();
    assert!(third > ahead, "{third} after {ahead}");
}
