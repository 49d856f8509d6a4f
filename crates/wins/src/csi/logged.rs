//! One packet as a card's tool logs it ([`Logged`]): the record to write back in the tool's
//! format ([`LogWriter`]) and to hand to the estimator ([`Logged::into_received`]). The simulator
//! makes them for its rigs; `wins live` takes them from the CSI Tool's TCP stream and Nexmon's
//! UDP packets, and records them in the same formats.

use std::io::{self, Write};

use super::Received;
use super::atheros::{AtherosRecord, ByteOrder, encode_record as encode_atheros};
use super::feitcsi::{FeitRecord, encode_record as encode_feitcsi};
use super::format::CaptureFormat;
use super::intel5300::{CsiRecord, encode_record as encode_intel5300};
use super::nexmon::NexmonPacket;
use super::nexmon::frames::frames;
use super::nexmon::write::{encode_packet, pcap_header};
use super::packet::{CsiPacket, from_atheros, from_feitcsi, from_nexmon};

/// One packet as its card's tool logs it.
// Not boxed: most packets are Intel 5300 records, and a box would cost each an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Logged {
    /// An Intel 5300 record.
    Intel5300(CsiRecord),
    /// An Atheros CSI Tool record.
    Atheros(AtherosRecord),
    /// Nexmon's packets of one frame, one per core.
    Nexmon(Vec<NexmonPacket>),
    /// A FeitCSI record of an Intel AX200/AX210.
    FeitCsi(FeitRecord),
}

impl Logged {
    /// The format its tool writes.
    pub fn format(&self) -> CaptureFormat {
        match self {
            Self::Intel5300(_) => CaptureFormat::Intel5300,
            Self::Atheros(_) => CaptureFormat::Atheros,
            Self::Nexmon(_) => CaptureFormat::Nexmon,
            Self::FeitCsi(_) => CaptureFormat::FeitCsi,
        }
    }

    /// The Intel 5300 record, if it is one.
    pub fn intel5300(&self) -> Option<&CsiRecord> {
        match self {
            Self::Intel5300(r) => Some(r),
            Self::Atheros(_) | Self::Nexmon(_) | Self::FeitCsi(_) => None,
        }
    }

    /// Another card's record as the loader reads it, or why it cannot be one (`None` for a
    /// 5300 record).
    pub fn card_packet(&self) -> Option<Result<CsiPacket, String>> {
        match self {
            Self::Intel5300(_) => None,
            Self::Atheros(r) => Some(from_atheros(r)),
            Self::Nexmon(p) => Some(match frames(p).first() {
                Some(f) => from_nexmon(f),
                None => Err("a Nexmon frame without packets".into()),
            }),
            Self::FeitCsi(r) => Some(from_feitcsi(r)),
        }
    }

    /// What the estimator takes, or why this record cannot be it.
    pub fn into_received(self) -> Result<Received, String> {
        match self {
            Self::Intel5300(r) => Ok(Received::Intel5300(r)),
            other => other
                .card_packet()
                .unwrap_or_else(|| Err("no packet".into()))
                .map(Received::Card),
        }
    }

    /// Its time on the card's clock, ns, as the loader takes it ([`Received::nic_time_ns`]).
    pub fn nic_time_ns(&self) -> i64 {
        match self {
            Self::Intel5300(r) => r.timestamp.as_nanos(),
            Self::Atheros(r) => r.clock_ns(),
            Self::Nexmon(p) => p.first().map_or(0, |p| p.time_ns),
            Self::FeitCsi(r) => r.header.mu_clock_ns(),
        }
    }

    /// Sets its clock to `us` microseconds, as its format stores them (the 5300's and the
    /// AX200's 32-bit counters modulo 2³², a Nexmon pcap's seconds and microseconds).
    pub fn set_clock_us(&mut self, us: i64) {
        let low32 = us.rem_euclid(1 << 32) as u32;
        match self {
            Self::Intel5300(r) => r.header.timestamp_low = low32,
            Self::Atheros(r) => r.timestamp_us = us.max(0) as u64,
            Self::Nexmon(packets) => {
                let us = us.max(0);
                for p in packets {
                    p.ts_sec = (us / 1_000_000) as u32;
                    p.ts_frac = (us % 1_000_000) as u32;
                    p.time_ns = us * 1000;
                }
            }
            Self::FeitCsi(r) => r.header.mu_clock = low32,
        }
    }

    /// The count a truth pairs it by: the 5300's `bfee_count`, the other cards' 802.11 sequence
    /// number (0 for FeitCSI, whose files keep none).
    pub fn count(&self) -> u16 {
        match self {
            Self::Intel5300(r) => r.header.bfee_count,
            Self::Atheros(r) => r.sequence().unwrap_or(0),
            Self::Nexmon(p) => p.first().map_or(0, NexmonPacket::seq_num),
            Self::FeitCsi(_) => 0,
        }
    }
}

/// Appends `record` in its tool's format (a Nexmon frame's packets as pcap records, without the
/// pcap's global header).
pub fn encode(record: &Logged, out: &mut Vec<u8>) -> io::Result<()> {
    match record {
        Logged::Intel5300(r) => encode_intel5300(r, out),
        Logged::Atheros(r) => {
            encode_atheros(r, ByteOrder::Little, out).map_err(io::Error::other)?;
        }
        Logged::Nexmon(packets) => {
            for p in packets {
                encode_packet(p, out);
            }
        }
        Logged::FeitCsi(r) => encode_feitcsi(r, out),
    }
    Ok(())
}

/// Writes [`Logged`] records in their tools' formats to any `io::Write`: a 5300 `.dat` log, an
/// Atheros log (little-endian), a Nexmon pcap (its global header before the first packet), a
/// FeitCSI file.
#[derive(Debug)]
pub struct LogWriter<W: Write> {
    inner: W,
    buf: Vec<u8>,
    records: u64,
    pcap_started: bool,
}

impl<W: Write> LogWriter<W> {
    /// A writer over `inner`.
    pub fn new(inner: W) -> Self {
        Self {
            inner,
            buf: Vec::with_capacity(1024),
            records: 0,
            pcap_started: false,
        }
    }

    /// Writes one record.
    pub fn write(&mut self, record: &Logged) -> io::Result<()> {
        self.buf.clear();
        if matches!(record, Logged::Nexmon(_)) && !self.pcap_started {
            pcap_header(&mut self.buf);
            self.pcap_started = true;
        }
        encode(record, &mut self.buf)?;
        self.inner.write_all(&self.buf)?;
        self.records += 1;
        Ok(())
    }

    /// Records written so far.
    pub fn records(&self) -> u64 {
        self.records
    }

    /// Flushes and returns the inner writer.
    pub fn finish(mut self) -> io::Result<W> {
        self.inner.flush()?;
        Ok(self.inner)
    }
}
