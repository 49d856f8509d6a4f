//! Strip plot rendering: one column of jittered points per group, with its median.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::colormap::qualitative;
use crate::style::{
    DESC_FONT_PX, FONT, MARGIN_PX, TICK_FONT_PX, TITLE_FONT_PX, Y_LABEL_AREA_PX, draw_err,
    write_png,
};
use crate::ticks::TickFormat;
use crate::validate::check_size;
use crate::xy_plot::{Frame, render_frame};
use crate::{PlotError, ShapeProblem, StripPlot};

/// Points of a group spread over ± this many group widths around its centre.
pub(crate) const JITTER_HALF_WIDTH: f64 = 0.3;
/// The median bar spans ± this many group widths.
const MEDIAN_HALF_WIDTH: f64 = 0.38;
/// Radius of a point, pixels.
pub(crate) const POINT_RADIUS_PX: i32 = 4;
/// Height of the area under the axis for the two lines of a group's label, pixels.
const GROUP_LABEL_AREA_PX: u32 = 48;
/// Margin above and below the values, as a fraction of their span.
const MARGIN_FRACTION: f64 = 0.05;
/// `1/φ`: successive multiples modulo 1 spread evenly over [0, 1) (a low-discrepancy sequence).
const GOLDEN_FRACTION: f64 = 0.618_033_988_749_894_8;

/// Horizontal offset of point `index` of a group from the group's centre, in group widths:
/// deterministic, so the same data always give the same picture.
pub(crate) fn jitter(index: usize) -> f64 {
    let u = (index as f64 * GOLDEN_FRACTION).fract();
    (2.0 * u - 1.0) * JITTER_HALF_WIDTH
}

/// Renders `plot` as a `width` x `height` PNG at `path`.
///
/// Group `i` is centred on x = `i`; its points sit at x = `i` + a deterministic jitter within
/// ±0.3, coloured from the qualitative palette by group, with a black bar at the group's
/// median. Under the axis each group shows its label and, below it, its note. The y range spans
/// every value and 0, with a 5 % margin (0 to 1 when no group has a value). The file is written
/// only after the whole plot has been drawn.
///
/// # Errors
/// [`PlotError::ImageSize`] for a size outside the accepted range; [`PlotError::Shape`] with
/// `field: "groups"`, [`ShapeProblem::TooShort`] when there is no group, or `field: "values"`,
/// [`ShapeProblem::NonFinite`] (its index counted over all groups' values in order) for a NaN
/// or infinite value; [`PlotError::Draw`] when plotters cannot load a font or write the file.
pub fn strip_plot_png(
    path: &Path,
    plot: &StripPlot,
    width: u32,
    height: u32,
) -> Result<(), PlotError> {
    let (rgb, _) = render_rgb(plot, width, height)?;
    write_png(path, &rgb, width, height)
}

/// The y range: every value and 0, with a margin.
fn y_range(plot: &StripPlot) -> Result<std::ops::Range<f64>, PlotError> {
    if plot.groups.is_empty() {
        return Err(PlotError::Shape {
            field: "groups",
            problem: ShapeProblem::TooShort { len: 0, min: 1 },
        });
    }
    let values = plot.groups.iter().flat_map(|g| g.values.iter().copied());
    let (mut lo, mut hi) = (0.0_f64, 0.0_f64);
    for (index, v) in values.enumerate() {
        if !v.is_finite() {
            return Err(PlotError::Shape {
                field: "values",
                problem: ShapeProblem::NonFinite { index },
            });
        }
        (lo, hi) = (lo.min(v), hi.max(v));
    }
    if hi <= lo {
        return Ok(0.0..1.0);
    }
    let margin = (hi / 2.0 - lo / 2.0) * (2.0 * MARGIN_FRACTION);
    let range = (lo - if lo < 0.0 { margin } else { 0.0 })..(hi + margin);
    if range.start.is_finite() && range.end.is_finite() && (range.end - range.start).is_finite() {
        Ok(range)
    } else {
        Err(PlotError::Shape {
            field: "values",
            problem: ShapeProblem::RangeTooWide,
        })
    }
}

/// The median of `values` (mean of the two middle ones for an even count).
fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(v[n / 2 - 1] / 2.0 + v[n / 2] / 2.0),
    }
}

/// Renders `plot` into a row-major RGB buffer of `width * height * 3` bytes and returns it
/// with the data-to-pixel mapping of the axes.
pub(crate) fn render_rgb(
    plot: &StripPlot,
    width: u32,
    height: u32,
) -> Result<(Vec<u8>, Frame), PlotError> {
    check_size(width, height)?;
    let y = y_range(plot)?;
    render_frame(width, height, |root| draw(root, plot, y))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &StripPlot,
    y: std::ops::Range<f64>,
) -> Result<Frame, PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let body = if plot.title.is_empty() {
        root.clone()
    } else {
        root.titled(plot.title, (FONT, TITLE_FONT_PX))
            .map_err(draw_err)?
    };
    let n = plot.groups.len() as f64;
    let y_ticks = TickFormat::for_range(y.start, y.end);
    let y_bottom = y.start;
    let mut chart = ChartBuilder::on(&body)
        .margin(MARGIN_PX)
        .x_label_area_size(GROUP_LABEL_AREA_PX)
        .y_label_area_size(Y_LABEL_AREA_PX)
        .build_cartesian_2d(-0.5..n - 0.5, y)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .bold_line_style(RGBColor(225, 225, 225))
        .max_light_lines(0)
        .y_label_formatter(&|v| y_ticks.format(*v))
        .y_desc(plot.y_label)
        .label_style((FONT, TICK_FONT_PX))
        .axis_desc_style((FONT, DESC_FONT_PX))
        .draw()
        .map_err(draw_err)?;
    for (g, group) in plot.groups.iter().enumerate() {
        let colour = qualitative(g);
        let x = g as f64;
        let points = group
            .values
            .iter()
            .enumerate()
            .map(|(i, &v)| Circle::new((x + jitter(i), v), POINT_RADIUS_PX, colour.filled()));
        chart.draw_series(points).map_err(draw_err)?;
        if let Some(m) = median(group.values) {
            let bar = [(x - MEDIAN_HALF_WIDTH, m), (x + MEDIAN_HALF_WIDTH, m)];
            chart
                .draw_series([PathElement::new(bar, BLACK.stroke_width(2))])
                .map_err(draw_err)?;
        }
    }
    // Group labels under the axis, centred on their group (drawn on the root, in pixels).
    let label = TextStyle::from((FONT, TICK_FONT_PX).into_font())
        .pos(Pos::new(HPos::Center, VPos::Top))
        .color(&BLACK);
    let line_px = TICK_FONT_PX as i32 + 4;
    for (g, group) in plot.groups.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(g as f64, y_bottom));
        let top = py + 6;
        root.draw_text(group.label, &label, (px, top))
            .map_err(draw_err)?;
        if !group.note.is_empty() {
            root.draw_text(group.note, &label, (px, top + line_px))
                .map_err(draw_err)?;
        }
    }
    Ok(chart.as_coord_spec().clone())
}

#[cfg(test)]
#[path = "strip_plot_tests.rs"]
mod tests;
