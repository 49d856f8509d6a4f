//! When each AP's packets arrive: a nominal rate with timing jitter and random loss.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::time::{NANOS_PER_SEC, Timestamp};

/// Jitter is clipped to this fraction of the period, so packets never swap order.
const MAX_JITTER_FRACTION: f64 = 0.4;

/// One packet the AP sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PacketSlot {
    /// Reception time on the IMU clock.
    pub t: Timestamp,
    /// Whether the packet was lost (no CSI is reported for it).
    pub lost: bool,
}

/// Packet slots in `[0, duration_ns)`: the first at a random phase of the period, then one per
/// period plus N(0, σ²) jitter clipped to ±40% of the period; each lost with probability `loss`.
pub fn schedule(
    rate_hz: f64,
    jitter_s: f64,
    loss: f64,
    duration_ns: i64,
    rng: &mut ChaCha8Rng,
) -> Vec<PacketSlot> {
    let period_s = 1.0 / rate_hz;
    let phase_s = rng.random::<f64>() * period_s;
    let max_jitter_s = MAX_JITTER_FRACTION * period_s;
    let mut out = Vec::with_capacity((duration_ns as f64 * 1e-9 * rate_hz) as usize + 1);
    for n in 0u64.. {
        let z: f64 = StandardNormal.sample(rng);
        let jitter = (z * jitter_s).clamp(-max_jitter_s, max_jitter_s);
        let lost = rng.random::<f64>() < loss;
        let nominal_s = phase_s + n as f64 * period_s;
        let t_ns = ((nominal_s + jitter) * NANOS_PER_SEC as f64).round() as i64;
        if nominal_s * NANOS_PER_SEC as f64 >= duration_ns as f64 {
            break;
        }
        if (0..duration_ns).contains(&t_ns) {
            out.push(PacketSlot {
                t: Timestamp(t_ns),
                lost,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng;

    #[test]
    fn rate_loss_and_order() {
        let mut r = rng::stream(1, "packets/test");
        let slots = schedule(50.0, 0.002, 0.1, 60 * NANOS_PER_SEC, &mut r);
        assert!((2990..=3001).contains(&slots.len()), "{}", slots.len());
        assert!(slots.windows(2).all(|w| w[0].t < w[1].t));
        let lost = slots.iter().filter(|s| s.lost).count() as f64 / slots.len() as f64;
        assert!((0.08..0.12).contains(&lost), "{lost}");
        let gaps: Vec<f64> = slots
            .windows(2)
            .map(|w| w[1].t.secs_since(w[0].t))
            .collect();
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        assert!((mean - 0.02).abs() < 1e-4, "{mean}");
        let sd = (gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / gaps.len() as f64).sqrt();
        // The gap of two independent jitters has σ·√2.
        assert!((sd - 0.002 * 2f64.sqrt()).abs() < 3e-4, "{sd}");
    }

    #[test]
    fn no_jitter_no_loss_is_a_clean_comb() {
        let mut r = rng::stream(2, "packets/test");
        let slots = schedule(10.0, 0.0, 0.0, NANOS_PER_SEC, &mut r);
        assert_eq!(slots.len(), 10);
        assert!(slots.iter().all(|s| !s.lost));
        for w in slots.windows(2) {
            assert!((w[1].t.0 - w[0].t.0 - 100_000_000).abs() <= 1);
        }
    }
}
