//! Line and scatter plot rendering: axes and grid, series, vertical lines, markers and legend.

use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use crate::style::{
    DESC_FONT_PX, FONT, MARGIN_PX, TICK_FONT_PX, TITLE_FONT_PX, X_LABEL_AREA_PX, Y_LABEL_AREA_PX,
    draw_err, glyph, write_png,
};
use crate::ticks::TickFormat;
use crate::validate::check_size;
use crate::xy_legend::{
    self, DASH_GAP_PX, DASH_PX, DOT_RADIUS_PX, LINE_WIDTH_PX, series_colour, vertical_line_colour,
};
use crate::xy_range::{Axes, check, equalize};
use crate::{MarkerStyle, PlotError, SeriesStyle, XyPlot};

/// Colour of the grid lines at the ticks.
const GRID_COLOUR: RGBColor = RGBColor(225, 225, 225);

/// The mapping from data to pixel coordinates of a drawn plot.
pub(crate) type Frame = Cartesian2d<RangedCoordf64, RangedCoordf64>;

/// Renders `plot` as a `width` x `height` PNG at `path`.
///
/// The file is written only after the whole plot has been drawn, so a failed call leaves no
/// partial image. The encoder is chosen from the extension of `path`, so it should end in
/// `.png`. Text needs a `sans-serif` font reachable through fontconfig. Non-finite series
/// points are gaps; see [`XyPlot`] for the ranges and colours.
///
/// # Errors
/// [`PlotError::ImageSize`] for a size outside the accepted range; [`PlotError::Shape`] with
/// - `field: "series"`, [`ShapeProblem::NoFiniteValue`](crate::ShapeProblem::NoFiniteValue)
///   when no series point and no marker is finite (nothing to plot),
/// - `field: "markers"` or `"vertical_lines"`,
///   [`ShapeProblem::NonFinite`](crate::ShapeProblem::NonFinite) for a NaN or infinite one,
/// - `field: "x"` or `"y"`, [`ShapeProblem::RangeTooWide`](crate::ShapeProblem::RangeTooWide)
///   when the axis range overflows `f64`;
///
/// [`PlotError::Draw`] when plotters cannot load a font or write the file.
pub fn xy_plot_png(path: &Path, plot: &XyPlot, width: u32, height: u32) -> Result<(), PlotError> {
    let (rgb, _) = render_rgb(plot, width, height)?;
    write_png(path, &rgb, width, height)
}

/// Renders `plot` into a row-major RGB buffer of `width * height * 3` bytes and returns it
/// with the data-to-pixel mapping of the axes.
pub(crate) fn render_rgb(
    plot: &XyPlot,
    width: u32,
    height: u32,
) -> Result<(Vec<u8>, Frame), PlotError> {
    check_size(width, height)?;
    let axes = check(plot)?;
    render_frame(width, height, |root| draw(root, plot, axes))
}

/// A `width` x `height` RGB buffer (row-major, 3 bytes a pixel, sizes checked by the caller with
/// [`check_size`]) drawn by `draw`, and the axes' mapping it returns.
pub(crate) fn render_frame(
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<Frame, PlotError>,
) -> Result<(Vec<u8>, Frame), PlotError> {
    // check_size bounds both sides, so this cannot overflow.
    let mut rgb = vec![0; width as usize * height as usize * 3];
    let frame = {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        let frame = draw(&root)?;
        root.present().map_err(draw_err)?;
        frame
    };
    Ok((rgb, frame))
}

fn chart_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(MARGIN_PX)
        .x_label_area_size(X_LABEL_AREA_PX)
        .y_label_area_size(Y_LABEL_AREA_PX);
    builder
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &XyPlot,
    axes: Axes,
) -> Result<Frame, PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let body = if plot.title.is_empty() {
        root.clone()
    } else {
        root.titled(plot.title, (FONT, TITLE_FONT_PX))
            .map_err(draw_err)?
    };
    let rows = xy_legend::entries(plot);
    let legend_px = xy_legend::width(&body, &rows)?;
    let (body_width, _) = body.dim_in_pixel();
    let (plot_area, legend_area) = body.split_horizontally(body_width.saturating_sub(legend_px));

    let axes = if plot.equal_aspect {
        // Building a chart draws nothing: this one only measures the plotting area.
        let probe = chart_builder(&plot_area)
            .build_cartesian_2d(axes.x.clone(), axes.y.clone())
            .map_err(draw_err)?;
        let spec = probe.as_coord_spec();
        let px = |r: std::ops::Range<i32>| (r.end - r.start).unsigned_abs();
        let x_px = px(spec.get_x_axis_pixel_range());
        let y_px = px(spec.get_y_axis_pixel_range());
        equalize(&axes, x_px, y_px)?
    } else {
        axes
    };
    let (x_ticks, y_ticks) = (
        TickFormat::for_range(axes.x.start, axes.x.end),
        TickFormat::for_range(axes.y.start, axes.y.end),
    );
    let y_range = axes.y.clone();
    let mut chart = chart_builder(&plot_area)
        .build_cartesian_2d(axes.x, axes.y)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .bold_line_style(GRID_COLOUR)
        .max_light_lines(0)
        .x_label_formatter(&|v| x_ticks.format(*v))
        .y_label_formatter(&|v| y_ticks.format(*v))
        .x_desc(plot.x_label)
        .y_desc(plot.y_label)
        .label_style((FONT, TICK_FONT_PX))
        .axis_desc_style((FONT, DESC_FONT_PX))
        .draw()
        .map_err(draw_err)?;

    for (i, series) in plot.series.iter().enumerate() {
        let colour = series_colour(plot, i);
        match series.style {
            SeriesStyle::Dots => {
                let dots = series.points.iter().filter(|&&p| finite(p));
                chart
                    .draw_series(dots.map(|&p| Circle::new(p, DOT_RADIUS_PX, colour.filled())))
                    .map_err(draw_err)?;
            }
            SeriesStyle::Line => draw_line(&mut chart, series.points, colour, LINE_WIDTH_PX)?,
            SeriesStyle::Edge => draw_line(&mut chart, series.points, colour, 1)?,
        }
    }
    for (i, v) in plot.vertical_lines.iter().enumerate() {
        let style = vertical_line_colour(plot, i).stroke_width(LINE_WIDTH_PX);
        let ends = [(v.x, y_range.start), (v.x, y_range.end)];
        chart
            .draw_series([DashedPathElement::new(ends, DASH_PX, DASH_GAP_PX, style)])
            .map_err(draw_err)?;
    }
    for m in plot.markers {
        let p = (m.x, m.y);
        match m.style {
            MarkerStyle::Cross => chart.draw_series([glyph!(Cross, p)]),
            MarkerStyle::Circle => chart.draw_series([glyph!(Circle, p)]),
        }
        .map_err(draw_err)?;
    }
    xy_legend::draw(&legend_area, &rows)?;
    Ok(chart.as_coord_spec().clone())
}

fn finite((x, y): (f64, f64)) -> bool {
    x.is_finite() && y.is_finite()
}

/// Draws `points` as lines broken at non-finite points; a piece that is a single pixel
/// (one point, or all its points on one pixel) becomes a dot so that it does not vanish.
///
/// Each segment is drawn on its own: plotters draws a thick polyline as one polygon with
/// unbounded inner miter joins, which sends spikes far off a noisy track.
fn draw_line<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Frame>,
    points: &[(f64, f64)],
    colour: RGBColor,
    width_px: u32,
) -> Result<(), PlotError> {
    let pieces = points.split(|&p| !finite(p)).filter(|p| !p.is_empty());
    for piece in pieces {
        let first = chart.backend_coord(&piece[0]);
        if piece.iter().all(|p| chart.backend_coord(p) == first) {
            let dot = Circle::new(piece[0], width_px, colour.filled());
            chart.draw_series([dot]).map_err(draw_err)?;
        } else {
            let style = colour.stroke_width(width_px);
            let segments = piece
                .windows(2)
                .map(|w| PathElement::new(vec![w[0], w[1]], style));
            chart.draw_series(segments).map_err(draw_err)?;
        }
    }
    Ok(())
}

#[cfg(test)]
#[path = "xy_plot_tests.rs"]
mod tests;
