//! Tests of strip plot rendering (PNG files and RGB buffers).

use super::*;
use crate::StripGroup;
use crate::png_check::{take_png, temp_png};

const W: u32 = 480;
const H: u32 = 320;

fn group<'a>(label: &'a str, values: &'a [f64]) -> StripGroup<'a> {
    StripGroup {
        label,
        note: "",
        values,
    }
}

fn plot<'a>(groups: &'a [StripGroup<'a>]) -> StripPlot<'a> {
    StripPlot {
        title: "ATE per scenario",
        y_label: "ATE RMSE (m)",
        groups,
    }
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

#[test]
fn writes_a_png_of_the_requested_size() {
    let a = [0.4, 0.5, 0.9];
    let b = [1.2];
    let groups = [
        StripGroup {
            label: "paper-circle",
            note: "3 runs",
            values: &a,
        },
        StripGroup {
            label: "hover",
            note: "2 runs, 1 never converged",
            values: &b,
        },
    ];
    let path = temp_png("strip", "writes_a_png");
    strip_plot_png(&path, &plot(&groups), 640, 400).unwrap();
    take_png(&path, 640, 400);
}

#[test]
fn each_point_is_drawn_in_its_group_colour_at_its_value_and_jitter() {
    let a = [1.0, 2.0, 3.0];
    let b = [0.5, 4.0];
    let groups = [group("a", &a), group("b", &b)];
    let (rgb, frame) = render_rgb(&plot(&groups), W, H).unwrap();
    for (g, values) in [&a[..], &b[..]].into_iter().enumerate() {
        for (i, &v) in values.iter().enumerate() {
            let at = frame.translate(&(g as f64 + jitter(i), v));
            assert!(near(&rgb, at, 3, qualitative(g)), "group {g} point {i}");
        }
    }
    // The median bars: black at the middle of each group, at 2.0 and at 2.25.
    for (g, m) in [(0.0, 2.0), (1.0, 2.25)] {
        let at = frame.translate(&(g + MEDIAN_HALF_WIDTH * 0.9, m));
        assert!(near(&rgb, at, 1, BLACK), "median of group {g}");
    }
    // Nothing of a group's colour in the other group's column.
    let far = frame.translate(&(1.0, 1.0));
    assert!(!near(&rgb, far, 3, qualitative(0)));
}

#[test]
fn jitter_is_deterministic_within_bounds_and_spreads_points() {
    let offsets: Vec<f64> = (0..50).map(jitter).collect();
    assert_eq!(offsets, (0..50).map(jitter).collect::<Vec<_>>());
    assert!(offsets.iter().all(|o| o.abs() <= JITTER_HALF_WIDTH));
    // Neighbouring points do not land on one another.
    assert!(offsets.windows(2).all(|w| (w[0] - w[1]).abs() > 0.05));
}

#[test]
fn the_range_starts_at_zero_and_empty_groups_keep_their_place() {
    let a = [2.0, 3.0];
    let groups = [group("a", &a), group("none converged", &[])];
    let r = y_range(&plot(&groups)).unwrap();
    assert_eq!(r.start, 0.0);
    assert!((r.end - 3.15).abs() < 1e-12, "{r:?}");
    let (rgb, frame) = render_rgb(&plot(&groups), W, H).unwrap();
    // The empty group's column lies inside the axes and holds no point.
    let (x, _) = frame.translate(&(1.0, 1.5));
    assert!(x > 0 && x < W as i32);
    assert!(!near(&rgb, frame.translate(&(1.0, 2.5)), 4, qualitative(1)));
    // No value at all: a 0..1 axis, still drawn.
    let empty = [group("a", &[]), group("b", &[])];
    assert_eq!(y_range(&plot(&empty)).unwrap(), 0.0..1.0);
    render_rgb(&plot(&empty), W, H).unwrap();
}

#[test]
fn bad_input_is_refused_before_drawing() {
    let err = render_rgb(&plot(&[]), W, H).err().unwrap();
    assert!(matches!(
        err,
        PlotError::Shape {
            field: "groups",
            problem: ShapeProblem::TooShort { len: 0, min: 1 }
        }
    ));
    let a = [1.0];
    let b = [2.0, f64::NAN];
    let groups = [group("a", &a), group("b", &b)];
    let err = render_rgb(&plot(&groups), W, H).err().unwrap();
    assert!(
        matches!(
            err,
            PlotError::Shape {
                field: "values",
                problem: ShapeProblem::NonFinite { index: 2 }
            }
        ),
        "{err}"
    );
    let ok = [group("a", &a)];
    assert!(matches!(
        render_rgb(&plot(&ok), 10, 10),
        Err(PlotError::ImageSize { .. })
    ));
}
