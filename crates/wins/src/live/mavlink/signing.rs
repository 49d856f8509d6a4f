//! MAVLink 2 message signing on `wins live`'s link (`live.mavlink_key`, `--mavlink-key FILE`), as
//! the specification has it: <https://mavlink.io/en/guide/message_signing.html>.
//!
//! With a key, every message sent carries the 13-byte signature block (link id, 48-bit
//! timestamp, the first 6 bytes of SHA-256 over the key and the frame), and every message
//! received must carry a valid one. A refused message goes no further (the decoder never sees it)
//! and is counted by its reason ([`SigningCounts`]):
//! - `unsigned`: a MAVLink 1 frame, or a MAVLink 2 frame without the signed flag. Unsigned
//!   messages are never taken with a key, not even a `HEARTBEAT` (the secure choice; a flight
//!   controller that signs sends nothing unsigned);
//! - `bad_signature`: the signature does not match the frame under our key (another key, or bytes
//!   changed on the way);
//! - `replayed`: a valid signature whose timestamp is not after the last one taken from the same
//!   stream (link id, system, component);
//! - `stale`: the first message of a stream whose timestamp lies more than one minute behind our
//!   own (the specification's rule for new streams; a recording of an old session, or a flight
//!   controller whose signing clock is far behind this computer's).
//!
//! Our timestamp ([`Signer::sign`]) is in units of 10 µs since 2015-01-01 00:00:00 UTC (Unix time
//! 1 420 070 400 s), from the system clock, strictly increasing from one message to the next, and
//! never behind the newest timestamp of a message we took (as the specification and pymavlink
//! do), so a computer whose clock is not set still signs ahead of the flight controller. Our
//! messages go out with link id [`LINK_ID`] (0).
//!
//! The key file ([`MavlinkKey::read`]) holds the 32-byte secret key in one of three forms, told
//! apart by its length: the 32 bytes themselves; PX4's key file (40 bytes: the key, then an
//! 8-byte timestamp, which is not used); or 64 hexadecimal digits (either case, blank space around
//! them allowed). A passphrase is not read, since it could not be told from a key: convert it
//! first (MAVProxy's `signing setup PASSPHRASE` uses SHA-256 of the passphrase, i.e. the hex
//! digits `sha256sum` prints); a file that is all printable text but not 64 hex digits is taken
//! for one and refused (a random 32-byte key is all printable with a chance below 10⁻¹³). Errors and
//! `Debug` never show the key.

use std::collections::HashMap;
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use ::mavlink::consts::v2::{IFLAG_SIGNED, SIGNATURE_VALUE_SIZE};
use ::mavlink::dialects::common::MavMessage;
use ::mavlink::error::ParserError;
use ::mavlink::{MAVLinkMessageRaw, MAVLinkV2MessageRaw, MavHeader, Message};
use serde::Serialize;

/// Bytes of a secret key.
pub const KEY_LEN: usize = 32;
/// Bytes of PX4's key file (`/mavlink/mavlink-signing-key.bin` on its SD card): the key, then a
/// little-endian `u64` timestamp.
pub const PX4_KEY_FILE_LEN: usize = 40;
/// The link id our messages are signed with.
pub const LINK_ID: u8 = 0;
/// The signing epoch, 2015-01-01 00:00:00 UTC, as Unix time, s.
const EPOCH_UNIX_S: u64 = 1_420_070_400;
/// How far behind our timestamp a new stream may start, 10 µs units (one minute).
const NEW_STREAM_WINDOW: u64 = 60 * 100_000;
/// Timestamps are 48 bits.
const TIMESTAMP_MASK: u64 = (1 << 48) - 1;
/// The forms a key file may take, quoted by every error about its content.
const FORMS: &str = "a key file holds 32 raw bytes, PX4's 40-byte key file, or 64 hex digits \
                     (a passphrase: give the hex digits of its SHA-256, as MAVProxy's `signing \
                     setup` does)";

/// A 32-byte MAVLink signing key. Its `Debug` does not show it.
#[derive(Clone, PartialEq, Eq)]
pub struct MavlinkKey([u8; KEY_LEN]);

impl fmt::Debug for MavlinkKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("MavlinkKey(..)")
    }
}

/// Why a key file could not be used; never shows the key.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    /// The file could not be read.
    #[error("cannot read the MAVLink key file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The system's reason.
        source: io::Error,
    },
    /// The file's content is none of the accepted forms.
    #[error("the MAVLink key file {path}: {reason}; {FORMS}")]
    Form {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
}

impl MavlinkKey {
    /// The key of these bytes.
    pub fn from_bytes(bytes: [u8; KEY_LEN]) -> Self {
        Self(bytes)
    }

    /// The key in a key file's content (module doc for the forms); the error says what is wrong
    /// without showing the content.
    pub fn parse(content: &[u8]) -> Result<Self, String> {
        let text = std::str::from_utf8(content).ok().map(str::trim);
        if let Some(hex) = text.filter(|t| t.len() == 2 * KEY_LEN) {
            return from_hex(hex).map(Self);
        }
        let looks_like_text = content
            .iter()
            .all(|b| b.is_ascii_graphic() || b.is_ascii_whitespace());
        if looks_like_text && !content.is_empty() {
            let chars = text.map_or(content.len(), str::len);
            return Err(format!(
                "it holds {chars} characters of text, not the 64 hex digits of a key"
            ));
        }
        match content.len() {
            KEY_LEN | PX4_KEY_FILE_LEN => {
                let mut key = [0_u8; KEY_LEN];
                key.copy_from_slice(content.get(..KEY_LEN).unwrap_or_default());
                Ok(Self(key))
            }
            n => Err(format!("it holds {n} bytes")),
        }
    }

    /// The key in the file at `path`.
    pub fn read(path: &Path) -> Result<Self, KeyError> {
        let content = std::fs::read(path).map_err(|source| KeyError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&content).map_err(|reason| KeyError::Form {
            path: path.to_path_buf(),
            reason,
        })
    }
}

/// 64 hex digits as 32 bytes.
fn from_hex(hex: &str) -> Result<[u8; KEY_LEN], String> {
    let digit = |c: u8| (c as char).to_digit(16).and_then(|d| u8::try_from(d).ok());
    let mut key = [0_u8; KEY_LEN];
    for (byte, pair) in key.iter_mut().zip(hex.as_bytes().chunks_exact(2)) {
        match (
            pair.first().copied().and_then(digit),
            pair.get(1).copied().and_then(digit),
        ) {
            (Some(high), Some(low)) => *byte = high << 4 | low,
            _ => return Err("it holds 64 characters that are not all hex digits".into()),
        }
    }
    Ok(key)
}

/// What to say about the key file's permissions, when other users can read or change it (Unix;
/// `None` elsewhere, or when its permissions cannot be read).
pub fn key_file_warning(path: &Path) -> Option<String> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).ok()?.permissions().mode() & 0o777;
        (mode & 0o077 != 0).then(|| {
            format!(
                "the MAVLink key file {} can be read or changed by other users (mode {mode:03o}): \
                 `chmod 600 {}`",
                path.display(),
                path.display()
            )
        })
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// Why a received message was refused (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// No signature (MAVLink 1, or MAVLink 2 without the signed flag).
    Unsigned,
    /// The signature does not match under our key.
    BadSignature,
    /// A timestamp not after the last one of its stream.
    Replayed,
    /// A new stream starting more than a minute behind our timestamp.
    Stale,
}

/// Counts of the link's signed traffic (`stats.json`'s `mavlink_signing`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SigningCounts {
    /// Messages signed and sent.
    pub signed_out: u64,
    /// Messages received with a valid signature (passed on to the decoder).
    pub accepted: u64,
    /// Refused: no signature.
    pub unsigned: u64,
    /// Refused: a signature that does not match.
    pub bad_signature: u64,
    /// Refused: a timestamp not after its stream's last.
    pub replayed: u64,
    /// Refused: a new stream more than a minute behind our timestamp.
    pub stale: u64,
}

impl SigningCounts {
    /// Every refused message.
    pub fn refused(&self) -> u64 {
        self.unsigned + self.bad_signature + self.replayed + self.stale
    }
}

/// The timestamps: ours, and the last taken from each stream.
#[derive(Debug, Default)]
struct Clock {
    /// The last timestamp we signed with, or the newest we took, whichever is later.
    timestamp: u64,
    /// (link id, system, component) → its last timestamp taken. Only messages with a valid
    /// signature add a stream, so no sender without the key can grow it.
    streams: HashMap<(u8, u32, u8), u64>,
}

/// Signs what the link sends and checks what it receives, with one key (module doc).
#[derive(Debug)]
pub struct Signer {
    key: MavlinkKey,
    link_id: u8,
    clock: Mutex<Clock>,
    signed_out: AtomicU64,
    accepted: AtomicU64,
    unsigned: AtomicU64,
    bad_signature: AtomicU64,
    replayed: AtomicU64,
    stale: AtomicU64,
}

/// The system clock as a signing timestamp: 10 µs units since 2015-01-01 (0 before then).
pub fn timestamp_now() -> u64 {
    let since_unix = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros());
    let since_epoch = since_unix.saturating_sub(u128::from(EPOCH_UNIX_S) * 1_000_000) / 10;
    u64::try_from(since_epoch).unwrap_or(u64::MAX) & TIMESTAMP_MASK
}

impl Signer {
    /// A signer with `key`, signing with link id [`LINK_ID`].
    pub fn new(key: MavlinkKey) -> Self {
        Self::with_link_id(key, LINK_ID)
    }

    /// A signer with `key` and `link_id`.
    pub fn with_link_id(key: MavlinkKey, link_id: u8) -> Self {
        Self {
            key,
            link_id,
            clock: Mutex::new(Clock::default()),
            signed_out: AtomicU64::new(0),
            accepted: AtomicU64::new(0),
            unsigned: AtomicU64::new(0),
            bad_signature: AtomicU64::new(0),
            replayed: AtomicU64::new(0),
            stale: AtomicU64::new(0),
        }
    }

    /// The counts so far.
    pub fn counts(&self) -> SigningCounts {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        SigningCounts {
            signed_out: get(&self.signed_out),
            accepted: get(&self.accepted),
            unsigned: get(&self.unsigned),
            bad_signature: get(&self.bad_signature),
            replayed: get(&self.replayed),
            stale: get(&self.stale),
        }
    }

    fn clock(&self) -> std::sync::MutexGuard<'_, Clock> {
        // The lock guards plain numbers, valid whatever a panicking holder left.
        self.clock
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// `message` from `header` as a signed MAVLink 2 frame: its bytes are
    /// [`MAVLinkV2MessageRaw::raw_bytes`]. The timestamp is the system clock's, or one more than
    /// the last one used or taken, whichever is later.
    pub fn sign(&self, header: MavHeader, message: &MavMessage) -> MAVLinkV2MessageRaw {
        let mut clock = self.clock();
        let timestamp = timestamp_now().max(clock.timestamp.saturating_add(1)) & TIMESTAMP_MASK;
        clock.timestamp = timestamp;
        drop(clock);
        self.sign_at(header, message, timestamp)
    }

    /// Like [`Self::sign`] with a given timestamp, which moves nothing (tests).
    pub fn sign_at(
        &self,
        header: MavHeader,
        message: &MavMessage,
        timestamp: u64,
    ) -> MAVLinkV2MessageRaw {
        let mut frame = MAVLinkV2MessageRaw::new();
        frame.serialize_message_for_signing(header, message);
        *frame.signature_link_id_mut() = self.link_id;
        let bytes = (timestamp & TIMESTAMP_MASK).to_le_bytes();
        frame
            .signature_timestamp_bytes_mut()
            .copy_from_slice(bytes.get(..6).unwrap_or_default());
        let mut signature = [0_u8; SIGNATURE_VALUE_SIZE];
        frame.calculate_signature(&self.key.0, &mut signature);
        frame.signature_value_mut().copy_from_slice(&signature);
        self.signed_out.fetch_add(1, Ordering::Relaxed);
        frame
    }

    /// Checks a received frame (module doc), counting it; a frame taken moves its stream's
    /// timestamp, and ours when later.
    pub fn check(&self, frame: &MAVLinkMessageRaw) -> Result<(), Refusal> {
        let result = self.verify(frame);
        let counter = match result {
            Ok(()) => &self.accepted,
            Err(Refusal::Unsigned) => &self.unsigned,
            Err(Refusal::BadSignature) => &self.bad_signature,
            Err(Refusal::Replayed) => &self.replayed,
            Err(Refusal::Stale) => &self.stale,
        };
        counter.fetch_add(1, Ordering::Relaxed);
        result
    }

    fn verify(&self, frame: &MAVLinkMessageRaw) -> Result<(), Refusal> {
        let MAVLinkMessageRaw::V2(frame) = frame else {
            return Err(Refusal::Unsigned);
        };
        if frame.incompatibility_flags() & IFLAG_SIGNED == 0 {
            return Err(Refusal::Unsigned);
        }
        let mut signature = [0_u8; SIGNATURE_VALUE_SIZE];
        frame.calculate_signature(&self.key.0, &mut signature);
        if signature != frame.signature_value() {
            return Err(Refusal::BadSignature);
        }
        let timestamp = frame.signature_timestamp();
        let stream = (
            frame.signature_link_id(),
            frame.system_id(),
            frame.component_id(),
        );
        let mut clock = self.clock();
        match clock.streams.get(&stream) {
            Some(&last) if timestamp <= last => return Err(Refusal::Replayed),
            None => {
                let ours = clock.timestamp.max(timestamp_now());
                if timestamp.saturating_add(NEW_STREAM_WINDOW) < ours {
                    return Err(Refusal::Stale);
                }
            }
            Some(_) => {}
        }
        clock.streams.insert(stream, timestamp);
        clock.timestamp = clock.timestamp.max(timestamp);
        Ok(())
    }

    /// Checks a received frame and decodes it: `None` when refused (counted), else its header and
    /// message (or why the message cannot be decoded).
    pub fn accept(
        &self,
        frame: &MAVLinkMessageRaw,
    ) -> Option<Result<(MavHeader, MavMessage), ParserError>> {
        self.check(frame).ok()?;
        Some(decode(frame))
    }
}

/// A received frame's header and message: with `signer`, only when its signature holds (the
/// others are counted by it); `None` when refused or when its payload does not decode.
pub fn receive(
    signer: Option<&Signer>,
    frame: &MAVLinkMessageRaw,
) -> Option<(MavHeader, MavMessage)> {
    match signer {
        Some(signer) => signer.accept(frame)?.ok(),
        None => decode(frame).ok(),
    }
}

/// A raw frame's header and message.
pub fn decode(frame: &MAVLinkMessageRaw) -> Result<(MavHeader, MavMessage), ParserError> {
    let header = MavHeader {
        system_id: frame.system_id(),
        component_id: frame.component_id(),
        sequence: frame.sequence(),
    };
    let message = MavMessage::parse(frame.version(), frame.message_id(), frame.payload())?;
    Ok((header, message))
}

#[cfg(test)]
mod tests;
