//! The CSI words of a BCM4366c0 (and the other chips nexmon_csi's `unpack_float.c` decodes):
//! per word, the real and imaginary parts as sign + 11-bit magnitude, and one shared 6-bit
//! exponent. Two readings: with autoscale (`unpack_float.c` with `autoscale = 1`, as csiread and
//! the muTrack MATLAB decode: each packet scaled so its largest value has 10 bits), and exact
//! (`±m · 2^(e + 42)`, as nexcsi and nexmon_csi's MATLAB since 2020 decode; f64 holds these
//! exactly, an 11-bit mantissa times a power of two).

use num_complex::Complex;

/// Bits of the magnitude of a part.
const MANTISSA_BITS: u32 = 11;
/// Bits of the shared exponent.
const EXPONENT_BITS: u32 = 6;
/// Autoscale: the largest value gets this many bits (`nbits` of `unpack_float.c`).
const AUTOSCALE_BITS: i32 = 10;
/// Autoscale: a value shifted right by more than this is zero (`-nman - 1` of `unpack_float.c`).
const AUTOSCALE_ZERO: i32 = -12;
/// The exact reading's exponent offset (the chip's fixed point).
const EXACT_SHIFT: i32 = 42;

/// One word's fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Word {
    re: u32,
    im: u32,
    re_negative: bool,
    im_negative: bool,
    exponent: i32,
}

fn word(w: u32) -> Word {
    let mask = (1 << MANTISSA_BITS) - 1;
    let e = (w & ((1 << EXPONENT_BITS) - 1)) as i32;
    Word {
        re: (w >> (EXPONENT_BITS + MANTISSA_BITS + 1)) & mask,
        im: (w >> EXPONENT_BITS) & mask,
        re_negative: w & (1 << 29) != 0,
        im_negative: w & (1 << 17) != 0,
        exponent: if e >= 32 { e - 64 } else { e },
    }
}

/// The autoscaled values of a packet's `words` and the shift applied (`shft`, csiread's
/// `float_shift`): `shft = 10 − maxbit`, `maxbit` the largest `e + ⌊log₂(re | im)⌋` over the
/// words with a nonzero magnitude; each part is `±m · 2^(e + shft)` rounded toward zero as
/// `unpack_float.c` shifts it, and zero below `2^(−12)`.
pub fn autoscaled(words: &[u32]) -> (Vec<Complex<i64>>, i32) {
    let fields: Vec<Word> = words.iter().map(|&w| word(w)).collect();
    let maxbit = fields
        .iter()
        .filter(|f| (f.re | f.im) != 0)
        .map(|f| f.exponent + (31 - (f.re | f.im).leading_zeros()) as i32)
        .max()
        .unwrap_or(-32);
    let shift = AUTOSCALE_BITS - maxbit;
    let part = |m: u32, negative: bool, e: i32| -> i64 {
        let k = e + shift;
        let v = if k < AUTOSCALE_ZERO {
            0
        } else if k < 0 {
            i64::from(m >> (-k).min(31))
        } else {
            i64::from(m).checked_shl(k as u32).unwrap_or(0)
        };
        if negative { -v } else { v }
    };
    let values = fields
        .iter()
        .map(|f| {
            Complex::new(
                part(f.re, f.re_negative, f.exponent),
                part(f.im, f.im_negative, f.exponent),
            )
        })
        .collect();
    (values, shift)
}

/// The exact values of `words`: `±m · 2^(e + 42)`.
pub fn exact(words: &[u32]) -> Vec<Complex<f64>> {
    words
        .iter()
        .map(|&w| {
            let f = word(w);
            let scale = 2f64.powi(f.exponent + EXACT_SHIFT);
            let part = |m: u32, negative: bool| {
                let v = f64::from(m) * scale;
                if negative { -v } else { v }
            };
            Complex::new(part(f.re, f.re_negative), part(f.im, f.im_negative))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A word of re `re`, im `im` (signed magnitudes below 2¹¹) and exponent `e` (−32…31).
    fn pack(re: i32, im: i32, e: i32) -> u32 {
        let mut w = (e.rem_euclid(64)) as u32;
        w |= (im.unsigned_abs() & 0x7ff) << 6;
        w |= (re.unsigned_abs() & 0x7ff) << 18;
        if re < 0 {
            w |= 1 << 29;
        }
        if im < 0 {
            w |= 1 << 17;
        }
        w
    }

    #[test]
    fn the_fields_are_where_unpack_float_reads_them() {
        let words = [pack(-5, 7, -3), pack(1023, -1, 4)];
        let exact = exact(&words);
        assert_eq!(
            exact[0],
            Complex::new(-5.0 * 2f64.powi(39), 7.0 * 2f64.powi(39))
        );
        assert_eq!(
            exact[1],
            Complex::new(1023.0 * 2f64.powi(46), -(2f64.powi(46)))
        );
        // The largest value: 1023 at e = 4, ⌊log₂ 1023⌋ = 9, maxbit 13, shift −3.
        let (values, shift) = autoscaled(&words);
        assert_eq!(shift, -3);
        assert_eq!(values[1], Complex::new(1023 << 1, -2));
        // 5 · 2^(−6) and 7 · 2^(−6) truncate to zero; a part 13 below is zero too.
        assert_eq!(values[0], Complex::new(0, 0));
        let (values, _) = autoscaled(&[pack(1023, 0, 20), pack(2047, 2047, 0)]);
        assert_eq!(values[1], Complex::new(0, 0));
        assert_eq!(autoscaled(&[]).1, 42);
    }
}
