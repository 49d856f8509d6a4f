//! The Intel 5300's own response over the band: what it multiplies every path's CSI by,
//! subcarrier by subcarrier and chain by chain, measured on real captures. The simulator applies
//! it (`sim::ReceiverResponse`) and the AoA stage divides it out (`[aoa]
//! remove_receiver_response`).
//!
//! Seven static captures of the public lgtm set (`../shared/data/intel5300/lgtm`: channel 64,
//! HT20, the transmitter 1 m away at −20°, −10°, 0° three times, +10°, +20°; `0-degrees test-5`,
//! where something moved, left out) give per chain and subcarrier:
//!
//! - the **amplitude**, `20 log₁₀|H[m, k]|` less its mean over the subcarriers, averaged over
//!   each capture's packets and then over the captures: a shape that rises to +3 dB above the
//!   band's middle and rolls off to −7 to −8 dB at its upper edge, the same in every capture
//!   (each capture's own profile, 2.3–2.8 dB RMS, is within 0.2–0.9 dB of the mean, 2.0 dB for
//!   `neg-10`, so the reflections, which change from capture to capture, are not what it is);
//! - the **phase**, `arg H[m, k]` unwrapped over the subcarriers less each packet's straight
//!   line through it (the timing offset and the common phase), averaged likewise: a bow of
//!   ±30–40° (17–21° RMS per capture, within 1–6° of the mean), chain B's flatter than A's and
//!   C's by about a quarter.
//!
//! A straight line in phase is a delay, which the AoA stage removes with the timing offset; a bow
//! is not: each path's phase over the subcarriers stops being a straight line, the smoothed
//! covariance's shifted windows stop being shifts of one another, and the error they leave
//! scales with the signal, a floor under the strongest path that white noise does not make. The
//! amplitude here is relative (normalized to unit mean power per chain, so the link budget
//! keeps its meaning). The captures are HT20 only: on an HT40 channel the same profile is laid on
//! the 30 reported subcarriers in their order (the response of the wider filter is not measured).
//! How much one card's response differs from this mean is not measured either (the captures are
//! of one card): each capture's own profile is within 0.2–0.9 dB and 1–6° RMS of the mean, and
//! that scatter, reflections included, bounds the card's own from above.

use num_complex::Complex64;

use crate::csi::NUM_SUBCARRIERS;

/// Chains measured.
pub const RESPONSE_CHAINS: usize = 3;

/// Amplitude, dB, per chain A, B, C and reported subcarrier (lowest frequency first).
const AMPLITUDE_DB: [[f64; NUM_SUBCARRIERS]; RESPONSE_CHAINS] = [
    [
        -1.28, -1.46, -1.23, -1.23, -1.25, -1.19, -1.02, -0.83, -0.90, -0.35, -0.20, 0.58, 1.34,
        1.27, 1.25, 1.63, 1.95, 2.40, 2.88, 2.78, 3.19, 2.70, 2.98, 2.54, 1.02, -0.18, -1.18,
        -3.66, -5.17, -7.39,
    ],
    [
        -0.51, -0.54, -0.12, 0.03, 0.12, 0.25, 0.45, 0.58, 0.41, 0.80, 0.82, 1.31, 1.79, 1.46,
        1.30, 1.42, 1.47, 1.67, 1.96, 1.69, 1.96, 1.36, 1.60, 1.18, -0.26, -1.34, -2.20, -4.55,
        -5.97, -8.14,
    ],
    [
        -1.53, -1.59, -1.24, -1.15, -1.11, -1.03, -0.86, -0.72, -0.87, -0.40, -0.28, 0.33, 0.99,
        0.85, 0.81, 1.17, 1.49, 1.95, 2.49, 2.46, 2.97, 2.59, 3.03, 2.76, 1.41, 0.36, -0.55, -3.00,
        -4.56, -6.79,
    ],
];

/// Phase beyond a straight line over the subcarriers, degrees, per chain and subcarrier.
const PHASE_DEG: [[f64; NUM_SUBCARRIERS]; RESPONSE_CHAINS] = [
    [
        -32.8, -28.1, -23.5, -18.9, -12.9, -8.1, -3.6, 1.5, 6.1, 11.7, 14.2, 18.0, 20.2, 21.8,
        22.6, 23.7, 25.1, 24.6, 23.6, 21.9, 14.3, 9.9, 7.2, -0.1, -6.5, -14.0, -21.1, -28.7, -32.1,
        -35.8,
    ],
    [
        -24.8, -20.7, -16.8, -13.5, -8.9, -5.7, -2.9, 0.5, 3.4, 7.7, 9.1, 12.1, 13.8, 15.1, 15.8,
        17.1, 19.0, 19.1, 18.9, 18.3, 12.1, 9.2, 8.1, 2.3, -2.8, -9.2, -15.7, -23.1, -26.9, -30.6,
    ],
    [
        -30.1, -25.7, -21.5, -17.7, -12.5, -8.6, -4.9, -0.4, 3.7, 9.1, 11.6, 15.7, 18.2, 20.1,
        21.2, 23.0, 24.9, 25.0, 24.7, 23.6, 16.6, 12.6, 10.1, 2.7, -4.1, -12.5, -20.8, -29.8,
        -34.8, -39.2,
    ],
];

/// The measured response per chain A, B, C and reported subcarrier (lowest frequency first), unit
/// mean power per chain (module docs); computed once.
pub fn receiver_response() -> &'static [[Complex64; NUM_SUBCARRIERS]; RESPONSE_CHAINS] {
    static RESPONSE: std::sync::LazyLock<[[Complex64; NUM_SUBCARRIERS]; RESPONSE_CHAINS]> =
        std::sync::LazyLock::new(|| {
            std::array::from_fn(|m| {
                let linear: [f64; NUM_SUBCARRIERS] =
                    AMPLITUDE_DB[m].map(|db| 10f64.powf(db / 20.0));
                let power = linear.iter().map(|a| a * a).sum::<f64>() / NUM_SUBCARRIERS as f64;
                std::array::from_fn(|k| {
                    Complex64::from_polar(linear[k] / power.sqrt(), PHASE_DEG[m][k].to_radians())
                })
            })
        });
    &RESPONSE
}
