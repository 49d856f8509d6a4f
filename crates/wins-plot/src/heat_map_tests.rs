//! Tests of heat map rendering (PNG files and RGB buffers).

use super::*;
use crate::png_check::{take_png, temp_png};
use crate::{MIN_IMAGE_HEIGHT, MIN_IMAGE_WIDTH, Marker, ShapeProblem};

const W: u32 = 480;
const H: u32 = 320;

fn map<'a>(
    x: &'a [f64],
    y: &'a [f64],
    values: &'a [f64],
    markers: &'a [Marker<'a>],
) -> HeatMap<'a> {
    HeatMap {
        title: "MUSIC spectrum",
        x_label: "AoA (deg)",
        y_label: "ToF (ns)",
        colorbar_label: "spectrum (dB)",
        x,
        y,
        values,
        markers,
    }
}

/// Number of pixels of exactly `color` in an RGB buffer.
fn count(rgb: &[u8], color: RGBColor) -> usize {
    rgb.chunks_exact(3)
        .filter(|p| p == &[color.0, color.1, color.2])
        .count()
}

#[test]
fn renders_a_png_file() {
    let x: Vec<f64> = (0..19).map(|i| -90.0 + 10.0 * i as f64).collect();
    let y: Vec<f64> = (0..11).map(|i| 10.0 * i as f64).collect();
    let values: Vec<f64> = (0..x.len() * y.len())
        .map(|k| {
            let (ix, iy) = ((k % x.len()) as f64, (k / x.len()) as f64);
            -((ix - 7.0).powi(2) + (iy - 4.0).powi(2)) / 10.0
        })
        .collect();
    let markers = [
        Marker {
            x: -20.0,
            y: 40.0,
            label: "peak",
            style: MarkerStyle::Cross,
        },
        Marker {
            x: 50.0,
            y: 80.0,
            label: "peak",
            style: MarkerStyle::Cross,
        },
        Marker {
            x: -15.0,
            y: 42.0,
            label: "truth",
            style: MarkerStyle::Circle,
        },
    ];
    let path = temp_png("heat", "renders_a_png_file");
    heat_map_png(&path, &map(&x, &y, &values, &markers), 640, 400).unwrap();
    take_png(&path, 640, 400);
}

#[test]
fn different_values_give_different_pixels() {
    let (x, y) = ([0.0, 1.0, 2.0], [0.0, 1.0]);
    let a = render_rgb(&map(&x, &y, &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0], &[]), W, H).unwrap();
    let b = render_rgb(&map(&x, &y, &[5.0, 4.0, 3.0, 2.0, 1.0, 0.0], &[]), W, H).unwrap();
    let a_again = render_rgb(&map(&x, &y, &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0], &[]), W, H).unwrap();
    assert_eq!(a.len(), (W * H * 3) as usize);
    assert_eq!(a, a_again, "rendering is not deterministic");
    let differing = a
        .chunks_exact(3)
        .zip(b.chunks_exact(3))
        .filter(|(p, q)| p != q)
        .count();
    assert!(differing > 10_000, "only {differing} pixels differ");
}

#[test]
fn nan_cells_are_background_and_values_are_clamped() {
    let (x, y) = ([0.0, 1.0], [0.0, 1.0]);
    let top = viridis(1.0);
    let full = render_rgb(&map(&x, &y, &[0.0, 3.0, 3.0, 3.0], &[]), W, H).unwrap();
    let holed = render_rgb(&map(&x, &y, &[0.0, 3.0, 3.0, f64::NAN], &[]), W, H).unwrap();
    // +inf is clamped to the finite maximum, so it looks exactly like 3.0.
    let inf = render_rgb(&map(&x, &y, &[0.0, 3.0, 3.0, f64::INFINITY], &[]), W, H).unwrap();
    assert_eq!(full, inf);
    let cell = count(&full, top) - count(&holed, top);
    assert!(
        cell > 2_000,
        "NaN cell removed only {cell} top-colour pixels"
    );
    let white_gain = count(&holed, WHITE) - count(&full, WHITE);
    assert!(
        white_gain + 500 > cell,
        "NaN cell not white: {white_gain} vs {cell}"
    );
}

#[test]
fn markers_are_drawn() {
    let (x, y, v) = ([0.0, 1.0], [0.0, 1.0], [0.0, 1.0, 2.0, 3.0]);
    let plain = render_rgb(&map(&x, &y, &v, &[]), W, H).unwrap();
    let m = |style, label| Marker {
        x: 0.5,
        y: 0.5,
        label,
        style,
    };
    let cross = render_rgb(&map(&x, &y, &v, &[m(MarkerStyle::Cross, "")]), W, H).unwrap();
    let circle = render_rgb(&map(&x, &y, &v, &[m(MarkerStyle::Circle, "")]), W, H).unwrap();
    let labelled = render_rgb(&map(&x, &y, &v, &[m(MarkerStyle::Circle, "truth")]), W, H).unwrap();
    assert!(count(&cross, RED) > 20 && count(&plain, RED) == 0);
    assert_ne!(cross, circle);
    assert_ne!(circle, labelled, "legend missing");
    // Markers outside the axes are clipped, not an error.
    let outside = [Marker {
        x: 1e6,
        y: -1e6,
        label: "far",
        style: MarkerStyle::Cross,
    }];
    render_rgb(&map(&x, &y, &v, &outside), W, H).unwrap();
}

#[test]
fn awkward_ranges_render() {
    let (x, y) = ([0.0, 1.0], [0.0, 1.0]);
    for v in [
        [2.0; 4],
        [-f64::MAX, 0.0, 1.0, f64::MAX],
        [1e-12, 2e-12, 3e-12, 4e-12],
    ] {
        render_rgb(&map(&x, &y, &v, &[]), W, H).unwrap();
    }
    let big = [1e300, 2e300];
    let tiny = [1e9, 1e9 + 1e-6];
    render_rgb(&map(&big, &tiny, &[1.0, 2.0, 3.0, 4.0], &[]), W, H).unwrap();
    let untitled = HeatMap {
        title: "",
        x_label: "",
        y_label: "",
        colorbar_label: "",
        ..map(&x, &y, &[0.0; 4], &[])
    };
    render_rgb(&untitled, W, H).unwrap();
}

#[test]
fn bad_input_is_an_error_and_writes_nothing() {
    let path = temp_png("heat", "bad_input");
    let (x, y) = ([0.0, 1.0], [0.0, 1.0]);
    let r = heat_map_png(&path, &map(&x, &y, &[0.0; 3], &[]), W, H);
    let expected = ShapeProblem::LengthMismatch {
        len: 3,
        expected: 4,
    };
    assert!(matches!(r, Err(PlotError::Shape { field: "values", problem }) if problem == expected));
    let r = heat_map_png(&path, &map(&[1.0, 0.0], &y, &[0.0; 4], &[]), W, H);
    assert!(matches!(r, Err(PlotError::Shape { field: "x", .. })));
    let r = heat_map_png(&path, &map(&x, &y, &[f64::NAN; 4], &[]), W, H);
    assert!(matches!(
        r,
        Err(PlotError::Shape {
            field: "values",
            ..
        })
    ));
    let r = heat_map_png(&path, &map(&x, &y, &[0.0; 4], &[]), 10, 10);
    assert!(matches!(
        r,
        Err(PlotError::ImageSize {
            width: 10,
            height: 10
        })
    ));
    assert!(!path.exists());
}

#[test]
fn unwritable_path_is_a_draw_error() {
    let path = std::env::temp_dir()
        .join(format!("wins-plot-{}-no-such-dir", std::process::id()))
        .join("x.png");
    let (x, y) = ([0.0, 1.0], [0.0, 1.0]);
    let r = heat_map_png(&path, &map(&x, &y, &[0.0; 4], &[]), W, H);
    assert!(matches!(r, Err(PlotError::Draw(_))), "{r:?}");
}

#[test]
fn smallest_image_with_crowded_legend_renders() {
    let (x, y, v) = ([0.0, 1.0], [0.0, 1.0], [0.0, 1.0, 2.0, 3.0]);
    let labels = [
        "a rather long legend label",
        "b",
        "c",
        "d",
        "e",
        "f",
        "g",
        "h",
    ];
    let markers: Vec<Marker> = labels
        .iter()
        .enumerate()
        .map(|(i, &label)| {
            let style = if i % 2 == 0 {
                MarkerStyle::Cross
            } else {
                MarkerStyle::Circle
            };
            Marker {
                x: i as f64 / 8.0,
                y: 0.5,
                label,
                style,
            }
        })
        .collect();
    let long = "a title much longer than the smallest image is wide, to see that it is clipped";
    let crowded = HeatMap {
        title: long,
        x_label: long,
        ..map(&x, &y, &v, &markers)
    };
    let rgb = render_rgb(&crowded, MIN_IMAGE_WIDTH, MIN_IMAGE_HEIGHT).unwrap();
    assert_eq!(rgb.len(), (MIN_IMAGE_WIDTH * MIN_IMAGE_HEIGHT * 3) as usize);
}
