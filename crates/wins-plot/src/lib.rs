//! PNG plots for wins: heat maps (e.g. a MUSIC spectrum over AoA x ToF) with a colour bar,
//! axis labels, a title and point markers.
//!
//! The crate takes plain slices so it does not depend on the estimator. Text is rendered by
//! plotters' `ttf` feature, which finds the `sans-serif` font through fontconfig/freetype.
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
#![warn(missing_docs)]

mod colormap;
mod heat_map;
mod ticks;
mod validate;

pub use heat_map::heat_map_png;
pub use validate::{MAX_IMAGE_SIDE, MIN_IMAGE_HEIGHT, MIN_IMAGE_WIDTH};

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

/// A point marked on top of a [`HeatMap`], in the map's x/y coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker<'a> {
    /// x coordinate (same units as [`HeatMap::x`]); must be finite.
    pub x: f64,
    /// y coordinate (same units as [`HeatMap::y`]); must be finite.
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
    /// Every value is NaN or infinite, so there is no colour range.
    #[error("has no finite value")]
    NoFiniteValue,
}

/// Errors of the plotting functions.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// An input slice has the wrong length or content.
    #[error("`{field}` {problem}")]
    Shape {
        /// Name of the offending field, e.g. `"x"`, `"values"`, `"markers"`.
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
