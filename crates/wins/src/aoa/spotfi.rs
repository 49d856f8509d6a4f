//! SpotFi's direct-path selection over a group of packets (Kotaru et al., "SpotFi: Decimeter Level
//! Localization Using WiFi", SIGCOMM 2015, §4.3 "Identifying the direct path"); WINS Algorithm 1
//! line 2 uses it to initialize the AoA that PAoA then tracks.
//!
//! The MUSIC peaks of all packets are clustered in (AoA, ToF) space; the direct path is the cluster
//! that is seen by many packets, is tight, and arrives first. SpotFi clusters with Gaussian means
//! (G-means); here single linkage with per-axis tolerances, which is deterministic. ToF is not
//! wrapped at the unambiguous span 1/Δf: peaks are expected in one ToF period.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::peak::Peak;
use crate::check::Problems;

/// Smallest SpotFi group: the clusters of a single packet say nothing about the direct path.
pub const MIN_GROUP_SIZE: usize = 2;

/// Default AoA linking tolerance, degrees.
const DEFAULT_AOA_TOLERANCE_DEG: f64 = 5.0;
/// Slack on the eligibility comparison so `3/10 ≥ 0.3` holds despite rounding.
const FRACTION_SLACK: f64 = 1e-9;

/// Parameters of the clustering and of SpotFi's likelihood (§4.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpotfiConfig {
    /// Two peaks are linked when their AoAs differ by at most this, rad (> 0). Default 5°.
    pub aoa_tolerance_rad: f64,
    /// ... and their ToFs differ by at most this, s (> 0). Default 10 ns.
    pub tof_tolerance_s: f64,
    /// Weight of the fraction of packets in the cluster, dimensionless. Default 4.
    pub w_count: f64,
    /// Weight of the AoA std, in units of `aoa_tolerance_rad`. Default 1.
    pub w_aoa_spread: f64,
    /// Weight of the ToF std, in units of `tof_tolerance_s`. Default 1.
    pub w_tof_spread: f64,
    /// Weight of the mean ToF above the earliest cluster, in units of `tof_scale_s`. Default 1.
    pub w_tof: f64,
    /// ToF normalization of the `w_tof` term, s (> 0). Default 50 ns.
    pub tof_scale_s: f64,
    /// Clusters seen by fewer than this fraction of the group's packets are not eligible, in
    /// [0, 1]. Default 0.3; too high for groups where the direct path is often missed.
    pub min_cluster_fraction: f64,
}

impl SpotfiConfig {
    /// Tolerances and scale finite and > 0, weights finite, the fraction in [0, 1]; every
    /// problem under `prefix`.
    pub fn problems(&self, prefix: &str) -> Problems {
        let mut p = Problems::new();
        p.positive(prefix, "aoa_tolerance_rad", self.aoa_tolerance_rad);
        p.positive(prefix, "tof_tolerance_s", self.tof_tolerance_s);
        p.positive(prefix, "tof_scale_s", self.tof_scale_s);
        for (key, w) in [
            ("w_count", self.w_count),
            ("w_aoa_spread", self.w_aoa_spread),
            ("w_tof_spread", self.w_tof_spread),
            ("w_tof", self.w_tof),
        ] {
            p.require(w.is_finite(), prefix, key, format!("{w} is not finite"));
        }
        p.in_range(
            prefix,
            "min_cluster_fraction",
            self.min_cluster_fraction,
            0.0,
            1.0,
        );
        p
    }
}

impl Default for SpotfiConfig {
    fn default() -> Self {
        Self {
            aoa_tolerance_rad: DEFAULT_AOA_TOLERANCE_DEG.to_radians(),
            tof_tolerance_s: 10e-9,
            w_count: 4.0,
            w_aoa_spread: 1.0,
            w_tof_spread: 1.0,
            w_tof: 1.0,
            tof_scale_s: 50e-9,
            min_cluster_fraction: 0.3,
        }
    }
}

/// Why no direct path could be selected.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum SpotfiError {
    /// The group has no packets.
    #[error("the packet group is empty")]
    EmptyGroup,
    /// The group's packets have no peaks at all.
    #[error("none of the {packets} packets has a MUSIC peak")]
    NoPeaks {
        /// Number of packets in the group.
        packets: usize,
    },
    /// A peak has a NaN or infinite AoA, ToF or residual.
    #[error("peak {peak} of packet {packet} is not finite")]
    NonFinitePeak {
        /// Index of the packet in the group.
        packet: usize,
        /// Index of the peak in the packet.
        peak: usize,
    },
    /// A tolerance or `tof_scale_s` is not positive, a weight is not finite, or
    /// A setting is out of range (every such setting listed).
    #[error("{0}")]
    InvalidConfig(Problems),
    /// Every cluster is seen by fewer than `min_cluster_fraction` of the packets.
    #[error("the largest cluster has {best} of {packets} packets, below the minimum fraction")]
    NoEligibleCluster {
        /// Packets contributing to the most widely seen cluster.
        best: usize,
        /// Packets in the group.
        packets: usize,
    },
}

/// One (AoA, ToF) cluster of a packet group with its SpotFi likelihood.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cluster {
    /// Mean AoA of the member peaks, rad.
    pub aoa_rad: f64,
    /// Mean ToF of the member peaks, s.
    pub tof_s: f64,
    /// Population std of the member AoAs, rad (0 for one member).
    pub aoa_spread_rad: f64,
    /// Population std of the member ToFs, s (0 for one member).
    pub tof_spread_s: f64,
    /// Number of distinct packets with a peak in the cluster.
    pub packets: usize,
    /// Number of member peaks (≥ `packets`).
    pub peaks: usize,
    /// SpotFi's ln L (see [`direct_path`]); comparable only within one group.
    pub log_likelihood: f64,
    /// Whether the cluster reaches `min_cluster_fraction` of the packets.
    pub eligible: bool,
}

/// The selected direct path of a packet group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DirectPath {
    /// Mean AoA of the chosen cluster, rad.
    pub aoa_rad: f64,
    /// Mean ToF of the chosen cluster, s.
    pub tof_s: f64,
    /// Population std of the chosen cluster's AoAs, rad.
    pub aoa_spread_rad: f64,
    /// Population std of the chosen cluster's ToFs, s.
    pub tof_spread_s: f64,
    /// Number of distinct packets contributing to the chosen cluster.
    pub packets: usize,
    /// ln L of the chosen cluster.
    pub log_likelihood: f64,
    /// `per_packet[i]`: packet i's peak in the chosen cluster (its lowest-ToF one if several),
    /// `None` if packet i has none.
    pub per_packet: Vec<Option<Peak>>,
    /// All clusters, by likelihood descending (ties: earlier ToF first); the chosen one is the
    /// first eligible.
    pub clusters: Vec<Cluster>,
}

/// Selects the direct path of a packet group, SpotFi §4.3.
///
/// `group[i]` holds the MUSIC peaks of packet i. All peaks are clustered by single linkage: two
/// peaks are linked when |ΔAoA| ≤ `aoa_tolerance_rad` and |ΔToF| ≤ `tof_tolerance_s`. Each cluster
/// scores `ln L = w_count·(n/N) − w_aoa_spread·σ_θ/aoa_tol − w_tof_spread·σ_τ/tof_tol −
/// w_tof·(τ̄ − min τ̄)/tof_scale`, with n the distinct packets of the cluster, N the group's packets
/// and min τ̄ over all clusters (a constant shift that does not change the ranking). SpotFi's
/// likelihood has the same terms with its own weights. The eligible cluster with the highest ln L
/// wins. Peak residuals are not used.
pub fn direct_path(group: &[Vec<Peak>], config: &SpotfiConfig) -> Result<DirectPath, SpotfiError> {
    validate(config)?;
    let packets = group.len();
    if packets == 0 {
        return Err(SpotfiError::EmptyGroup);
    }
    // Flatten in packet-major order: members of each cluster stay sorted by packet.
    let mut flat: Vec<(usize, Peak)> = Vec::new();
    for (packet, peaks) in group.iter().enumerate() {
        for (peak, p) in peaks.iter().enumerate() {
            if !(p.aoa_rad.is_finite() && p.tof_s.is_finite() && p.residual.is_finite()) {
                return Err(SpotfiError::NonFinitePeak { packet, peak });
            }
            flat.push((packet, *p));
        }
    }
    if flat.is_empty() {
        return Err(SpotfiError::NoPeaks { packets });
    }

    // Single linkage via union-find; sweep in AoA order so only near pairs are compared.
    let mut parent: Vec<usize> = (0..flat.len()).collect();
    let mut by_aoa: Vec<usize> = (0..flat.len()).collect();
    by_aoa.sort_by(|&a, &b| flat[a].1.aoa_rad.total_cmp(&flat[b].1.aoa_rad));
    for (k, &i) in by_aoa.iter().enumerate() {
        for &j in &by_aoa[k + 1..] {
            if flat[j].1.aoa_rad - flat[i].1.aoa_rad > config.aoa_tolerance_rad {
                break;
            }
            if (flat[j].1.tof_s - flat[i].1.tof_s).abs() <= config.tof_tolerance_s {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                parent[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    // Members per cluster, clusters in order of their first peak.
    let mut slot = vec![usize::MAX; flat.len()];
    let mut members: Vec<Vec<usize>> = Vec::new();
    for i in 0..flat.len() {
        let root = find(&mut parent, i);
        if slot[root] == usize::MAX {
            slot[root] = members.len();
            members.push(Vec::new());
        }
        members[slot[root]].push(i);
    }

    let mut clusters: Vec<(Cluster, Vec<usize>)> = members
        .into_iter()
        .map(|m| (summarize(&flat, &m, packets, config), m))
        .collect();
    let min_tof = clusters
        .iter()
        .map(|(c, _)| c.tof_s)
        .fold(f64::INFINITY, f64::min);
    for (c, _) in &mut clusters {
        c.log_likelihood = config.w_count * (c.packets as f64 / packets as f64)
            - config.w_aoa_spread * (c.aoa_spread_rad / config.aoa_tolerance_rad)
            - config.w_tof_spread * (c.tof_spread_s / config.tof_tolerance_s)
            - config.w_tof * ((c.tof_s - min_tof) / config.tof_scale_s);
    }
    clusters.sort_by(|(a, _), (b, _)| {
        b.log_likelihood
            .total_cmp(&a.log_likelihood)
            .then(a.tof_s.total_cmp(&b.tof_s))
    });

    let Some((best, best_members)) = clusters.iter().find(|(c, _)| c.eligible) else {
        let best = clusters.iter().map(|(c, _)| c.packets).max().unwrap_or(0);
        return Err(SpotfiError::NoEligibleCluster { best, packets });
    };
    let mut per_packet: Vec<Option<Peak>> = vec![None; packets];
    for &i in best_members {
        let (packet, peak) = flat[i];
        match &per_packet[packet] {
            Some(kept) if kept.tof_s <= peak.tof_s => {}
            _ => per_packet[packet] = Some(peak),
        }
    }
    Ok(DirectPath {
        aoa_rad: best.aoa_rad,
        tof_s: best.tof_s,
        aoa_spread_rad: best.aoa_spread_rad,
        tof_spread_s: best.tof_spread_s,
        packets: best.packets,
        log_likelihood: best.log_likelihood,
        per_packet,
        clusters: clusters.into_iter().map(|(c, _)| c).collect(),
    })
}

/// Checks the settings ([`SpotfiConfig::problems`]).
fn validate(c: &SpotfiConfig) -> Result<(), SpotfiError> {
    c.problems("")
        .into_result()
        .map_err(SpotfiError::InvalidConfig)
}

/// Union-find root with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Means, population stds and distinct packets of one cluster (likelihood filled in later).
fn summarize(
    flat: &[(usize, Peak)],
    members: &[usize],
    n_packets: usize,
    config: &SpotfiConfig,
) -> Cluster {
    let n = members.len() as f64;
    let mean = |f: fn(&Peak) -> f64| members.iter().map(|&i| f(&flat[i].1)).sum::<f64>() / n;
    let var = |f: fn(&Peak) -> f64, m: f64| {
        members
            .iter()
            .map(|&i| (f(&flat[i].1) - m).powi(2))
            .sum::<f64>()
            / n
    };
    let (aoa, tof) = (mean(|p| p.aoa_rad), mean(|p| p.tof_s));
    // Members are in packet order, so distinct packets = number of packet changes.
    let packets = 1 + members
        .windows(2)
        .filter(|w| flat[w[0]].0 != flat[w[1]].0)
        .count();
    Cluster {
        aoa_rad: aoa,
        tof_s: tof,
        aoa_spread_rad: var(|p| p.aoa_rad, aoa).sqrt(),
        tof_spread_s: var(|p| p.tof_s, tof).sqrt(),
        packets,
        peaks: members.len(),
        log_likelihood: 0.0,
        eligible: packets as f64 + FRACTION_SLACK >= config.min_cluster_fraction * n_packets as f64,
    }
}

#[cfg(test)]
mod tests;
