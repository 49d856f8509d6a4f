//! Tests of line and scatter plot rendering (PNG files and RGB buffers).

use super::*;
use crate::colormap::qualitative;
use crate::png_check::{take_png, temp_png};
use crate::{MIN_IMAGE_HEIGHT, MIN_IMAGE_WIDTH, Marker, Series, ShapeProblem, VerticalLine};

const W: u32 = 480;
const H: u32 = 320;

fn plot<'a>(series: &'a [Series<'a>], markers: &'a [Marker<'a>]) -> XyPlot<'a> {
    XyPlot {
        title: "Trajectory",
        x_label: "x (m)",
        y_label: "y (m)",
        series,
        markers,
        vertical_lines: &[],
        equal_aspect: false,
    }
}

fn series<'a>(label: &'a str, points: &'a [(f64, f64)], style: SeriesStyle) -> Series<'a> {
    Series {
        label,
        points,
        style,
    }
}

fn marker(x: f64, y: f64, label: &str, style: MarkerStyle) -> Marker<'_> {
    Marker { x, y, label, style }
}

/// Colour of pixel `(x, y)` of a `W`-wide RGB buffer.
fn pixel(rgb: &[u8], (x, y): (i32, i32)) -> RGBColor {
    let k = (y as usize * W as usize + x as usize) * 3;
    RGBColor(rgb[k], rgb[k + 1], rgb[k + 2])
}

/// Whether a pixel of `colour` lies within `r` pixels (Chebyshev) of `at`.
fn near(rgb: &[u8], at: (i32, i32), r: i32, colour: RGBColor) -> bool {
    (-r..=r).any(|dy| (-r..=r).any(|dx| pixel(rgb, (at.0 + dx, at.1 + dy)) == colour))
}

/// Width and height in pixels of the bounding box of the pixels of `colour`.
fn extent(rgb: &[u8], colour: RGBColor) -> (i32, i32) {
    let (mut x0, mut y0, mut x1, mut y1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
    for (k, p) in rgb.chunks_exact(3).enumerate() {
        if p == [colour.0, colour.1, colour.2] {
            let (x, y) = ((k % W as usize) as i32, (k / W as usize) as i32);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    assert!(x1 >= x0, "no pixel of {colour:?}");
    (x1 - x0, y1 - y0)
}

#[test]
fn writes_a_png_of_the_requested_size() {
    let pts = [(0.0, 0.0), (1.0, 2.0), (2.0, 1.0)];
    let s = [series("estimate", &pts, SeriesStyle::Line)];
    let path = temp_png("xy", "writes_a_png");
    xy_plot_png(&path, &plot(&s, &[]), 640, 400).unwrap();
    take_png(&path, 640, 400);
}

#[test]
fn series_colours_are_where_their_data_is() {
    let diagonal = [(0.0, 0.0), (10.0, 10.0)];
    let dots = [(2.0, 8.0), (8.0, 2.0)];
    let s = [
        series("line", &diagonal, SeriesStyle::Line),
        series("dots", &dots, SeriesStyle::Dots),
    ];
    let (rgb, frame) = render_rgb(&plot(&s, &[]), W, H).unwrap();
    assert_eq!(rgb.len(), (W * H * 3) as usize);
    let at = |p: (f64, f64)| frame.translate(&p);
    let (line, dot) = (qualitative(0), qualitative(1));
    assert!(near(&rgb, at((5.0, 5.0)), 1, line));
    assert!(near(&rgb, at((7.5, 7.5)), 1, line));
    assert!(near(&rgb, at((2.0, 8.0)), 1, dot) && near(&rgb, at((8.0, 2.0)), 1, dot));
    assert!(!near(&rgb, at((8.0, 5.0)), 3, line) && !near(&rgb, at((8.0, 5.0)), 3, dot));
    // Swapping the series swaps the colours.
    let swapped = [s[1], s[0]];
    let (rgb, frame) = render_rgb(&plot(&swapped, &[]), W, H).unwrap();
    assert!(near(&rgb, frame.translate(&(5.0, 5.0)), 1, dot));
    assert!(near(&rgb, frame.translate(&(2.0, 8.0)), 1, line));
}

#[test]
fn an_edge_takes_the_colour_of_the_series_it_bounds() {
    let middle = [(0.0, 5.0), (10.0, 5.0)];
    let upper = [(0.0, 8.0), (10.0, 8.0)];
    let other = [(0.0, 1.0), (10.0, 1.0)];
    let s = [
        series("error", &middle, SeriesStyle::Line),
        series("", &upper, SeriesStyle::Edge),
        series("other", &other, SeriesStyle::Line),
    ];
    let (rgb, frame) = render_rgb(&plot(&s, &[]), W, H).unwrap();
    let at = |p: (f64, f64)| frame.translate(&p);
    assert!(near(&rgb, at((5.0, 8.0)), 1, qualitative(0)));
    assert!(!near(&rgb, at((5.0, 8.0)), 1, qualitative(1)));
    // The series after the edge keeps its own place in the palette.
    assert!(near(&rgb, at((5.0, 1.0)), 1, qualitative(2)));
    // An unlabelled edge has no legend row.
    let rows = xy_legend::entries(&plot(&s, &[]));
    assert_eq!(rows.len(), 2);
}

#[test]
fn legend_does_not_cover_data() {
    // Data in every corner of the axes; the legend has a long label.
    let corners = [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)];
    let s = [series(
        "a rather long legend label",
        &corners,
        SeriesStyle::Dots,
    )];
    let m = [marker(0.5, 0.5, "AP (true)", MarkerStyle::Circle)];
    let (rgb, frame) = render_rgb(&plot(&s, &m), W, H).unwrap();
    for p in corners {
        assert!(near(&rgb, frame.translate(&p), 1, qualitative(0)), "{p:?}");
    }
    let legend_dots = extent(&rgb, qualitative(0));
    assert!(legend_dots.0 > frame.translate(&(1.0, 1.0)).0 - frame.translate(&(0.0, 0.0)).0);
}

#[test]
fn equal_aspect_equalizes_units_per_pixel() {
    // A unit square (series 0) next to a far point that makes the data 10 wide (or tall).
    let square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)];
    for far in [(10.0, 0.5), (0.5, 10.0)] {
        let far = [far];
        let s = [
            series("", &square, SeriesStyle::Line),
            series("", &far, SeriesStyle::Dots),
        ];
        let equal = XyPlot {
            equal_aspect: true,
            ..plot(&s, &[])
        };
        let (rgb, frame) = render_rgb(&equal, W, H).unwrap();
        let (o, c) = (frame.translate(&(0.0, 0.0)), frame.translate(&(1.0, 1.0)));
        let (dx, dy) = (c.0 - o.0, o.1 - c.1);
        assert!(dx > 10 && (dx - dy).abs() <= 1, "{far:?}: {dx} vs {dy} px");
        let (w, h) = extent(&rgb, qualitative(0));
        assert!((w - h).abs() <= 2, "{far:?}: square drawn {w}x{h} px");
        // Without equal aspect the square is visibly stretched.
        let (rgb, _) = render_rgb(&plot(&s, &[]), W, H).unwrap();
        let (w, h) = extent(&rgb, qualitative(0));
        assert!((w - h).abs() > 20, "{far:?}: square drawn {w}x{h} px");
    }
}

#[test]
fn non_finite_points_make_gaps() {
    let whole = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (4.0, 1.0)];
    let holed = [
        (0.0, 0.0),
        (1.0, 0.0),
        (f64::NAN, 0.0),
        (2.0, 0.0),
        (3.0, f64::INFINITY),
        (3.5, 0.5),
        (f64::NEG_INFINITY, f64::NAN),
        (4.0, 1.0),
    ];
    let colour = qualitative(0);
    let (rgb, frame) =
        render_rgb(&plot(&[series("", &whole, SeriesStyle::Line)], &[]), W, H).unwrap();
    assert!(near(&rgb, frame.translate(&(1.5, 0.0)), 0, colour));
    let (rgb, holed_frame) =
        render_rgb(&plot(&[series("", &holed, SeriesStyle::Line)], &[]), W, H).unwrap();
    // Same finite extent, so the same axes.
    assert_eq!(frame.get_x_range(), holed_frame.get_x_range());
    let at = |p: (f64, f64)| frame.translate(&p);
    assert!(
        near(&rgb, at((0.5, 0.0)), 0, colour),
        "piece before the gap missing"
    );
    assert!(!near(&rgb, at((1.5, 0.0)), 3, colour), "NaN point bridged");
    assert!(
        near(&rgb, at((2.0, 0.0)), 1, colour),
        "lone point between gaps missing"
    );
    assert!(
        !near(&rgb, at((2.5, 0.0)), 3, colour),
        "infinite point bridged"
    );
    assert!(near(&rgb, at((3.5, 0.5)), 1, colour) && near(&rgb, at((4.0, 1.0)), 1, colour));
    assert!(
        !near(&rgb, at((3.75, 0.75)), 3, colour),
        "lone points joined"
    );
    // Dots skip non-finite points the same way.
    let (rgb, frame) =
        render_rgb(&plot(&[series("", &holed, SeriesStyle::Dots)], &[]), W, H).unwrap();
    assert!(near(&rgb, frame.translate(&(2.0, 0.0)), 1, colour));
}

#[test]
fn sharp_turns_do_not_spike() {
    // A zig-zag with near reversals, as a noisy track has. plotters' thick polyline turns such
    // corners into miter spikes reaching far outside the data; segments drawn one by one do not.
    let zigzag: Vec<(f64, f64)> = (0..40)
        .map(|i| (f64::from(i % 2), 0.4 + 0.005 * f64::from(i)))
        .collect();
    let corners = [(-1.0, -1.0), (2.0, 2.0)];
    let s = [
        series("", &zigzag, SeriesStyle::Line),
        series("", &corners, SeriesStyle::Dots),
    ];
    let (rgb, frame) = render_rgb(&plot(&s, &[]), W, H).unwrap();
    let (lo, hi) = (frame.translate(&(0.0, 0.4)), frame.translate(&(1.0, 0.6)));
    let (w, h) = extent(&rgb, qualitative(0));
    let slack = 2 * LINE_WIDTH_PX as i32;
    assert!(w <= hi.0 - lo.0 + slack, "line {w} px wide");
    assert!(h <= lo.1 - hi.1 + slack, "line {h} px high");
}

#[test]
fn vertical_lines_and_markers_are_drawn() {
    let pts = [(0.0, 0.0), (10.0, 1.0)];
    let s = [series("error", &pts, SeriesStyle::Line)];
    let lines = [VerticalLine {
        x: 12.0,
        label: "converged",
    }];
    let m = [marker(5.0, 0.8, "", MarkerStyle::Cross)];
    let p = XyPlot {
        vertical_lines: &lines,
        ..plot(&s, &m)
    };
    let (rgb, frame) = render_rgb(&p, W, H).unwrap();
    // The vertical line widens the x range and takes the colour after the series'.
    let colour = qualitative(1);
    let column = (0..=20).filter(|&k| {
        let y = f64::from(k) / 20.0;
        near(&rgb, frame.translate(&(12.0, y)), 1, colour)
    });
    assert!(
        column.count() > 10,
        "vertical line missing or not dashed-visible"
    );
    assert!(near(&rgb, frame.translate(&(5.0, 0.8)), 2, RED));
    let (plain, _) = render_rgb(&plot(&s, &[]), W, H).unwrap();
    assert!(!plain.chunks_exact(3).any(|p| p == [255, 0, 0]));
}

#[test]
fn bad_input_is_an_error_and_writes_nothing() {
    let path = temp_png("xy", "bad_input");
    let shape = |r: Result<(), PlotError>| match r {
        Err(PlotError::Shape { field, problem }) => (field, problem),
        other => panic!("expected a shape error, got {other:?}"),
    };
    let r = xy_plot_png(&path, &plot(&[], &[]), W, H);
    assert_eq!(shape(r), ("series", ShapeProblem::NoFiniteValue));
    let nan = [(f64::NAN, f64::NAN); 3];
    let r = xy_plot_png(
        &path,
        &plot(&[series("x", &nan, SeriesStyle::Line)], &[]),
        W,
        H,
    );
    assert_eq!(shape(r), ("series", ShapeProblem::NoFiniteValue));
    let pts = [(0.0, 0.0)];
    let s = [series("x", &pts, SeriesStyle::Dots)];
    let m = [marker(f64::NAN, 0.0, "", MarkerStyle::Cross)];
    let r = xy_plot_png(&path, &plot(&s, &m), W, H);
    assert_eq!(shape(r), ("markers", ShapeProblem::NonFinite { index: 0 }));
    let huge = [(-f64::MAX, 0.0), (f64::MAX, 0.0)];
    let r = xy_plot_png(
        &path,
        &plot(&[series("", &huge, SeriesStyle::Line)], &[]),
        W,
        H,
    );
    assert_eq!(shape(r), ("x", ShapeProblem::RangeTooWide));
    let r = xy_plot_png(&path, &plot(&s, &[]), MIN_IMAGE_WIDTH - 1, H);
    assert!(
        matches!(r, Err(PlotError::ImageSize { width, height: H }) if width == MIN_IMAGE_WIDTH - 1)
    );
    let r = xy_plot_png(&path, &plot(&s, &[]), W, 0);
    assert!(matches!(r, Err(PlotError::ImageSize { height: 0, .. })));
    assert!(!path.exists());
}

#[test]
fn awkward_ranges_render() {
    for pts in [
        vec![(3.0, 3.0)],
        vec![(0.0, 0.0), (0.0, 0.0)],
        vec![(1e9, 1.0), (1e9 + 1e-6, 1.0 + 1e-12)],
        vec![(1e300, -1e300), (2e300, 1e300)],
        vec![(0.0, 5e-324), (1e-320, 0.0)],
    ] {
        for equal_aspect in [false, true] {
            let s = [series("", &pts, SeriesStyle::Line)];
            let p = XyPlot {
                equal_aspect,
                ..plot(&s, &[])
            };
            render_rgb(&p, W, H).unwrap();
        }
    }
    // A marker alone is enough to plot.
    let m = [marker(-2.0, 4.0, "AP", MarkerStyle::Circle)];
    let empty = [series("no data yet", &[], SeriesStyle::Dots)];
    render_rgb(&plot(&empty, &m), W, H).unwrap();
}

#[test]
fn smallest_image_with_crowded_legend_renders() {
    let pts = [(0.0, 0.0), (1.0, 1.0)];
    let labels = [
        "a rather long legend label, longer than the legend column",
        "b",
        "c",
    ];
    let many: Vec<Series> = (0..12)
        .map(|i| series(labels[i % 3], &pts, SeriesStyle::Line))
        .collect();
    let long = "a title much longer than the smallest image is wide, to see that it is clipped";
    let crowded = XyPlot {
        title: long,
        x_label: long,
        equal_aspect: true,
        ..plot(&many, &[])
    };
    let (rgb, _) = render_rgb(&crowded, MIN_IMAGE_WIDTH, MIN_IMAGE_HEIGHT).unwrap();
    assert_eq!(rgb.len(), (MIN_IMAGE_WIDTH * MIN_IMAGE_HEIGHT * 3) as usize);
}
