//! The findings of a capture check, from its measurements, each with the threshold that decides
//! it and the reason for it.

use super::measure::{CHAINS, GAP_S, Measurements};
use super::phases;
use super::{CheckOptions, Finding, Verdict, finding, pct};
use crate::csi::intel5300::Identified;
use crate::csi::intel5300::{DEFAULT_NOISE_DBM, LogSummary};

/// A chain this far under the strongest, in CSI power over the band, is suspect: antennas a few
/// centimetres apart see the same power within a few dB, but a multipath null at one spot can
/// take one of them 10 dB down (the public lgtm captures: up to 12 dB, static, every antenna
/// connected); a missing antenna or an open connector loses 15–30 dB everywhere, dB.
pub(super) const CHAIN_WARN_DB: f64 = -8.0;
pub(super) const CHAIN_BAD_DB: f64 = -15.0;
/// Records without an RSSI reading on a chain, above this share: no signal there.
const RSSI_ZERO_BAD: f64 = 0.1;
/// SNR for AoA: MUSIC resolves the paths of a 5300's 30 subcarriers well above 20 dB; under
/// 10 dB the noise subspace swallows the weaker paths and the direct path's peak wanders, dB.
const SNR_GOOD_DB: f64 = 20.0;
const SNR_BAD_DB: f64 = 10.0;
/// Packet rates: the estimator tracks a turning drone at 50–100 packets/s; under 10 it loses
/// the AP between packets, Hz.
pub(super) const RATE_GOOD_HZ: f64 = 25.0;
pub(super) const RATE_BAD_HZ: f64 = 10.0;
/// Reports the driver counted but the log lacks, above this share.
const MISSING_WARN: f64 = 0.1;
/// CSI entries at the 8-bit limits: a few are rounding, more are a saturated receiver.
pub(super) const CLIPPED_WARN: f64 = 0.001;
pub(super) const CLIPPED_BAD: f64 = 0.01;

const CHAIN_NAMES: [&str; CHAINS] = ["A", "B", "C"];

/// Every finding, in the order a user would fix them.
pub(super) fn findings(
    summary: &LogSummary,
    m: &Measurements,
    identified: Option<&Identified>,
    options: &CheckOptions,
) -> Vec<Finding> {
    let mut out = vec![file(summary, identified)];
    if summary.csi_records == 0 {
        return out;
    }
    out.push(antennas(summary, m));
    out.push(signal(summary));
    out.push(clipping(m));
    out.push(phases::chain_phases(m));
    out.push(phases::calibration(m, options));
    out.push(bandwidth(summary, options));
    out.push(packets(summary, m));
    out
}

fn file(s: &LogSummary, identified: Option<&Identified>) -> Finding {
    let named = identified.map(Identified::describe);
    if s.csi_records == 0 {
        let what = named.unwrap_or_else(|| {
            format!(
                "no CSI record in {} bytes: not an Intel 5300 CSI Tool log",
                s.bytes
            )
        });
        let advice = match identified {
            Some(Identified::LongerCsiRecords { .. } | Identified::PrefixedRecords { .. }) => {
                "record with the Linux 802.11n CSI Tool's own log_to_file, or strip the extra \
                 bytes: wins reads the CSI Tool's layout"
            }
            _ => "give a .dat log written by the CSI Tool's log_to_file (or log_to_server)",
        };
        return finding("file", Verdict::Bad, what, Some(advice.into()));
    }
    let records = format!(
        "{} CSI records, {} other records",
        s.csi_records,
        s.non_csi_records.values().sum::<u64>()
    );
    if s.lost_bytes == 0 {
        return finding(
            "file",
            Verdict::Good,
            format!("{records}, every byte framed"),
            None,
        );
    }
    let lost = format!(
        "{records}; {} bytes in {} places do not frame as records",
        s.lost_bytes,
        s.lost.len()
    );
    let advice = match named {
        Some(n) => format!("{n}: the CSI records were recovered, the rest is lost"),
        None => "the log is damaged there (`wins csi info` lists every place); the records \
                 around it are read"
            .into(),
    };
    finding("file", Verdict::Warning, lost, Some(advice))
}

fn antennas(s: &LogSummary, m: &Measurements) -> Finding {
    let records = s.csi_records as f64;
    let three = m.three_chain_records as f64 / records;
    if three < 0.5 {
        return finding(
            "antennas",
            Verdict::Bad,
            format!(
                "{} of the records have three receive chains ({:?})",
                pct(three),
                s.chains
            ),
            Some(
                "AoA needs the three antennas: enable every receive chain (`iwconfig`/`iw` \
                  antenna settings, or the driver's rx chain mask) and connect all three"
                    .into(),
            ),
        );
    }
    let power = m.chain_power_db();
    let mut worst = (Verdict::Good, String::new());
    let mut parts = Vec::new();
    for rx in 0..CHAINS {
        let zero = m.rssi_zero[rx] as f64 / records;
        let p = power[rx].unwrap_or(f64::NEG_INFINITY);
        parts.push(format!("{} {:+.1} dB", CHAIN_NAMES[rx], p));
        let (verdict, why) = if zero > RSSI_ZERO_BAD {
            (
                Verdict::Bad,
                format!(
                    "antenna {} reads no signal on {} of the packets",
                    CHAIN_NAMES[rx],
                    pct(zero)
                ),
            )
        } else if p < CHAIN_BAD_DB {
            (
                Verdict::Bad,
                format!(
                    "antenna {} is {:.0} dB under the strongest",
                    CHAIN_NAMES[rx], -p
                ),
            )
        } else if p < CHAIN_WARN_DB {
            (
                Verdict::Warning,
                format!(
                    "antenna {} is {:.0} dB under the strongest",
                    CHAIN_NAMES[rx], -p
                ),
            )
        } else {
            continue;
        };
        if verdict > worst.0 {
            worst = (verdict, why);
        }
    }
    let measured = format!(
        "three chains on {}; CSI power {}",
        pct(three),
        parts.join(", ")
    );
    let advice = match worst.0 {
        Verdict::Good | Verdict::Unknown => None,
        Verdict::Warning => Some(format!(
            "{}: a multipath null at this spot, or a loose connector; move the receiver a few \
             centimetres and check again (a connector at fault stays low everywhere)",
            worst.1
        )),
        Verdict::Bad => Some(format!(
            "{}: check that its antenna is connected and its cable seated; AoA compares the \
             antennas' phases and needs all three",
            worst.1
        )),
    };
    finding("antennas", worst.0, measured, advice)
}

fn signal(s: &LogSummary) -> Finding {
    if s.total_rss_dbm.count == 0 {
        return finding(
            "signal",
            Verdict::Bad,
            "no record has an RSSI reading".into(),
            Some("the NIC reported no received power: the log's CSI cannot be scaled".into()),
        );
    }
    let rss = s.total_rss_dbm.mean;
    let (noise, assumed) = if s.noise_dbm.count > 0 {
        (s.noise_dbm.mean, "")
    } else {
        (DEFAULT_NOISE_DBM, ", assumed: the log reports none")
    };
    let snr = rss - noise;
    let measured = format!(
        "RSS {rss:.1} dBm (from {:.1} to {:.1}), noise {noise:.0} dBm{assumed}: SNR {snr:.0} dB",
        s.total_rss_dbm.min, s.total_rss_dbm.max
    );
    let (verdict, advice) = if snr >= SNR_GOOD_DB {
        (Verdict::Good, None)
    } else if snr >= SNR_BAD_DB {
        (
            Verdict::Warning,
            Some(
                "a weak signal: the AoA's peaks wander; move closer to the AP or raise its power"
                    .to_string(),
            ),
        )
    } else {
        (Verdict::Bad, Some("too weak for AoA: the noise hides the paths; move closer to the AP, raise its power or face the antennas to it".to_string()))
    };
    let verdict = if assumed.is_empty() || verdict == Verdict::Good {
        verdict
    } else {
        Verdict::Warning
    };
    finding("signal", verdict, measured, advice)
}

fn clipping(m: &Measurements) -> Finding {
    let share = m.clipped_entries as f64 / m.entries.max(1) as f64;
    let measured = format!(
        "{} of the CSI entries at the 8-bit limits ({} records); the AGC changed {} times",
        pct(share),
        m.clipped_records,
        m.agc_changes
    );
    let (verdict, advice) = if share <= CLIPPED_WARN {
        (Verdict::Good, None)
    } else {
        let verdict = if share <= CLIPPED_BAD {
            Verdict::Warning
        } else {
            Verdict::Bad
        };
        (verdict, Some("the receiver saturates: clipped entries bend the phases MUSIC reads; move away from the AP or lower its transmit power".to_string()))
    };
    finding("clipping", verdict, measured, advice)
}

fn bandwidth(s: &LogSummary, options: &CheckOptions) -> Finding {
    let widths: Vec<String> = s
        .bandwidth
        .iter()
        .map(|(w, n)| format!("{w}: {n}"))
        .collect();
    let channel = match options.center_freq_hz {
        Some(f) => format!("centre {:.3} GHz as given", f * 1e-9),
        None => "the channel is not recorded in a CSI Tool log".into(),
    };
    let measured = format!("{}; {channel}", widths.join(", "));
    if s.bandwidth.len() > 1 {
        return finding(
            "bandwidth, channel",
            Verdict::Warning,
            measured,
            Some("the AP changes its bandwidth: each packet's subcarriers are used as reported, but HT20 and HT40 packets see the paths at different resolutions; fix the AP's bandwidth".into()),
        );
    }
    let advice = options.center_freq_hz.is_none().then(|| {
        "name the channel in dataset.toml's [channel] (or `wins aoa --channel`): the angle scales with the wavelength".to_string()
    });
    finding("bandwidth, channel", Verdict::Good, measured, advice)
}

fn packets(s: &LogSummary, m: &Measurements) -> Finding {
    let Some(rate) = s.packet_rate_hz else {
        return finding(
            "packets",
            Verdict::Unknown,
            format!("{} record(s): no rate", s.csi_records),
            None,
        );
    };
    let missing = s.bfee_count_gaps as f64 / (s.csi_records + s.bfee_count_gaps) as f64;
    let measured = format!(
        "{rate:.1} packets/s over {:.1} s; longest gap {:.2} s, {} gaps over {GAP_S} s; {} reports missing ({}) by the driver's counter",
        s.duration_s.unwrap_or(0.0),
        m.longest_gap_s,
        m.gaps,
        s.bfee_count_gaps,
        pct(missing)
    );
    let (mut verdict, mut advice) = if rate >= RATE_GOOD_HZ {
        (Verdict::Good, None)
    } else if rate >= RATE_BAD_HZ {
        (Verdict::Warning, Some("slow: the AoA track may lose the AP while the drone turns; 50–100 packets/s is best (ping the AP, or raise its beacon or traffic rate)".to_string()))
    } else {
        (Verdict::Bad, Some("too slow to track the AP in flight: raise the packet rate to 50–100 per second (ping the AP at that rate)".to_string()))
    };
    if verdict == Verdict::Good && (missing > MISSING_WARN || m.gaps > 0) {
        verdict = Verdict::Warning;
        advice = Some("packets were lost or the capture paused: a busy channel, or the logger falling behind (log to a local file, not over a slow link)".into());
    }
    finding("packets", verdict, measured, advice)
}
