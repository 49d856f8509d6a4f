//! `wins csi check` on a capture of another card than the Intel 5300 (Nexmon, FeitCSI,
//! PicoScenes, Atheros), from its packets ([`crate::csi::packet`]): the file, the antennas'
//! power, the phases between neighbouring chains (stable, stepping, or, on the AX200, flipping
//! by 180° as that card does), the channel, the packets' rate and gaps, and clipping at the
//! card's integer limits. The thresholds are the 5300 check's.

use std::fmt;
use std::path::Path;

use num_complex::Complex64;
use serde::Serialize;

use super::measure::{GAP_S, spread};
use super::phases::{STABLE_IQR_DEG, STEPPED_SHARE, steady_or_moving};
use super::verdicts::{
    CHAIN_BAD_DB, CHAIN_WARN_DB, CLIPPED_BAD, CLIPPED_WARN, RATE_BAD_HZ, RATE_GOOD_HZ,
};
use super::{Finding, Verdict, finding, overall, pct, write_findings};
use crate::aoa::packet::chains_flip_sign;
use crate::csi::capture::CaptureError;
use crate::csi::format::CaptureFormat;
use crate::csi::packet::{CsiPacket, CsiPackets, read_packets};

/// The check of another card's capture.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CardCheck {
    /// The capture's format.
    pub format: CaptureFormat,
    /// Packets read.
    pub packets: usize,
    /// Every finding, in the order a user would fix them.
    pub findings: Vec<Finding>,
}

impl CardCheck {
    /// The worst verdict of the findings that could be measured.
    pub fn verdict(&self) -> Verdict {
        overall(&self.findings)
    }
}

impl fmt::Display for CardCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_findings(f, &self.findings)
    }
}

/// Checks the capture at `path` in `format`. Errors: the file cannot be read at all.
pub fn check_card(path: &Path, format: CaptureFormat) -> Result<CardCheck, CaptureError> {
    let (_, read) = read_packets(path, Some(format))?;
    let packets = &read.packets;
    let mut findings = vec![file(format, &read)];
    if !packets.is_empty() {
        findings.push(antennas(packets));
        findings.push(chain_phases(packets));
        findings.push(channel(&packets[0]));
        findings.push(rate(packets));
        findings.push(clipping(format, packets));
    }
    Ok(CardCheck {
        format,
        packets: packets.len(),
        findings,
    })
}

fn file(format: CaptureFormat, read: &CsiPackets) -> Finding {
    let skipped: u64 = read.skipped.values().sum();
    let mut measured = format!("{}: {} packets", format.describe(), read.packets.len());
    if skipped > 0 {
        let why: Vec<String> = read
            .skipped
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect();
        measured.push_str(&format!("; skipped {}", why.join(", ")));
    }
    if let Some(lost) = &read.lost {
        measured.push_str(&format!("; not read: {lost}"));
    }
    let (verdict, advice) = if read.packets.is_empty() {
        (
            Verdict::Bad,
            Some("no packet with CSI: check that the tool logged CSI (not only frames), and the format (`--format`)".to_string()),
        )
    } else if read.lost.is_some() {
        (
            Verdict::Warning,
            Some("the file is damaged or cut after the packets read: copy it again".into()),
        )
    } else {
        (Verdict::Good, None)
    };
    finding("file", verdict, measured, advice)
}

/// Each receive row's mean power over the first stream, dB under the strongest.
fn chain_power_db(packets: &[CsiPacket], rows: usize) -> Vec<f64> {
    let mut power = vec![0.0; rows];
    for p in packets.iter().filter(|p| p.num_rx() == rows) {
        for (rx, sum) in power.iter_mut().enumerate() {
            *sum += (0..p.subcarriers.len())
                .filter_map(|sc| p.at(sc, rx, 0))
                .map(|v| v.norm_sqr())
                .sum::<f64>();
        }
    }
    let strongest = power.iter().copied().fold(0.0, f64::max);
    if strongest <= 0.0 {
        return vec![f64::NEG_INFINITY; rows];
    }
    power
        .iter()
        .map(|p| 10.0 * (p / strongest).log10())
        .collect()
}

/// The receive rows most packets have, and their chains.
fn usual_rows(packets: &[CsiPacket]) -> (usize, Vec<u8>) {
    let mut counts = std::collections::BTreeMap::<usize, usize>::new();
    for p in packets {
        *counts.entry(p.num_rx()).or_default() += 1;
    }
    let rows = counts
        .iter()
        .max_by_key(|(_, n)| **n)
        .map_or(0, |(r, _)| *r);
    let chains = packets
        .iter()
        .find(|p| p.num_rx() == rows)
        .map(|p| p.chains.clone())
        .unwrap_or_default();
    (rows, chains)
}

fn antennas(packets: &[CsiPacket]) -> Finding {
    let (rows, chains) = usual_rows(packets);
    let share = packets.iter().filter(|p| p.num_rx() == rows).count() as f64 / packets.len() as f64;
    let power = chain_power_db(packets, rows);
    let parts: Vec<String> = chains
        .iter()
        .zip(&power)
        .map(|(c, p)| format!("chain {c} {p:+.1} dB"))
        .collect();
    let measured = format!(
        "{rows} chains ({}) on {} of the packets; CSI power {}",
        chains
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        pct(share),
        parts.join(", ")
    );
    let weakest = power.iter().copied().fold(0.0, f64::min);
    if power.iter().all(|p| *p == f64::NEG_INFINITY) {
        return finding(
            "antennas",
            Verdict::Bad,
            measured,
            Some("every chain's CSI is zero: the card logged no channel (check the tool's CSI setting)".into()),
        );
    }
    if rows < 2 {
        return finding(
            "antennas",
            Verdict::Bad,
            measured,
            Some("AoA compares antennas: enable at least two receive chains and connect their antennas".into()),
        );
    }
    let (verdict, advice) = if weakest < CHAIN_BAD_DB {
        (
            Verdict::Bad,
            Some(format!(
                "a chain is {:.0} dB under the strongest: check that its antenna is connected and its cable seated",
                -weakest
            )),
        )
    } else if weakest < CHAIN_WARN_DB {
        (
            Verdict::Warning,
            Some(format!(
                "a chain is {:.0} dB under the strongest: a multipath null at this spot, or a loose connector; move the receiver a few centimetres and check again",
                -weakest
            )),
        )
    } else {
        (Verdict::Good, None)
    };
    finding("antennas", verdict, measured, advice)
}

fn chain_phases(packets: &[CsiPacket]) -> Finding {
    let (rows, chains) = usual_rows(packets);
    let flips = packets.first().is_some_and(chains_flip_sign);
    let mut parts = Vec::new();
    let (mut iqr_deg, mut stepped, mut quarter) = (0.0f64, 0.0f64, 0.0f64);
    for r in 0..rows.saturating_sub(1) {
        let phases: Vec<f64> = packets
            .iter()
            .filter(|p| p.num_rx() == rows)
            .map(|p| {
                (0..p.subcarriers.len())
                    .map(|sc| {
                        p.at(sc, r + 1, 0).unwrap_or_default()
                            * p.at(sc, r, 0).unwrap_or_default().conj()
                    })
                    .sum::<Complex64>()
            })
            .filter(|z| z.norm() > 0.0)
            .map(|z| z.arg())
            .collect();
        let Some(s) = spread(&phases) else { continue };
        parts.push(format!(
            "{} − {} {:.1}° (IQR {:.1}°)",
            chains[r + 1],
            chains[r],
            s.mean_rad.to_degrees(),
            s.iqr_rad.to_degrees()
        ));
        iqr_deg = iqr_deg.max(s.iqr_rad.to_degrees());
        stepped = stepped.max(s.stepped);
        quarter = quarter.max(s.quarter_share);
    }
    let measured = parts.join(", ");
    if parts.is_empty() {
        return finding(
            "chain phases",
            Verdict::Unknown,
            "no two chains with signal".into(),
            None,
        );
    }
    if iqr_deg <= STABLE_IQR_DEG && stepped > STEPPED_SHARE {
        if flips && quarter <= STEPPED_SHARE {
            return finding(
                "chain phases",
                Verdict::Warning,
                format!(
                    "{measured}; on {} of the packets the second chain is off by 180° ({} by 90°)",
                    pct(stepped - quarter),
                    pct(quarter)
                ),
                Some("this card flips its second chain's sign from packet to packet: each angle has a twin (`wins aoa` lists it with the aliases), and only the motion tells which is right".into()),
            );
        }
        return finding(
            "chain phases",
            Verdict::Bad,
            format!("{measured}; on {} of the packets they step by multiples of 90°", pct(stepped)),
            Some("the chains' phase offsets step within the capture: AoA from these packets aliases; do not restart the card between calibration and flight".into()),
        );
    }
    steady_or_moving(measured, iqr_deg)
}

fn channel(first: &CsiPacket) -> Finding {
    match first.carrier_hz {
        Some(hz) => finding(
            "bandwidth, channel",
            Verdict::Good,
            format!(
                "{} MHz wide at {:.3} GHz, {} subcarriers",
                first.bandwidth_mhz,
                hz / 1e9,
                first.subcarriers.len()
            ),
            None,
        ),
        None => finding(
            "bandwidth, channel",
            Verdict::Unknown,
            format!(
                "{} MHz wide, {} subcarriers; the file does not say its carrier",
                first.bandwidth_mhz,
                first.subcarriers.len()
            ),
            Some(
                "give the channel (`wins aoa --channel N`): the angle scales with the wavelength"
                    .into(),
            ),
        ),
    }
}

fn rate(packets: &[CsiPacket]) -> Finding {
    let times: Vec<i64> = packets.iter().map(|p| p.clock_ns).collect();
    let gaps: Vec<f64> = times
        .windows(2)
        .map(|w| (w[1] - w[0]) as f64 * 1e-9)
        .collect();
    let span_s: f64 = gaps.iter().filter(|g| **g >= 0.0).sum();
    if packets.len() < 2 || span_s <= 0.0 {
        return finding(
            "packets",
            Verdict::Unknown,
            format!("{} packet(s): no rate", packets.len()),
            None,
        );
    }
    let rate_hz = (packets.len() - 1) as f64 / span_s;
    let longest = gaps.iter().copied().fold(0.0, f64::max);
    let long = gaps.iter().filter(|g| **g > GAP_S).count();
    let backward = gaps.iter().filter(|g| **g < 0.0).count();
    let measured = format!(
        "{rate_hz:.1} packets/s over {span_s:.1} s; longest gap {longest:.2} s, {long} gaps over {GAP_S} s, {backward} clock steps back"
    );
    let (mut verdict, mut advice) = if rate_hz >= RATE_GOOD_HZ {
        (Verdict::Good, None)
    } else if rate_hz >= RATE_BAD_HZ {
        (Verdict::Warning, Some("slow: the AoA track may lose the AP while the drone turns; 50–100 packets/s is best".to_string()))
    } else {
        (
            Verdict::Bad,
            Some(
                "too slow to track the AP in flight: raise the packet rate to 50–100 per second"
                    .to_string(),
            ),
        )
    };
    if verdict == Verdict::Good && (long > 0 || backward > 0) {
        verdict = Verdict::Warning;
        advice = Some(
            "the capture paused or its clock stepped back (a card counter wrapping, or a restart)"
                .into(),
        );
    }
    finding("packets", verdict, measured, advice)
}

/// The largest magnitude of a real or imaginary part each format can hold (`None`: floating
/// point, nothing to clip).
fn limit(format: CaptureFormat) -> Option<f64> {
    match format {
        CaptureFormat::Atheros => Some(511.0),
        CaptureFormat::FeitCsi | CaptureFormat::PicoScenes => Some(32_767.0),
        CaptureFormat::Intel5300 => Some(127.0),
        CaptureFormat::Nexmon => None,
    }
}

fn clipping(format: CaptureFormat, packets: &[CsiPacket]) -> Finding {
    let Some(max) = limit(format) else {
        return finding(
            "clipping",
            Verdict::Good,
            "floating-point CSI: nothing to clip".into(),
            None,
        );
    };
    let at = |x: f64| x >= max || x <= -max - 1.0;
    let (mut values, mut clipped) = (0u64, 0u64);
    for v in packets.iter().flat_map(|p| &p.csi) {
        values += 1;
        clipped += u64::from(at(v.re) || at(v.im));
    }
    let share = clipped as f64 / values.max(1) as f64;
    let measured = format!(
        "{} of the CSI values at the card's limit (±{max})",
        pct(share)
    );
    let verdict = if share > CLIPPED_BAD {
        Verdict::Bad
    } else if share > CLIPPED_WARN {
        Verdict::Warning
    } else {
        Verdict::Good
    };
    let advice = (verdict != Verdict::Good).then(|| {
        "the receiver is saturated: move it further from the AP, or lower the AP's power"
            .to_string()
    });
    finding("clipping", verdict, measured, advice)
}

#[cfg(test)]
mod tests {
    use num_complex::Complex64;

    use super::*;

    fn packet(value: f64, chains: usize) -> CsiPacket {
        CsiPacket {
            format: CaptureFormat::Atheros,
            offset: 0,
            clock_ns: 0,
            carrier_hz: Some(2.437e9),
            bandwidth_mhz: 20,
            spacing_hz: 312_500.0,
            subcarriers: vec![-1, 1],
            chains: (0..chains as u8).collect(),
            num_tx: 1,
            csi: vec![Complex64::new(value, 0.0); 2 * chains],
            rssi: vec![None; chains],
            transmitter: None,
            sequence: None,
        }
    }

    #[test]
    fn chains_without_any_power_are_bad_and_one_chain_is_not_an_array() {
        assert_eq!(antennas(&[packet(0.0, 3)]).verdict, Verdict::Bad);
        assert_eq!(antennas(&[packet(5.0, 3)]).verdict, Verdict::Good);
        assert_eq!(antennas(&[packet(5.0, 1)]).verdict, Verdict::Bad);
        // A packet whose values do not fill its shape gives no rows (and no panic).
        let mut short = packet(5.0, 3);
        short.csi.pop();
        assert_eq!(short.antenna_rows(0), None);
    }
}
