//! The receiver response a simulated NIC applies: the Intel 5300's measured mean
//! ([`crate::csi::intel5300::receiver_response`]), times a card's own smooth deviation from it.

use std::f64::consts::TAU;

use num_complex::Complex64;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::csi::NUM_SUBCARRIERS;
use crate::csi::intel5300::{RESPONSE_CHAINS, receiver_response};
use crate::sim::radio::ReceiverResponse;

/// RMS of a card's deviation from the measured mean response over the subcarriers: amplitude,
/// dB, and phase, degrees. The real captures' own profiles scatter about their mean by 0.2–0.9 dB
/// and 1–6° (median 0.4 dB and 1.6°), reflections included; a card's own deviation is at most
/// that, and is taken at the median.
const DEVIATION_DB: f64 = 0.4;
const DEVIATION_DEG: f64 = 1.6;

/// Cosine terms of a card's smooth deviation over the band (the response is a filter's: it
/// changes over a few subcarriers, not from one to the next).
const DEVIATION_TERMS: usize = 3;

impl ReceiverResponse {
    /// The complex factor per chain and subcarrier for one card, its deviation drawn from `rng`;
    /// `None` for [`ReceiverResponse::Flat`] (nothing is drawn then).
    pub fn factors(
        self,
        rng: &mut ChaCha8Rng,
    ) -> Option<[[Complex64; NUM_SUBCARRIERS]; RESPONSE_CHAINS]> {
        match self {
            Self::Flat => None,
            Self::Intel5300 => {
                let mean = receiver_response();
                Some(std::array::from_fn(|m| {
                    let amplitude_db = smooth_deviation(rng, DEVIATION_DB);
                    let phase_deg = smooth_deviation(rng, DEVIATION_DEG);
                    std::array::from_fn(|k| {
                        mean[m][k]
                            * Complex64::from_polar(
                                10f64.powf(amplitude_db[k] / 20.0),
                                phase_deg[k].to_radians(),
                            )
                    })
                }))
            }
        }
    }
}

/// A smooth curve over the subcarriers with RMS about `rms`: a few cosines of random amplitude
/// and phase, the `j`-th completing `j / 2` periods over the band.
fn smooth_deviation(rng: &mut ChaCha8Rng, rms: f64) -> [f64; NUM_SUBCARRIERS] {
    let terms: Vec<(f64, f64)> = (0..DEVIATION_TERMS)
        .map(|_| {
            let a: f64 = StandardNormal.sample(rng);
            (
                a * rms * (2.0 / DEVIATION_TERMS as f64).sqrt(),
                rng.random::<f64>() * TAU,
            )
        })
        .collect();
    std::array::from_fn(|k| {
        let x = k as f64 / (NUM_SUBCARRIERS - 1) as f64;
        terms
            .iter()
            .enumerate()
            .map(|(j, (a, phase))| a * (std::f64::consts::PI * (j + 1) as f64 * x + phase).cos())
            .sum()
    })
}
