//! A printable summary of a simulated flight: what a user checks before trusting a dataset.

use std::fmt;

use super::run::SimOutput;

/// Per-AP figures of a simulated flight.
#[derive(Clone, Debug, PartialEq)]
pub struct ApSummary {
    /// AP name.
    pub name: String,
    /// Packet slots.
    pub sent: usize,
    /// Packets with CSI.
    pub received: usize,
    /// Mean and range of the per-packet SNR over received packets, dB.
    pub snr_db: (f64, f64, f64),
    /// Range of the true direct-path AoA over received packets, degrees.
    pub aoa_deg: (f64, f64),
    /// Fraction of received packets with the AP in front of the array.
    pub in_front: f64,
    /// Fraction of received packets whose direct path the obstacle attenuates.
    pub obstructed: f64,
    /// Median Rician K factor, dB.
    pub k_factor_db: f64,
    /// CSI components clipped by the quantizer.
    pub clipped: u64,
}

/// Summary of a whole flight.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSummary {
    /// IMU samples.
    pub imu_samples: usize,
    /// Barometer samples (0 without a barometer).
    pub baro_samples: usize,
    /// Per AP.
    pub aps: Vec<ApSummary>,
}

impl SimOutput {
    /// Per-AP figures.
    pub fn summary(&self) -> SimSummary {
        let aps = self
            .aps
            .iter()
            .map(|ap| {
                let rx: Vec<_> = ap.received_records().map(|(p, _)| &p.truth).collect();
                let n = rx.len().max(1) as f64;
                let snr: Vec<f64> = rx.iter().map(|t| t.snr_db).collect();
                let aoa: Vec<f64> = rx.iter().map(|t| t.aoa_rad.to_degrees()).collect();
                let mut k: Vec<f64> = rx.iter().map(|t| t.k_factor_db).collect();
                k.sort_by(f64::total_cmp);
                ApSummary {
                    name: ap.config.name.clone(),
                    sent: ap.packets.len(),
                    received: rx.len(),
                    snr_db: (snr.iter().sum::<f64>() / n, min(&snr), max(&snr)),
                    aoa_deg: (min(&aoa), max(&aoa)),
                    in_front: rx.iter().filter(|t| t.in_front).count() as f64 / n,
                    obstructed: rx.iter().filter(|t| t.direct_obstructed).count() as f64 / n,
                    k_factor_db: k.get(k.len() / 2).copied().unwrap_or(f64::NAN),
                    clipped: rx.iter().map(|t| u64::from(t.clipped)).sum(),
                }
            })
            .collect();
        SimSummary {
            imu_samples: self.imu.len(),
            baro_samples: self.baro.len(),
            aps,
        }
    }
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

impl fmt::Display for SimSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{:<12}{} samples", "imu", self.imu_samples)?;
        if self.baro_samples > 0 {
            writeln!(f, "{:<12}{} samples", "baro", self.baro_samples)?;
        }
        for ap in &self.aps {
            writeln!(
                f,
                "{:<12}{}/{} packets received; SNR mean {:.1} dB [{:.1}, {:.1}]; AoA [{:.1}°, {:.1}°]; \
                 AP in front {:.0}%; direct path obstructed {:.0}%; median K {:.1} dB; {} clipped",
                ap.name,
                ap.received,
                ap.sent,
                ap.snr_db.0,
                ap.snr_db.1,
                ap.snr_db.2,
                ap.aoa_deg.0,
                ap.aoa_deg.1,
                100.0 * ap.in_front,
                100.0 * ap.obstructed,
                ap.k_factor_db,
                ap.clipped
            )?;
        }
        Ok(())
    }
}
