//! `tcp:HOST:PORT`, `tcpin:HOST:PORT` and `serial:DEVICE:BAUD`: the flight controller over a
//! byte stream.
//!
//! The bytes are framed by [`super::framer`], so the garbage on a line (noise, a wrong baud rate,
//! a console sharing the port), corrupted frames and messages the dialect does not know are
//! counted ([`StreamLink::frame_counts`]) instead of skipped silently, as the mavlink crate's
//! readers do. A connection that ends (the flight controller closes it, a USB serial device
//! goes away) is counted ([`StreamLink::connections_lost`]) and the link connects again on the
//! next receive: `tcp` connects to the address again (once a second while it fails), `tcpin`
//! waits for the next client, `serial` opens the device again.
//!
//! With a signing key ([`super::signing`]) only messages whose signature holds are passed on (the
//! others are counted by the signer), and what is sent is signed.

use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::Duration;

use ::mavlink::MavHeader;
use ::mavlink::dialects::common::MavMessage;

use super::framer::{FrameCounts, Framer};
use super::signing::{Signer, receive};
use super::udp::encode;

/// A serial read returns after this long without bytes (and is tried again).
const SERIAL_READ_TIMEOUT: Duration = Duration::from_millis(100);
/// After a failed attempt to connect again, the next one waits this long.
const RECONNECT_WAIT: Duration = Duration::from_secs(1);
/// Bytes read at once.
const READ_CHUNK: usize = 4096;

/// Where the stream comes from.
#[derive(Debug)]
pub enum Endpoint {
    /// `tcp:`: connect to `HOST:PORT`.
    TcpOut(String),
    /// `tcpin:`: the flight controller (or a router) connects to us.
    TcpIn(TcpListener),
    /// `serial:`: a serial device at a baud rate.
    Serial {
        /// Device path (`/dev/ttyACM0`, `/dev/serial/by-id/…`, `COM3`).
        device: String,
        /// Baud rate, bit/s.
        baud: u32,
    },
}

type Reader = Box<dyn Read + Send>;
type Writer = Box<dyn Write + Send>;

/// The read half and what it has read.
struct Reading {
    port: Option<Reader>,
    framer: Framer,
    buffer: Vec<u8>,
    /// Whether a connection is lost and the next one is being made (not the first).
    again: bool,
}

/// A stream link (module doc).
pub struct StreamLink {
    endpoint: Endpoint,
    reading: Mutex<Reading>,
    writer: Mutex<Option<Writer>>,
    /// The framer's counts, readable while a receive blocks.
    counts: Mutex<FrameCounts>,
    sequence: AtomicU8,
    lost: AtomicU64,
    signer: Option<Arc<Signer>>,
}

impl std::fmt::Debug for StreamLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StreamLink")
            .field("endpoint", &self.endpoint)
            .finish_non_exhaustive()
    }
}

impl StreamLink {
    /// Opens the stream: `tcp` connects and `serial` opens the device now (an error says why);
    /// `tcpin` takes its client at the first receive.
    pub fn open(endpoint: Endpoint, signer: Option<Arc<Signer>>) -> io::Result<Self> {
        let link = Self {
            endpoint,
            reading: Mutex::new(Reading {
                port: None,
                framer: Framer::default(),
                buffer: vec![0; READ_CHUNK],
                again: false,
            }),
            writer: Mutex::new(None),
            counts: Mutex::new(FrameCounts::default()),
            sequence: AtomicU8::new(0),
            lost: AtomicU64::new(0),
            signer,
        };
        if !matches!(link.endpoint, Endpoint::TcpIn(_)) {
            let (reader, writer) = link.connect()?;
            link.lock_reading()?.port = Some(reader);
            *link.lock_writer()? = Some(writer);
        }
        Ok(link)
    }

    /// What the stream held, counted ([`super::framer`]).
    pub fn frame_counts(&self) -> FrameCounts {
        self.counts.lock().map(|c| *c).unwrap_or_default()
    }

    /// Connections that ended (each connected again at the next receive).
    pub fn connections_lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }

    /// Blocks until one message arrives; an error when the connection ends or cannot be made
    /// again (the next call tries again).
    pub fn recv(&self) -> io::Result<(MavHeader, MavMessage)> {
        let mut reading = self.lock_reading()?;
        loop {
            let r = &mut *reading;
            while let Some(frame) = r.framer.next_frame(false) {
                self.publish(&r.framer);
                if let Some(m) = receive(self.signer.as_deref(), &frame) {
                    return Ok(m);
                }
            }
            self.publish(&r.framer);
            let Some(port) = r.port.as_mut() else {
                match self.connect() {
                    Ok((reader, writer)) => {
                        r.port = Some(reader);
                        r.again = false;
                        *self.lock_writer()? = Some(writer);
                        continue;
                    }
                    Err(e) => {
                        if r.again {
                            thread::sleep(RECONNECT_WAIT);
                        }
                        r.again = true;
                        return Err(e);
                    }
                }
            };
            let n = match port.read(&mut r.buffer) {
                Ok(0) => Err(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "the flight controller closed the connection",
                )),
                Ok(n) => Ok(n),
                Err(e) if is_retry(&e) => continue,
                Err(e) => Err(e),
            };
            match n {
                Ok(n) => r.framer.push(r.buffer.get(..n).unwrap_or_default()),
                Err(e) => {
                    r.port = None;
                    r.again = true;
                    *self.lock_writer()? = None;
                    r.framer.finish();
                    self.publish(&r.framer);
                    self.lost.fetch_add(1, Ordering::Relaxed);
                    return Err(e);
                }
            }
        }
    }

    /// Sends one message as MAVLink 2 with `header`'s ids (the sequence is this link's), signed
    /// with a key; 0 bytes while not connected.
    pub fn send(&self, header: &MavHeader, message: &MavMessage) -> io::Result<usize> {
        let header = MavHeader {
            sequence: self.sequence.fetch_add(1, Ordering::Relaxed),
            ..*header
        };
        let bytes = encode(self.signer.as_deref(), header, message)?;
        let mut writer = self.lock_writer()?;
        let Some(w) = writer.as_mut() else {
            return Ok(0);
        };
        match w.write_all(&bytes) {
            Ok(()) => Ok(bytes.len()),
            Err(e) => {
                // The reader sees the end too, and connects again.
                *writer = None;
                Err(e)
            }
        }
    }

    /// A connection's two halves.
    fn connect(&self) -> io::Result<(Reader, Writer)> {
        match &self.endpoint {
            Endpoint::TcpOut(addr) => halves(TcpStream::connect(addr)?),
            Endpoint::TcpIn(listener) => halves(listener.accept()?.0),
            Endpoint::Serial { device, baud } => {
                let port = serialport::new(device, *baud)
                    .timeout(SERIAL_READ_TIMEOUT)
                    .open()?;
                let writer = port.try_clone()?;
                Ok((Box::new(port), Box::new(writer)))
            }
        }
    }

    fn publish(&self, framer: &Framer) {
        if let Ok(mut c) = self.counts.lock() {
            *c = framer.counts();
        }
    }

    fn lock_reading(&self) -> io::Result<MutexGuard<'_, Reading>> {
        self.reading
            .lock()
            .map_err(|_| io::Error::other("the MAVLink reader's lock is poisoned"))
    }

    fn lock_writer(&self) -> io::Result<MutexGuard<'_, Option<Writer>>> {
        self.writer
            .lock()
            .map_err(|_| io::Error::other("the MAVLink writer's lock is poisoned"))
    }
}

fn halves(stream: TcpStream) -> io::Result<(Reader, Writer)> {
    stream.set_nodelay(true)?;
    let writer = stream.try_clone()?;
    Ok((Box::new(stream), Box::new(writer)))
}

/// A read that found nothing yet (a serial timeout) or was interrupted: read again.
fn is_retry(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock
    )
}

#[cfg(test)]
mod tests;
