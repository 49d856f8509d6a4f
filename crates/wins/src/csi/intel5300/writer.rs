//! Encodes CSI records as byte-valid CSI Tool log records (code 0xBB), and the 0xC1 frame
//! records that name their transmitter.

use super::bfee::{pack_csi, write_header};
use super::layout::{CODE_CSI, CODE_FRAME, HEADER_LEN, LEN_FIELD, packed_csi_len};
use super::reader::MacAddress;
use super::record::CsiRecord;

/// Appends a 0xC1 frame record holding the 24-byte header of an 802.11 data frame from
/// `transmitter` (its `addr2`; `addr1` is the broadcast address, `addr3` the transmitter again).
/// The CSI Tool's logger writes such a record ahead of the CSI record of the same frame; the
/// decoders read its transmitter ([`super::StreamDecoder::transmitter`]).
pub fn encode_frame_record(transmitter: &MacAddress, out: &mut Vec<u8>) {
    const HEADER: usize = 24;
    let field_len = (1 + HEADER) as u16;
    out.extend_from_slice(&field_len.to_be_bytes());
    out.push(CODE_FRAME);
    out.extend_from_slice(&[0x08, 0x00, 0x00, 0x00]); // data frame, duration 0
    out.extend_from_slice(&[0xFF; 6]);
    out.extend_from_slice(transmitter);
    out.extend_from_slice(transmitter);
    out.extend_from_slice(&[0x00, 0x00]); // sequence control
}

/// Appends the bytes of one CSI record: the framing, the 20-byte header (reserved bytes 0) and the
/// CSI packed back into chain order (the inverse of the antenna permutation, when it was applied).
/// The record's `timestamp` and `offset` are not written: the log carries `timestamp_low` only.
pub fn encode_record(record: &CsiRecord, out: &mut Vec<u8>) {
    let h = &record.header;
    let len = packed_csi_len(h.nrx, h.ntx);
    let field_len = (1 + HEADER_LEN + len) as u16;
    out.reserve(LEN_FIELD + usize::from(field_len));
    out.extend_from_slice(&field_len.to_be_bytes());
    out.push(CODE_CSI);
    out.extend_from_slice(&write_header(h, len as u16));
    out.extend_from_slice(&pack_csi(h, record.csi()));
}
