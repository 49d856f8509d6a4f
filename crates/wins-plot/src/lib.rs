//! PNG plots for wins. Three kinds:
//!
//! - [`heat_map_png`]: a 2-D map on a regular grid (e.g. a MUSIC spectrum over AoA x ToF) with
//!   a colour bar and point markers;
//! - [`xy_plot_png`]: lines and dot clouds over x/y axes with markers, vertical lines and an
//!   optional equal aspect ratio, for the trajectory seen from above (estimate vs truth, APs),
//!   the position error over time and the per-packet AoA against the truth;
//! - [`strip_plot_png`]: the distribution of a value per group (e.g. the position error of
//!   each simulated flight, per scenario) as jittered points with the median.
//!
//! Each has a title and axis labels; the first two have a legend for labelled items. The crate takes plain slices
//! so it does not depend on the estimator; input is checked before anything is drawn and
//! rejected with a [`PlotError`], never a panic. Text is rendered by plotters' `ttf` feature,
//! which finds the `sans-serif` font through fontconfig/freetype.
//!
//! ```no_run
//! use wins_plot::{HeatMap, Marker, MarkerStyle, heat_map_png};
//! let x = [-30.0, 0.0, 30.0];
//! let y = [0.0, 50.0];
//! let values = [0.0, 3.0, 1.0, 2.0, 9.0, 4.0];
//! let markers = [Marker { x: 0.0, y: 50.0, label: "peak", style: MarkerStyle::Cross }];
//! let map = HeatMap {
//!     title: "MUSIC spectrum",
//!     x_label: "AoA (deg)",
//!     y_label: "ToF (ns)",
//!     colorbar_label: "spectrum (dB)",
//!     x: &x,
//!     y: &y,
//!     values: &values,
//!     markers: &markers,
//! };
//! heat_map_png(std::path::Path::new("spectrum.png"), &map, 800, 600)?;
//! # Ok::<(), wins_plot::PlotError>(())
//! ```
//!
//! ```no_run
//! use wins_plot::{Marker, MarkerStyle, Series, SeriesStyle, XyPlot, xy_plot_png};
//! let truth = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)];
//! let estimate = [(0.1, 0.0), (f64::NAN, f64::NAN), (0.9, 1.1)]; // NaN: a gap in the line
//! let series = [
//!     Series { label: "truth", points: &truth, style: SeriesStyle::Line },
//!     Series { label: "estimate", points: &estimate, style: SeriesStyle::Line },
//! ];
//! let aps = [Marker { x: 2.0, y: 2.0, label: "AP (true)", style: MarkerStyle::Circle }];
//! let plot = XyPlot {
//!     title: "Trajectory",
//!     x_label: "x (m)",
//!     y_label: "y (m)",
//!     series: &series,
//!     markers: &aps,
//!     vertical_lines: &[],
//!     equal_aspect: true,
//! };
//! xy_plot_png(std::path::Path::new("trajectory.png"), &plot, 800, 600)?;
//! # Ok::<(), wins_plot::PlotError>(())
//! ```
#![warn(missing_docs)]

mod colormap;
mod heat_map;
#[cfg(test)]
mod png_check;
mod strip_plot;
mod style;
mod ticks;
mod validate;
mod xy_legend;
mod xy_plot;
mod xy_range;

pub use heat_map::heat_map_png;
pub use strip_plot::strip_plot_png;
pub use validate::{MAX_IMAGE_SIDE, MIN_IMAGE_HEIGHT, MIN_IMAGE_WIDTH};
pub use xy_plot::xy_plot_png;

/// A 2-D map sampled on a regular grid, e.g. a MUSIC spectrum over (AoA, ToF).
///
/// Each value is drawn as a rectangle centred on its grid point that reaches half-way to the
/// neighbouring points (and as far again beyond the first and last points).
#[derive(Debug, Clone, Copy)]
pub struct HeatMap<'a> {
    /// Title drawn above the plot.
    pub title: &'a str,
    /// Horizontal axis label, e.g. `"AoA (deg)"`.
    pub x_label: &'a str,
    /// Vertical axis label, e.g. `"ToF (ns)"`.
    pub y_label: &'a str,
    /// Label of the colour bar, e.g. `"spectrum (dB)"`.
    pub colorbar_label: &'a str,
    /// Strictly increasing, finite grid coordinates along x; `nx = x.len() >= 2`.
    pub x: &'a [f64],
    /// Strictly increasing, finite grid coordinates along y; `ny = y.len() >= 2`.
    pub y: &'a [f64],
    /// Row-major by y: `values[iy * nx + ix]`, length `nx * ny`. NaN cells are left as
    /// background; infinities are clamped to the finite range like every other value.
    pub values: &'a [f64],
    /// Points drawn on top of the map (detected peaks, ground truth, ...). Markers sharing a
    /// non-empty label and style get one legend entry; an empty label gets none.
    pub markers: &'a [Marker<'a>],
}

/// A point marked on top of a [`HeatMap`] or an [`XyPlot`], in the plot's x/y coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker<'a> {
    /// x coordinate (same units as [`HeatMap::x`] or the series points); must be finite.
    pub x: f64,
    /// y coordinate (same units as [`HeatMap::y`] or the series points); must be finite.
    pub y: f64,
    /// Legend text; empty for no legend entry.
    pub label: &'a str,
    /// Glyph to draw.
    pub style: MarkerStyle,
}

/// Glyph of a [`Marker`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MarkerStyle {
    /// A red diagonal cross.
    Cross,
    /// A hollow white circle with a black halo.
    Circle,
}

/// A 2-D plot of lines and dot clouds, e.g. a trajectory seen from above, an error over time
/// or per-packet AoA against the truth.
///
/// Series are coloured from a fixed qualitative palette (matplotlib's `tab10`) by their index
/// in [`XyPlot::series`]; vertical lines take the palette colours that follow the series.
/// Labelled series, marker groups and vertical lines are listed in a legend to the right of
/// the axes, so the legend never covers data.
///
/// The axis ranges span every finite series point, every marker and every vertical line, with
/// a margin of 5 % of the span on each side. A single point or a flat coordinate gets a range
/// of ±5 % of its value (±1 at zero) around it.
///
/// Non-finite input: a series point with a NaN or infinite coordinate is not drawn and breaks a
/// [`SeriesStyle::Line`] into separate pieces (a gap); it does not count towards the ranges.
/// A non-finite marker or vertical line is rejected with [`ShapeProblem::NonFinite`].
#[derive(Debug, Clone, Copy)]
pub struct XyPlot<'a> {
    /// Title drawn above the plot.
    pub title: &'a str,
    /// Horizontal axis label, e.g. `"x (m)"` or `"t (s)"`.
    pub x_label: &'a str,
    /// Vertical axis label, e.g. `"y (m)"`.
    pub y_label: &'a str,
    /// Data, drawn in order (later series on top).
    pub series: &'a [Series<'a>],
    /// Points drawn on top of the series (AP positions, ...). Markers sharing a non-empty label
    /// and style get one legend entry; an empty label gets none.
    pub markers: &'a [Marker<'a>],
    /// Dashed lines across the whole height, e.g. at the convergence time.
    pub vertical_lines: &'a [VerticalLine<'a>],
    /// Same scale on both axes (1 m on x is as many pixels as 1 m on y), obtained by widening
    /// the range of the axis that would otherwise be stretched; for maps of positions.
    pub equal_aspect: bool,
}

/// One set of points of an [`XyPlot`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Series<'a> {
    /// Legend text; empty for no legend entry.
    pub label: &'a str,
    /// `(x, y)` points in drawing order. A point with a non-finite coordinate is a gap.
    pub points: &'a [(f64, f64)],
    /// How the points are drawn.
    pub style: SeriesStyle,
}

/// How a [`Series`] is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SeriesStyle {
    /// A 2-pixel line through consecutive finite points, broken at non-finite ones. A finite
    /// point with gaps on both sides is drawn as a dot so that it does not vanish.
    Line,
    /// A small filled dot per finite point, for clouds of thousands of points.
    Dots,
    /// A 1-pixel line, broken like [`SeriesStyle::Line`], in the colour of the nearest series
    /// before it that is not an `Edge`: an edge of that series' band (a ±σ bound, say).
    Edge,
}

/// A vertical line across an [`XyPlot`], e.g. marking the convergence time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalLine<'a> {
    /// Position on the x axis; must be finite.
    pub x: f64,
    /// Legend text; empty for no legend entry.
    pub label: &'a str,
}

/// The distribution of one value per group: for each group a column of points, spread
/// sideways by a deterministic jitter so that equal values stay visible, and a bar at the
/// group's median; e.g. the position error of every simulated flight, per scenario.
#[derive(Debug, Clone, Copy)]
pub struct StripPlot<'a> {
    /// Title drawn above the plot.
    pub title: &'a str,
    /// Vertical axis label, e.g. `"ATE RMSE (m)"`.
    pub y_label: &'a str,
    /// The groups, left to right; at least one.
    pub groups: &'a [StripGroup<'a>],
}

/// One column of a [`StripPlot`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StripGroup<'a> {
    /// Name under the axis.
    pub label: &'a str,
    /// Second line under the name (what the points leave out, e.g. `"8 runs, 2 never
    /// converged"`); empty for none.
    pub note: &'a str,
    /// The values, finite; may be empty (the group keeps its place and labels).
    pub values: &'a [f64],
}

/// What is wrong with one field of the input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ShapeProblem {
    /// Fewer elements than needed.
    #[error("has {len} elements, needs at least {min}")]
    TooShort {
        /// Number of elements given.
        len: usize,
        /// Minimum number of elements.
        min: usize,
    },
    /// The length does not match the grid.
    #[error("has {len} elements, expected {expected}")]
    LengthMismatch {
        /// Number of elements given.
        len: usize,
        /// Number of elements expected (`nx * ny` for the values).
        expected: usize,
    },
    /// Element `index` is not greater than element `index - 1`.
    #[error("is not strictly increasing at index {index}")]
    NotIncreasing {
        /// Index of the offending element.
        index: usize,
    },
    /// Element `index` is NaN or infinite.
    #[error("is not finite at index {index}")]
    NonFinite {
        /// Index of the offending element.
        index: usize,
    },
    /// The cell edges (half-way between points, half a spacing beyond the ends) overflow
    /// `f64` or collapse onto each other because the spacing is too small to halve.
    #[error("gives cell edges that overflow f64 or collapse (spacing too small)")]
    BadCellEdges,
    /// Every value is NaN or infinite (or there is none), so there is no range: for a heat
    /// map the colour range, for an [`XyPlot`] the axis ranges (no finite series point and no
    /// marker).
    #[error("has no finite value")]
    NoFiniteValue,
    /// The axis range needed to show the data (with its margin, and widened for an equal
    /// aspect ratio) overflows `f64`.
    #[error("needs an axis range wider than f64 can hold")]
    RangeTooWide,
}

/// Errors of the plotting functions.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// An input slice has the wrong length or content.
    #[error("`{field}` {problem}")]
    Shape {
        /// Name of the offending field, e.g. `"x"`, `"values"`, `"markers"`; for an axis range
        /// of an [`XyPlot`], `"x"` or `"y"`.
        field: &'static str,
        /// What is wrong with it.
        problem: ShapeProblem,
    },
    /// The requested image size is outside
    /// [`MIN_IMAGE_WIDTH`]..=[`MAX_IMAGE_SIDE`] x [`MIN_IMAGE_HEIGHT`]..=[`MAX_IMAGE_SIDE`].
    #[error(
        "image size {width}x{height} is outside \
         {MIN_IMAGE_WIDTH}..={MAX_IMAGE_SIDE} x {MIN_IMAGE_HEIGHT}..={MAX_IMAGE_SIDE}"
    )]
    ImageSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
    },
    /// plotters failed (missing font, unwritable file, ...); the message is plotters' own.
    #[error("drawing failed: {0}")]
    Draw(String),
}
