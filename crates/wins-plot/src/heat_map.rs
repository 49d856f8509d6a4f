//! Heat map rendering: cells, axes, colour bar, markers and legend.

use std::ops::Range;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::colormap::{normalize, viridis};
use crate::style::{
    DESC_FONT_PX, FONT, LEGEND_GLYPH_AREA_PX, MARGIN_PX, TICK_FONT_PX, TITLE_FONT_PX,
    X_LABEL_AREA_PX, Y_LABEL_AREA_PX, draw_err, glyph, legend_centre, write_png,
};
use crate::ticks::TickFormat;
use crate::validate::{Grid, check, check_size};
use crate::{HeatMap, MarkerStyle, PlotError};

/// Width of the colour bar column: bar, tick labels and the rotated label.
const COLORBAR_AREA_PX: u32 = 125;
const COLORBAR_LABEL_AREA_PX: u32 = 85;
/// Number of constant-colour steps in the colour bar.
const COLORBAR_STEPS: usize = 128;

/// Renders `map` as a `width` x `height` PNG at `path`.
///
/// The file is written only after the whole plot has been drawn, so a failed call leaves no
/// partial image. The encoder is chosen from the extension of `path`, so it should end in
/// `.png`. Text needs a `sans-serif` font reachable through fontconfig.
///
/// # Errors
/// [`PlotError::Shape`] for inconsistent input (see [`HeatMap`]), [`PlotError::ImageSize`] for a
/// size outside the accepted range, [`PlotError::Draw`] when plotters cannot load a font or
/// write the file.
pub fn heat_map_png(path: &Path, map: &HeatMap, width: u32, height: u32) -> Result<(), PlotError> {
    let rgb = render_rgb(map, width, height)?;
    write_png(path, &rgb, width, height)
}

/// Renders `map` into a row-major RGB buffer of `width * height * 3` bytes.
pub(crate) fn render_rgb(map: &HeatMap, width: u32, height: u32) -> Result<Vec<u8>, PlotError> {
    check_size(width, height)?;
    let grid = check(map)?;
    // check_size bounds both sides, so this cannot overflow.
    let mut rgb = vec![0; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        draw(&root, map, &grid)?;
        root.present().map_err(draw_err)?;
    }
    Ok(rgb)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    map: &HeatMap,
    grid: &Grid,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let body = if map.title.is_empty() {
        root.clone()
    } else {
        root.titled(map.title, (FONT, TITLE_FONT_PX))
            .map_err(draw_err)?
    };
    let (body_width, _) = body.dim_in_pixel();
    let (plot_area, bar_area) =
        body.split_horizontally(body_width.saturating_sub(COLORBAR_AREA_PX));
    draw_map(&plot_area, map, grid)?;
    draw_colorbar(&bar_area, map.colorbar_label, grid.lo, grid.hi)
}

fn draw_map<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    map: &HeatMap,
    grid: &Grid,
) -> Result<(), PlotError> {
    let (xe, ye) = (&grid.x_edges, &grid.y_edges);
    let x_range = xe[0]..xe[xe.len() - 1];
    let y_range = ye[0]..ye[ye.len() - 1];
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN_PX)
        .x_label_area_size(X_LABEL_AREA_PX)
        .y_label_area_size(Y_LABEL_AREA_PX)
        .build_cartesian_2d(x_range, y_range)
        .map_err(draw_err)?;

    let nx = map.x.len();
    // check() guarantees values.len() == nx * ny, so every index below is in range.
    let cells = map.values.iter().enumerate().filter(|(_, v)| !v.is_nan());
    let rects = cells.map(|(k, &v)| {
        let (ix, iy) = (k % nx, k / nx);
        let color = viridis(normalize(v, grid.lo, grid.hi));
        Rectangle::new([(xe[ix], ye[iy]), (xe[ix + 1], ye[iy + 1])], color.filled())
    });
    chart.draw_series(rects).map_err(draw_err)?;
    let x_ticks = TickFormat::for_range(xe[0], xe[xe.len() - 1]);
    let y_ticks = TickFormat::for_range(ye[0], ye[ye.len() - 1]);
    chart
        .configure_mesh()
        .disable_mesh()
        .x_label_formatter(&|v| x_ticks.format(*v))
        .y_label_formatter(&|v| y_ticks.format(*v))
        .x_desc(map.x_label)
        .y_desc(map.y_label)
        .label_style((FONT, TICK_FONT_PX))
        .axis_desc_style((FONT, DESC_FONT_PX))
        .draw()
        .map_err(draw_err)?;

    // One series, and one legend entry, per distinct (label, style).
    let mut groups: Vec<(&str, MarkerStyle)> = Vec::new();
    for m in map.markers {
        if !groups.contains(&(m.label, m.style)) {
            groups.push((m.label, m.style));
        }
    }
    for &(label, style) in &groups {
        let points = map
            .markers
            .iter()
            .filter(|m| m.label == label && m.style == style)
            .map(|m| (m.x, m.y));
        match style {
            MarkerStyle::Cross => {
                let series = chart
                    .draw_series(points.map(|p| glyph!(Cross, p)))
                    .map_err(draw_err)?;
                if !label.is_empty() {
                    series
                        .label(label)
                        .legend(|p| glyph!(Cross, legend_centre(p)));
                }
            }
            MarkerStyle::Circle => {
                let series = chart
                    .draw_series(points.map(|p| glyph!(Circle, p)))
                    .map_err(draw_err)?;
                if !label.is_empty() {
                    series
                        .label(label)
                        .legend(|p| glyph!(Circle, legend_centre(p)));
                }
            }
        }
    }
    if groups.iter().any(|(label, _)| !label.is_empty()) {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, DESC_FONT_PX))
            .legend_area_size(LEGEND_GLYPH_AREA_PX)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Vertical colour bar for values in `lo..=hi`, ticks and label on its right.
fn draw_colorbar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    label: &str,
    lo: f64,
    hi: f64,
) -> Result<(), PlotError> {
    let span = hi - lo;
    // plotters' tick search needs a finite, non-empty range; otherwise draw the bar over 0..1
    // (-1..1 for a flat map, so its single tick sits in the middle) and label the ticks with
    // the values they stand for.
    let direct = span.is_finite() && span > 0.0;
    let range: Range<f64> = match (direct, span == 0.0) {
        (true, _) => lo..hi,
        (false, true) => -1.0..1.0,
        (false, false) => 0.0..1.0,
    };
    let value_at = |t: f64| if direct { t } else { lo * (1.0 - t) + hi * t };
    let mut chart = ChartBuilder::on(area)
        .margin(MARGIN_PX)
        .margin_left(0)
        .x_label_area_size(X_LABEL_AREA_PX)
        .right_y_label_area_size(COLORBAR_LABEL_AREA_PX)
        .build_cartesian_2d(0.0..1.0, range.clone())
        .map_err(draw_err)?;
    let step = (range.end - range.start) / COLORBAR_STEPS as f64;
    let steps = (0..COLORBAR_STEPS).map(|i| {
        let y0 = range.start + step * i as f64;
        let y1 = if i + 1 == COLORBAR_STEPS {
            range.end
        } else {
            y0 + step
        };
        let color = viridis(normalize(value_at(y0 + step / 2.0), lo, hi));
        Rectangle::new([(0.0, y0), (1.0, y1)], color.filled())
    });
    chart.draw_series(steps).map_err(draw_err)?;
    let ticks = TickFormat::for_range(lo, hi);
    let format = |t: &f64| ticks.format(value_at(*t));
    let mut mesh = chart.configure_mesh();
    mesh.disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&format)
        .y_desc(label)
        .label_style((FONT, TICK_FONT_PX))
        .axis_desc_style((FONT, DESC_FONT_PX));
    if span == 0.0 {
        // A flat map: one tick with the value.
        mesh.y_labels(1);
    }
    mesh.draw().map_err(draw_err)?;
    chart
        .plotting_area()
        .draw(&Rectangle::new(
            [(0.0, range.start), (1.0, range.end)],
            BLACK.stroke_width(1),
        ))
        .map_err(draw_err)
}

#[cfg(test)]
#[path = "heat_map_tests.rs"]
mod tests;
