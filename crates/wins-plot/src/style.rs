//! Look shared by every plot kind: fonts, margins, label areas and marker glyphs.

use std::path::Path;

use plotters::prelude::*;

use crate::PlotError;

pub(crate) const FONT: &str = "sans-serif";
pub(crate) const TITLE_FONT_PX: u32 = 24;
pub(crate) const DESC_FONT_PX: u32 = 16;
pub(crate) const TICK_FONT_PX: u32 = 13;
pub(crate) const MARGIN_PX: u32 = 12;
pub(crate) const X_LABEL_AREA_PX: u32 = 45;
pub(crate) const Y_LABEL_AREA_PX: u32 = 70;
/// Half-size of a marker glyph in pixels, on the plot and in the legend.
pub(crate) const MARKER_PX: i32 = 7;
/// Width of the legend's glyph column; plotters hands the legend closure its left edge.
pub(crate) const LEGEND_GLYPH_AREA_PX: i32 = 30;

/// Wraps a plotters error, keeping only its message.
pub(crate) fn draw_err<E: std::error::Error + Send + Sync>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Writes a row-major RGB buffer of `width * height * 3` bytes as an image at `path`, the
/// encoder chosen from the extension.
pub(crate) fn write_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<(), PlotError> {
    let mut backend = BitMapBackend::new(path, (width, height));
    backend
        .blit_bitmap((0, 0), (width, height), rgb)
        .map_err(draw_err)?;
    backend.present().map_err(draw_err)
}

/// Centre of a legend glyph, given the point plotters passes to the legend closure.
pub(crate) fn legend_centre((x, y): (i32, i32)) -> (i32, i32) {
    (x + LEGEND_GLYPH_AREA_PX / 2, y)
}

/// A marker glyph of half-size [`MARKER_PX`] centred on `$at` (data or pixel coordinates):
/// a red cross or a white ring, both with a black halo so they show on any colour.
/// Needs `plotters::prelude::*` in scope at the call site.
macro_rules! glyph {
    (Cross, $at:expr) => {
        EmptyElement::at($at)
            + Cross::new((0, 0), $crate::style::MARKER_PX, BLACK.stroke_width(4))
            + Cross::new((0, 0), $crate::style::MARKER_PX, RED.stroke_width(2))
    };
    (Circle, $at:expr) => {
        EmptyElement::at($at)
            + Circle::new((0, 0), $crate::style::MARKER_PX, BLACK.stroke_width(4))
            + Circle::new((0, 0), $crate::style::MARKER_PX, WHITE.stroke_width(2))
    };
}
pub(crate) use glyph;
