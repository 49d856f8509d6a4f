//! The Intel 5300 "Linux 802.11n CSI Tool" log format (Halperin et al., CCR 2011): reader, streaming
//! decoder and writer.
//!
//! A log (`log_to_file`) or live stream (`log_to_server`, port 8090) is a sequence of records
//! `[u16 big-endian length][code byte][payload]`, the length counting the code and payload. Code
//! 0xBB carries CSI: a 20-byte little-endian header ([`BfeeHeader`]) and `60·nrx·ntx + 12` bytes of
//! bit-packed CSI (per subcarrier 3 pad bits, then `nrx·ntx` signed 8-bit (real, imag) pairs). Other
//! codes (0xC1: frame records) are skipped and counted. `nrx` and `ntx` change from record to
//! record in real logs.
//!
//! Decoded CSI follows `read_bf_file.m`: `[tx][rx][subcarrier]` with the antenna permutation applied
//! when valid ([`Perm`]); [`CsiRecord::scaled_csi`] follows `get_scaled_csi.m`. Corrupt input never
//! panics and never vanishes: every byte of a log is either in a record or in a [`Skip`] with its
//! offset and reason.
//!
//! ```
//! use wins::csi::intel5300::{BfeeHeader, CsiLog, CsiRecord, encode_record};
//! use wins::time::Timestamp;
//! use num_complex::Complex;
//!
//! let header = BfeeHeader { nrx: 3, ntx: 1, rssi: [40, 38, 35], agc: 30, ..Default::default() };
//! let csi = vec![Complex::new(7i8, -3); header.num_entries()];
//! let record = CsiRecord::new(header, &csi, Timestamp(0)).unwrap();
//! let mut bytes = Vec::new();
//! encode_record(&record, &mut bytes);
//! let log = CsiLog::from_bytes(&bytes);
//! assert_eq!(log.records[0].csi(), &csi[..]);
//! assert!(log.skips.is_empty());
//! ```

mod bfee;
mod columns;
mod export;
mod framing;
mod identify;
mod layout;
mod rate;
mod reader;
mod record;
mod response;
mod summary;
mod writer;

pub use bfee::unpack_reference;
pub use columns::CsiColumns;
pub use export::{ExportFormat, ExportStats, export};
pub use framing::{FramingError, MAX_UNFRAMED, Skip, SkipReason};
pub use identify::{Identified, identify, identify_bytes, looks_like_csi_tool, why_no_records};
pub use layout::{CODE_CSI, CODE_FRAME, CSI_PREFIX, HEADER_LEN, LEN_FIELD, packed_csi_len};
pub use rate::{Modulation, RateFlags};
pub use reader::{
    CsiLog, Event, LogReader, MacAddress, ReadError, SliceDecoder, StreamDecoder, read_log,
};
pub use record::{
    BfeeHeader, CsiRecord, DEFAULT_NOISE_DBM, MAX_CHAINS, MAX_ENTRIES, NOISE_UNKNOWN_DBM, Perm,
    RSSI_TO_DBM_OFFSET, ScaleError, ShapeError,
};
pub use response::{RESPONSE_CHAINS, receiver_response};
pub use summary::{LogSummary, Stats};
pub use writer::{encode_frame_record, encode_record};
