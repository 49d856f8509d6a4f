//! Legend of an [`XyPlot`]: a column to the right of the axes, one row per labelled item, so
//! that it never covers data.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::colormap::qualitative;
use crate::style::{DESC_FONT_PX, FONT, LEGEND_GLYPH_AREA_PX, MARGIN_PX, draw_err, glyph};
use crate::{MarkerStyle, PlotError, SeriesStyle, XyPlot};

/// Width of a plotted line, in the plot and in the legend.
pub(crate) const LINE_WIDTH_PX: u32 = 2;
/// Radius of a [`SeriesStyle::Dots`] dot.
pub(crate) const DOT_RADIUS_PX: i32 = 2;
/// Dash and gap lengths of a vertical line.
pub(crate) const DASH_PX: u32 = 8;
pub(crate) const DASH_GAP_PX: u32 = 5;
/// Height of one legend row.
const ROW_PX: i32 = DESC_FONT_PX as i32 + 8;
/// Space between the axes and the legend box, and inside the box around its rows.
const PAD_PX: i32 = 6;
/// Room for fonts whose rendered width exceeds plotters' estimate by a few pixels.
const TEXT_SLACK_PX: i32 = 4;
/// The legend takes at most this fraction of the image width; longer labels are clipped.
const MAX_WIDTH_FRACTION: f64 = 0.4;

/// What a legend row shows left of its label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Glyph {
    /// A solid line segment in a series colour.
    Line(RGBColor),
    /// Three dots in a series colour.
    Dots(RGBColor),
    /// A dashed segment (a vertical line's colour).
    Dashed(RGBColor),
    /// A marker glyph.
    Marker(MarkerStyle),
}

/// One legend row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Entry<'a> {
    pub label: &'a str,
    pub glyph: Glyph,
}

/// Colour of series `index`: its place in the palette, or for a [`SeriesStyle::Edge`] the
/// colour of the nearest series before it that is not an edge.
pub(crate) fn series_colour(plot: &XyPlot, index: usize) -> RGBColor {
    let owner = (0..=index)
        .rev()
        .find(|&i| plot.series[i].style != SeriesStyle::Edge)
        .unwrap_or(index);
    qualitative(owner)
}

/// Colour of vertical line `index`: the palette colours after those of the series.
pub(crate) fn vertical_line_colour(plot: &XyPlot, index: usize) -> RGBColor {
    qualitative(plot.series.len() + index)
}

/// Legend rows: labelled series, then marker groups (one per distinct non-empty label and
/// style), then labelled vertical lines.
pub(crate) fn entries<'a>(plot: &XyPlot<'a>) -> Vec<Entry<'a>> {
    let mut rows = Vec::new();
    for (i, s) in plot.series.iter().enumerate() {
        let glyph = match s.style {
            SeriesStyle::Line | SeriesStyle::Edge => Glyph::Line(series_colour(plot, i)),
            SeriesStyle::Dots => Glyph::Dots(series_colour(plot, i)),
        };
        rows.push(Entry {
            label: s.label,
            glyph,
        });
    }
    for m in plot.markers {
        let row = Entry {
            label: m.label,
            glyph: Glyph::Marker(m.style),
        };
        if !rows.contains(&row) {
            rows.push(row);
        }
    }
    for (i, v) in plot.vertical_lines.iter().enumerate() {
        rows.push(Entry {
            label: v.label,
            glyph: Glyph::Dashed(vertical_line_colour(plot, i)),
        });
    }
    rows.retain(|r| !r.label.is_empty());
    rows
}

/// Width of the legend column for `rows` in `area` (0 when there is no row).
pub(crate) fn width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Entry],
) -> Result<u32, PlotError> {
    if rows.is_empty() {
        return Ok(0);
    }
    let font = (FONT, DESC_FONT_PX).into_text_style(area);
    let mut text_px = 0;
    for row in rows {
        text_px = text_px.max(
            area.estimate_text_size(row.label, &font)
                .map_err(draw_err)?
                .0,
        );
    }
    // Frame inset, padding, glyph, gap before and after the text, frame inset.
    let chrome = 5 * PAD_PX + LEGEND_GLYPH_AREA_PX + TEXT_SLACK_PX;
    let wanted = text_px.saturating_add(chrome.unsigned_abs());
    let cap = f64::from(area.dim_in_pixel().0) * MAX_WIDTH_FRACTION;
    // cap is below u32::MAX, so the truncation is in range.
    Ok(wanted.min(cap as u32))
}

/// Draws `rows` in a framed box at the top of `area` (the column [`width`] asked for), as many
/// as fit in its height.
pub(crate) fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[Entry],
) -> Result<(), PlotError> {
    if rows.is_empty() {
        return Ok(());
    }
    let (w, h) = area.dim_in_pixel();
    let (left, top) = (PAD_PX, MARGIN_PX as i32);
    // Image sides are at most MAX_IMAGE_SIDE, so these fit in i32.
    let fit = ((h as i32 - top - 2 * PAD_PX) / ROW_PX).max(0);
    let n = fit.min(i32::try_from(rows.len()).unwrap_or(i32::MAX));
    let frame = [
        (left, top),
        (w as i32 - PAD_PX, top + n * ROW_PX + 2 * PAD_PX),
    ];
    area.draw(&Rectangle::new(frame, BLACK.stroke_width(1)))
        .map_err(draw_err)?;
    let font = (FONT, DESC_FONT_PX)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    for (k, row) in rows.iter().take(n as usize).enumerate() {
        let y = top + PAD_PX + ROW_PX / 2 + k as i32 * ROW_PX;
        let (x0, x1) = (left + PAD_PX, left + PAD_PX + LEGEND_GLYPH_AREA_PX);
        let centre = ((x0 + x1) / 2, y);
        let line =
            |c: RGBColor| PathElement::new(vec![(x0, y), (x1, y)], c.stroke_width(LINE_WIDTH_PX));
        match row.glyph {
            Glyph::Line(c) => area.draw(&line(c)),
            Glyph::Dots(c) => [x0 + 4, centre.0, x1 - 4]
                .iter()
                .try_for_each(|&x| area.draw(&Circle::new((x, y), DOT_RADIUS_PX, c.filled()))),
            Glyph::Dashed(c) => area.draw(&DashedPathElement::new(
                vec![(x0, y), (x1, y)],
                DASH_PX / 2,
                DASH_GAP_PX / 2,
                c.stroke_width(LINE_WIDTH_PX),
            )),
            Glyph::Marker(MarkerStyle::Cross) => area.draw(&glyph!(Cross, centre)),
            Glyph::Marker(MarkerStyle::Circle) => area.draw(&glyph!(Circle, centre)),
        }
        .map_err(draw_err)?;
        area.draw(&Text::new(row.label, (x1 + PAD_PX, y), font.clone()))
            .map_err(draw_err)?;
    }
    Ok(())
}
