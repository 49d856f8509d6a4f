//! A capture's packets written out for other tools: JSON Lines, one object per packet (its
//! fields, and the CSI as `[subcarrier][chain][stream]` of `[re, im]`), or a long CSV, one row
//! per value (`packet,offset,clock_ns,subcarrier,chain,stream,re,im`), which pandas and
//! spreadsheets read as it is.

use std::io::Write;

use serde::Serialize;

use super::CsiPacket;
use crate::csi::report::mac;

/// One packet as a JSON line.
#[derive(Serialize)]
struct PacketLine<'a> {
    index: usize,
    format: &'static str,
    offset: u64,
    clock_ns: i64,
    carrier_hz: Option<f64>,
    bandwidth_mhz: u32,
    spacing_hz: f64,
    subcarriers: &'a [i32],
    chains: &'a [u8],
    num_tx: usize,
    rssi: &'a [Option<f64>],
    transmitter: Option<String>,
    sequence: Option<u16>,
    csi: Vec<Vec<Vec<[f64; 2]>>>,
}

/// Writes `packets` as JSON Lines to `out`.
pub fn write_jsonl(packets: &[CsiPacket], mut out: impl Write) -> std::io::Result<()> {
    for (index, p) in packets.iter().enumerate() {
        let csi = (0..p.subcarriers.len())
            .map(|sc| {
                (0..p.num_rx())
                    .map(|rx| {
                        (0..p.num_tx)
                            .map(|tx| {
                                let v = p.at(sc, rx, tx).unwrap_or_default();
                                [v.re, v.im]
                            })
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let line = PacketLine {
            index,
            format: p.format.name(),
            offset: p.offset,
            clock_ns: p.clock_ns,
            carrier_hz: p.carrier_hz,
            bandwidth_mhz: p.bandwidth_mhz,
            spacing_hz: p.spacing_hz,
            subcarriers: &p.subcarriers,
            chains: &p.chains,
            num_tx: p.num_tx,
            rssi: &p.rssi,
            transmitter: p.transmitter.as_ref().map(mac),
            sequence: p.sequence,
            csi,
        };
        serde_json::to_writer(&mut out, &line)?;
        writeln!(out)?;
    }
    out.flush()
}

/// Writes `packets` as a long CSV to `out`: one row per value, the chain as the card numbers it.
pub fn write_csv(packets: &[CsiPacket], mut out: impl Write) -> std::io::Result<()> {
    writeln!(out, "packet,offset,clock_ns,subcarrier,chain,stream,re,im")?;
    for (index, p) in packets.iter().enumerate() {
        for (sc, k) in p.subcarriers.iter().enumerate() {
            for (rx, chain) in p.chains.iter().enumerate() {
                for tx in 0..p.num_tx {
                    let v = p.at(sc, rx, tx).unwrap_or_default();
                    writeln!(
                        out,
                        "{index},{},{},{k},{chain},{tx},{},{}",
                        p.offset, p.clock_ns, v.re, v.im
                    )?;
                }
            }
        }
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use num_complex::Complex64;

    use super::*;
    use crate::csi::format::CaptureFormat;

    fn packet() -> CsiPacket {
        CsiPacket {
            format: CaptureFormat::Atheros,
            offset: 7,
            clock_ns: 1000,
            carrier_hz: Some(2.437e9),
            bandwidth_mhz: 20,
            spacing_hz: 312_500.0,
            subcarriers: vec![-1, 1],
            chains: vec![0, 2],
            num_tx: 1,
            csi: (0..4).map(|i| Complex64::new(f64::from(i), -1.0)).collect(),
            rssi: vec![Some(40.0), None],
            transmitter: Some([1, 2, 3, 4, 5, 0xab]),
            sequence: Some(9),
        }
    }

    #[test]
    fn a_packet_is_written_as_one_json_line_and_one_csv_row_per_value() {
        let mut jsonl = Vec::new();
        write_jsonl(&[packet()], &mut jsonl).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&jsonl).unwrap();
        assert_eq!(v["transmitter"], "01:02:03:04:05:ab");
        // Subcarrier 1 (row 1), chain row 1 (chain 2): value 3.
        assert_eq!(v["csi"][1][1][0], serde_json::json!([3.0, -1.0]));
        let mut csv = Vec::new();
        write_csv(&[packet()], &mut csv).unwrap();
        let text = String::from_utf8(csv).unwrap();
        assert_eq!(text.lines().count(), 5);
        assert_eq!(text.lines().nth(4), Some("0,7,1000,1,2,0,3,-1"));
    }
}
