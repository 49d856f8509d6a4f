//! Colours: a viridis-like map (piecewise-linear between anchor colours) for values, and a
//! qualitative palette for telling series apart.

use plotters::style::RGBColor;

/// Anchors of matplotlib's viridis at t = 0, 1/8, ..., 1 (sRGB, 0-255).
const VIRIDIS_ANCHORS: [[f64; 3]; 9] = [
    [68.0, 1.0, 84.0],
    [71.0, 44.0, 122.0],
    [59.0, 81.0, 139.0],
    [44.0, 113.0, 142.0],
    [33.0, 144.0, 141.0],
    [39.0, 173.0, 129.0],
    [92.0, 200.0, 99.0],
    [170.0, 220.0, 50.0],
    [253.0, 231.0, 37.0],
];

/// matplotlib's `tab10` qualitative palette (sRGB), in the order series are coloured.
const TAB10: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Colour of series number `index`: `tab10`, repeating after ten series.
pub(crate) fn qualitative(index: usize) -> RGBColor {
    TAB10[index % TAB10.len()]
}

/// Colour of `t` in `[0, 1]` (values outside are clamped, NaN maps to the low end).
pub(crate) fn viridis(t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = VIRIDIS_ANCHORS.len() - 1;
    let pos = t * last as f64;
    // `pos` is in [0, last], so the truncation is in range.
    let i = (pos.floor() as usize).min(last - 1);
    let f = pos - i as f64;
    let (a, b) = (VIRIDIS_ANCHORS[i], VIRIDIS_ANCHORS[i + 1]);
    let channel = |k: usize| (a[k] + f * (b[k] - a[k])).round().clamp(0.0, 255.0) as u8;
    RGBColor(channel(0), channel(1), channel(2))
}

/// Position of `v` in `[lo, hi]` as a fraction in `[0, 1]`; a flat range maps to the middle.
pub(crate) fn normalize(v: f64, lo: f64, hi: f64) -> f64 {
    // Halved so that -f64::MAX..f64::MAX does not overflow.
    let half_span = hi / 2.0 - lo / 2.0;
    if half_span > 0.0 && half_span.is_finite() {
        ((v / 2.0 - lo / 2.0) / half_span).clamp(0.0, 1.0)
    } else {
        0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_match_anchors() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
    }

    #[test]
    fn interpolates_between_anchors() {
        // Half-way between anchors 0 and 1.
        assert_eq!(viridis(1.0 / 16.0), RGBColor(70, 23, 103));
        assert_eq!(viridis(0.5), RGBColor(33, 144, 141));
    }

    #[test]
    fn brightness_increases() {
        let luma = |c: RGBColor| 0.299 * c.0 as f64 + 0.587 * c.1 as f64 + 0.114 * c.2 as f64;
        let mut prev = -1.0;
        for i in 0..=100 {
            let l = luma(viridis(i as f64 / 100.0));
            assert!(l > prev, "luma not increasing at {i}: {l} <= {prev}");
            prev = l;
        }
    }

    #[test]
    fn palette_colours_differ_and_repeat() {
        for i in 0..TAB10.len() {
            for j in 0..i {
                assert_ne!(qualitative(i), qualitative(j), "{i} and {j}");
            }
            assert_ne!(qualitative(i), RGBColor(255, 255, 255));
        }
        assert_eq!(qualitative(0), RGBColor(31, 119, 180));
        assert_eq!(qualitative(13), qualitative(3));
    }

    #[test]
    fn normalize_clamps() {
        assert_eq!(normalize(5.0, 0.0, 10.0), 0.5);
        assert_eq!(normalize(f64::INFINITY, 0.0, 10.0), 1.0);
        assert_eq!(normalize(f64::NEG_INFINITY, 0.0, 10.0), 0.0);
        assert_eq!(normalize(3.0, 3.0, 3.0), 0.5);
        assert_eq!(normalize(f64::MAX, -f64::MAX, f64::MAX), 1.0);
        assert_eq!(normalize(0.0, -f64::MAX, f64::MAX), 0.5);
    }
}
