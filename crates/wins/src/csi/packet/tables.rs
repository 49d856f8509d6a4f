//! Which subcarriers a card's CSI values belong to. No file but the Intel 5300's says; these are
//! the standard occupied tone sets, in ascending order, as each folder's README in
//! `../shared/data` documents them for its card. Pilot tones are dropped where the card reports
//! them as copies (the AX200's firmware before version 83 repeats two values over its four HT
//! pilots, as the vendor's parser notes).

/// Subcarrier spacing of 802.11a/g/n/ac, Hz.
pub const LEGACY_SPACING_HZ: f64 = 312_500.0;
/// Subcarrier spacing of 802.11ax/be, Hz.
pub const HE_SPACING_HZ: f64 = 78_125.0;

/// The indices `-hi..=-lo` and `lo..=hi`, ascending.
fn symmetric(lo: i32, hi: i32) -> Vec<i32> {
    (-hi..=-lo).chain(lo..=hi).collect()
}

/// The subcarriers of `tones` values of an Atheros CSI Tool record: HT20 56 (±1…±28) or HT40
/// 114 (±2…±58).
pub fn atheros(tones: usize) -> Option<Vec<i32>> {
    match tones {
        56 => Some(symmetric(1, 28)),
        114 => Some(symmetric(2, 58)),
        _ => None,
    }
}

/// The pilots of a legacy-spaced 20 MHz channel.
const PILOTS_20: [i32; 4] = [-21, -7, 7, 21];

/// The subcarriers of `tones` values of an Intel AX200/AX210 (FeitCSI, PicoScenes), and which
/// positions to keep: non-HT 52 (±1…±26), HT20 56 (±1…±28) or HT40 114 (±2…±58) with the 20 MHz
/// pilots dropped (they repeat), VHT80/HE20 242 (±2…±122), HE40 484 (±3…±244), HE80 996
/// (±3…±500).
pub fn intel_ax(tones: usize) -> Option<Vec<i32>> {
    match tones {
        52 => Some(symmetric(1, 26)),
        56 => Some(symmetric(1, 28)),
        114 => Some(symmetric(2, 58)),
        242 => Some(symmetric(2, 122)),
        484 => Some(symmetric(3, 244)),
        996 => Some(symmetric(3, 500)),
        _ => None,
    }
}

/// Whether the AX200's value at subcarrier `k` of a `tones`-value report is a pilot copy.
pub fn intel_ax_pilot(tones: usize, k: i32) -> bool {
    matches!(tones, 52 | 56) && PILOTS_20.contains(&k)
}

/// The subcarrier of FFT bin `bin` of `bins` (bin k is subcarrier k below half the bins,
/// k − bins above), and whether Nexmon's CSI there is of an occupied tone: ±1…±28 at 20 MHz,
/// ±2…±58 at 40 MHz, ±2…±122 at 80 MHz (the DC bins and the guard bins hold small junk values).
pub fn nexmon_bin(bin: usize, bins: usize) -> Option<i32> {
    let k = if bin < bins / 2 {
        bin as i32
    } else {
        bin as i32 - bins as i32
    };
    let (lo, hi) = match bins {
        64 => (1, 28),
        128 => (2, 58),
        256 => (2, 122),
        _ => return None,
    };
    (lo..=hi).contains(&k.abs()).then_some(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_sets_have_the_counts_of_their_formats() {
        for (tones, first, last) in [(56, -28, 28), (114, -58, 58)] {
            let s = atheros(tones).unwrap();
            assert_eq!((s.len(), s[0], s[tones - 1]), (tones, first, last));
        }
        for tones in [52, 56, 114, 242, 484, 996] {
            let s = intel_ax(tones).unwrap();
            assert_eq!(s.len(), tones);
            assert!(s.windows(2).all(|w| w[0] < w[1]) && !s.contains(&0));
        }
        assert_eq!(intel_ax(30), None);
        let kept: Vec<i32> = (0..64).filter_map(|b| nexmon_bin(b, 64)).collect();
        assert_eq!(kept.len(), 56);
        assert_eq!(nexmon_bin(63, 64), Some(-1));
        assert_eq!(nexmon_bin(0, 64), None);
        assert_eq!((0..256).filter_map(|b| nexmon_bin(b, 256)).count(), 242);
    }
}
