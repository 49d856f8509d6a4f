//! Input checks and axis ranges for [`XyPlot`], done once before any drawing.

use std::ops::Range;

use crate::{PlotError, ShapeProblem, XyPlot};

/// Margin on each side of the data, as a fraction of its span.
const MARGIN_FRACTION: f64 = 0.05;
/// Half-width of the range around a flat coordinate, as a fraction of its magnitude.
const FLAT_HALF_FRACTION: f64 = 0.05;
/// Half-width of the range around a flat coordinate at zero (or subnormal).
const FLAT_HALF_AT_ZERO: f64 = 1.0;

/// The x and y ranges of the axes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Axes {
    /// Horizontal range, `start < end`, both finite with a finite span.
    pub x: Range<f64>,
    /// Vertical range, `start < end`, both finite with a finite span.
    pub y: Range<f64>,
}

/// Smallest and largest finite value seen along one axis (`lo > hi` while empty).
#[derive(Debug, Clone, Copy)]
struct Extent {
    lo: f64,
    hi: f64,
}

impl Extent {
    const EMPTY: Self = Self {
        lo: f64::INFINITY,
        hi: f64::NEG_INFINITY,
    };

    fn add(&mut self, v: f64) {
        self.lo = self.lo.min(v);
        self.hi = self.hi.max(v);
    }
}

fn shape(field: &'static str, problem: ShapeProblem) -> PlotError {
    PlotError::Shape { field, problem }
}

/// `r` if both ends and its span are finite, else [`ShapeProblem::RangeTooWide`].
fn finite_range(field: &'static str, r: Range<f64>) -> Result<Range<f64>, PlotError> {
    if r.start.is_finite() && r.end.is_finite() && (r.end - r.start).is_finite() {
        Ok(r)
    } else {
        Err(shape(field, ShapeProblem::RangeTooWide))
    }
}

/// The range shown for finite values in `lo..=hi`: a margin on both sides, or a band around
/// a flat value.
fn padded(field: &'static str, lo: f64, hi: f64) -> Result<Range<f64>, PlotError> {
    let (start, end) = if hi > lo {
        // Halves first so that a span near f64::MAX does not overflow.
        let margin = (hi / 2.0 - lo / 2.0) * (2.0 * MARGIN_FRACTION);
        (lo - margin, hi + margin)
    } else {
        let half = if lo.abs() >= f64::MIN_POSITIVE {
            lo.abs() * FLAT_HALF_FRACTION
        } else {
            FLAT_HALF_AT_ZERO
        };
        (lo - half, lo + half)
    };
    finite_range(field, start..end)
}

/// Checks every field of `plot` and returns the axis ranges (before any equal-aspect widening).
pub(crate) fn check(plot: &XyPlot) -> Result<Axes, PlotError> {
    if let Some(index) = plot
        .markers
        .iter()
        .position(|m| !(m.x.is_finite() && m.y.is_finite()))
    {
        return Err(shape("markers", ShapeProblem::NonFinite { index }));
    }
    if let Some(index) = plot.vertical_lines.iter().position(|v| !v.x.is_finite()) {
        return Err(shape("vertical_lines", ShapeProblem::NonFinite { index }));
    }
    let (mut x, mut y) = (Extent::EMPTY, Extent::EMPTY);
    let series_points = plot.series.iter().flat_map(|s| s.points.iter().copied());
    let marker_points = plot.markers.iter().map(|m| (m.x, m.y));
    for (px, py) in series_points.chain(marker_points) {
        if px.is_finite() && py.is_finite() {
            x.add(px);
            y.add(py);
        }
    }
    if x.lo > x.hi {
        return Err(shape("series", ShapeProblem::NoFiniteValue));
    }
    for v in plot.vertical_lines {
        x.add(v.x);
    }
    Ok(Axes {
        x: padded("x", x.lo, x.hi)?,
        y: padded("y", y.lo, y.hi)?,
    })
}

/// Widens one range of `axes` so that a data unit spans as many pixels on x as on y, given
/// the pixel lengths `x_px`, `y_px` the ranges are mapped onto. Ranges are kept centred.
pub(crate) fn equalize(axes: &Axes, x_px: u32, y_px: u32) -> Result<Axes, PlotError> {
    if x_px == 0 || y_px == 0 {
        return Ok(axes.clone());
    }
    let (x_px, y_px) = (f64::from(x_px), f64::from(y_px));
    let per_px_x = (axes.x.end - axes.x.start) / x_px;
    let per_px_y = (axes.y.end - axes.y.start) / y_px;
    let widen = |field, r: &Range<f64>, px: f64, per_px: f64| {
        let centre = r.start / 2.0 + r.end / 2.0;
        let half = per_px * px / 2.0;
        finite_range(
            field,
            (centre - half).min(r.start)..(centre + half).max(r.end),
        )
    };
    if per_px_x < per_px_y {
        Ok(Axes {
            x: widen("x", &axes.x, x_px, per_px_y)?,
            y: axes.y.clone(),
        })
    } else {
        Ok(Axes {
            x: axes.x.clone(),
            y: widen("y", &axes.y, y_px, per_px_x)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Marker, MarkerStyle, Series, SeriesStyle, VerticalLine};

    fn plot<'a>(
        series: &'a [Series<'a>],
        markers: &'a [Marker<'a>],
        vertical_lines: &'a [VerticalLine<'a>],
    ) -> XyPlot<'a> {
        XyPlot {
            title: "t",
            x_label: "x",
            y_label: "y",
            series,
            markers,
            vertical_lines,
            equal_aspect: false,
        }
    }

    fn line(points: &[(f64, f64)]) -> Series<'_> {
        Series {
            label: "",
            points,
            style: SeriesStyle::Line,
        }
    }

    fn problem(r: Result<Axes, PlotError>) -> (&'static str, ShapeProblem) {
        match r {
            Err(PlotError::Shape { field, problem }) => (field, problem),
            other => panic!("expected a shape error, got {other:?}"),
        }
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
    }

    fn close_range(r: &Range<f64>, start: f64, end: f64) -> bool {
        close(r.start, start) && close(r.end, end)
    }

    fn axes(x: Range<f64>, y: Range<f64>) -> Axes {
        Axes { x, y }
    }

    fn marker(x: f64, y: f64) -> Marker<'static> {
        let style = MarkerStyle::Cross;
        Marker {
            x,
            y,
            label: "",
            style,
        }
    }

    #[test]
    fn ranges_cover_finite_points_markers_and_lines_with_a_margin() {
        let pts = [
            (0.0, 10.0),
            (f64::NAN, 1e9),
            (2.0, f64::INFINITY),
            (4.0, 20.0),
        ];
        let m = [marker(1.0, 30.0)];
        let v = [VerticalLine { x: -6.0, label: "" }];
        let axes = check(&plot(&[line(&pts)], &m, &v)).unwrap();
        // x: -6..4 (the vertical line), y: 10..30 (the marker); NaN/inf points ignored.
        assert!(close_range(&axes.x, -6.5, 4.5), "{axes:?}");
        assert!(close_range(&axes.y, 9.0, 31.0), "{axes:?}");
    }

    #[test]
    fn flat_data_gets_a_non_empty_range() {
        let axes = check(&plot(&[line(&[(3.0, 0.0)])], &[], &[])).unwrap();
        assert!(close_range(&axes.x, 2.85, 3.15), "{axes:?}");
        assert_eq!(axes.y, -1.0..1.0);
        let sub = check(&plot(&[line(&[(5e-324, -1e300)])], &[], &[])).unwrap();
        assert_eq!(sub.x, (5e-324 - 1.0)..(5e-324 + 1.0));
        assert!(sub.y.start < -1e300 && sub.y.end > -1e300);
    }

    #[test]
    fn nothing_finite_is_rejected() {
        let r = check(&plot(&[], &[], &[]));
        assert_eq!(problem(r), ("series", ShapeProblem::NoFiniteValue));
        let nan = [(f64::NAN, 0.0), (1.0, f64::NEG_INFINITY)];
        let v = [VerticalLine { x: 1.0, label: "" }];
        let r = check(&plot(&[line(&nan), line(&[])], &[], &v));
        assert_eq!(problem(r), ("series", ShapeProblem::NoFiniteValue));
    }

    #[test]
    fn non_finite_markers_and_lines_are_rejected() {
        let pts = [(0.0, 0.0)];
        let m = [marker(0.0, 1.0), marker(0.0, f64::NAN)];
        let r = check(&plot(&[line(&pts)], &m, &[]));
        assert_eq!(
            problem(r),
            ("markers", ShapeProblem::NonFinite { index: 1 })
        );
        let v = [VerticalLine {
            x: f64::INFINITY,
            label: "",
        }];
        let r = check(&plot(&[line(&pts)], &[], &v));
        assert_eq!(
            problem(r),
            ("vertical_lines", ShapeProblem::NonFinite { index: 0 })
        );
    }

    #[test]
    fn overflowing_ranges_are_rejected() {
        let r = check(&plot(
            &[line(&[(-f64::MAX, 0.0), (f64::MAX, 0.0)])],
            &[],
            &[],
        ));
        assert_eq!(problem(r), ("x", ShapeProblem::RangeTooWide));
        let r = check(&plot(&[line(&[(0.0, f64::MAX)])], &[], &[]));
        assert_eq!(problem(r), ("y", ShapeProblem::RangeTooWide));
        let r = equalize(&axes(0.0..1.0, -1e307..1e307), 4000, 10);
        assert_eq!(problem(r), ("x", ShapeProblem::RangeTooWide));
    }

    #[test]
    fn equalize_matches_units_per_pixel_and_keeps_the_data() {
        for (given, x_px, y_px) in [
            (axes(0.0..10.0, -1.0..1.0), 400, 300),
            (axes(0.0..1.0, 5.0..25.0), 400, 300),
            (axes(-3.0..3.0, -2.0..2.0), 150, 100),
        ] {
            let eq = equalize(&given, x_px, y_px).unwrap();
            let per_px_x = (eq.x.end - eq.x.start) / f64::from(x_px);
            let per_px_y = (eq.y.end - eq.y.start) / f64::from(y_px);
            assert!(
                close(per_px_x, per_px_y),
                "{eq:?}: {per_px_x} vs {per_px_y}"
            );
            let (x, y) = (&given.x, &given.y);
            assert!(eq.x.start <= x.start && eq.x.end >= x.end, "{eq:?}");
            assert!(eq.y.start <= y.start && eq.y.end >= y.end, "{eq:?}");
            // Centres unchanged.
            assert!(close(eq.x.start + eq.x.end, x.start + x.end));
            assert!(close(eq.y.start + eq.y.end, y.start + y.end));
        }
        let wide = axes(0.0..10.0, -1.0..1.0);
        assert_eq!(equalize(&wide, 400, 300).unwrap().x, wide.x);
        assert_eq!(equalize(&wide, 0, 300).unwrap(), wide);
    }
}
