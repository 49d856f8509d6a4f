//! A peak of the MUSIC spectrum: one candidate propagation path of one packet.

use serde::{Deserialize, Serialize};

/// One (AoA, ToF) peak of a packet's MUSIC spectrum, refined below the grid spacing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Angle of arrival in the array frame (steering-vector convention), rad.
    pub aoa_rad: f64,
    /// Time of flight after sanitization, s: relative to the packet's fitted delay, so it can be
    /// negative; comparable between the peaks of one packet, and roughly between packets.
    pub tof_s: f64,
    /// Fraction of the steering vector's energy outside the signal subspace, in [0, 1]: 0 is a
    /// perfect path, 1 is pure noise. The MUSIC pseudo-spectrum is `1 / residual` (normalized).
    pub residual: f64,
}

impl Peak {
    /// The normalized MUSIC pseudo-spectrum at the peak, dB: `−10·log10(residual)`.
    pub fn spectrum_db(&self) -> f64 {
        -10.0 * self.residual.max(1e-300).log10()
    }

    /// The AoA in degrees.
    pub fn aoa_deg(&self) -> f64 {
        self.aoa_rad.to_degrees()
    }
}
