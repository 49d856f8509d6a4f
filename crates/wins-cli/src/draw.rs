//! Draws a run's figures ([`wins::figures::RunFigures`]) as PNG files with `wins-plot`: the
//! track from above, height, attitude, AoA per AP, position σ, and with a truth the position
//! error in its ±σ band. A figure with nothing to draw is left out.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use wins::figures::{Points, RunFigures};
use wins::io_safety::replace_atomically;
use wins::run::run_dir::{
    AOA_PNG, ATTITUDE_PNG, HEIGHT_PNG, POSITION_ERROR_PNG, SIGMA_PNG, TRAJECTORY_PNG,
};
use wins_plot::{Marker, MarkerStyle, Series, SeriesStyle, VerticalLine, XyPlot, xy_plot_png};

/// Image width, px.
const WIDTH: u32 = 900;

fn series<'a>(label: &'a str, points: &'a [(f64, f64)], style: SeriesStyle) -> Series<'a> {
    Series {
        label,
        points,
        style,
    }
}

/// `points` with each y negated (the lower edge of a ±σ band).
fn negated(points: &[(f64, f64)]) -> Points {
    points.iter().map(|&(x, y)| (x, -y)).collect()
}

/// Draws `fig` into `out`; returns the files written.
pub fn draw_run(out: &Path, fig: &RunFigures) -> Result<Vec<PathBuf>> {
    let events: Vec<VerticalLine> = fig
        .events
        .iter()
        .map(|e| VerticalLine {
            x: e.t_s,
            label: e.kind.label(),
        })
        .collect();
    let truth = fig.truth.as_ref();
    let empty = Points::new();
    let mut written = Vec::new();
    let mut draw = |name: &str, plot: XyPlot, height: u32| -> Result<()> {
        let has_data = plot
            .series
            .iter()
            .any(|s| s.points.iter().any(|(x, y)| x.is_finite() && y.is_finite()))
            || !plot.markers.is_empty();
        if !has_data {
            return Ok(());
        }
        let path = out.join(name);
        // Drawn to a temporary file beside it and renamed: never half an image.
        replace_atomically(&path, |temp| {
            xy_plot_png(temp, &plot, WIDTH, height).map_err(std::io::Error::other)
        })
        .with_context(|| format!("drawing {}", path.display()))?;
        written.push(path);
        Ok(())
    };

    // The track from above, the APs and their 2σ ellipses.
    let ap_labels: Vec<String> = fig.aps.iter().map(|a| format!("{} 2σ", a.name)).collect();
    let mut track = vec![series("WINS", &fig.track_xy, SeriesStyle::Line)];
    if let Some(t) = truth {
        track.insert(0, series("truth", &t.track_xy, SeriesStyle::Line));
    }
    for (a, label) in fig.aps.iter().zip(&ap_labels) {
        track.push(series(label, &a.ellipse_2sigma, SeriesStyle::Line));
    }
    let marker = |(x, y): (f64, f64), label, style| Marker { x, y, label, style };
    let mut markers: Vec<Marker> = fig
        .aps
        .iter()
        .map(|a| marker(a.xy, "AP (estimated)", MarkerStyle::Cross))
        .collect();
    if let Some(t) = truth {
        markers.extend(
            t.aps_xy
                .iter()
                .map(|(_, xy)| marker(*xy, "AP (true)", MarkerStyle::Circle)),
        );
    }
    let frame = if truth.is_some() {
        "trajectory from above (estimate aligned to the truth)"
    } else {
        "trajectory from above (the estimate's world frame)"
    };
    draw(
        TRAJECTORY_PNG,
        XyPlot {
            title: frame,
            x_label: "x (m)",
            y_label: "y (m)",
            series: &track,
            markers: &markers,
            vertical_lines: &[],
            equal_aspect: true,
        },
        700,
    )?;

    // Height, with the barometer's and the truth's.
    let mut height = Vec::new();
    if !fig.baro_height.is_empty() {
        height.push(series(
            "barometer (shifted)",
            &fig.baro_height,
            SeriesStyle::Dots,
        ));
    }
    height.push(series("WINS", &fig.height, SeriesStyle::Line));
    if let Some(t) = truth {
        height.push(series("truth", &t.height, SeriesStyle::Line));
    }
    draw(
        HEIGHT_PNG,
        XyPlot {
            title: "height",
            x_label: "time (s)",
            y_label: "z (m)",
            series: &height,
            markers: &[],
            vertical_lines: &events,
            equal_aspect: false,
        },
        450,
    )?;

    // Attitude.
    let names = ["roll", "pitch", "yaw"];
    let truth_names = ["roll (truth)", "pitch (truth)", "yaw (truth)"];
    let mut attitude = Vec::new();
    for k in 0..3 {
        attitude.push(series(names[k], &fig.attitude_deg[k], SeriesStyle::Line));
        if let Some(t) = truth {
            attitude.push(series(
                truth_names[k],
                &t.attitude_deg[k],
                SeriesStyle::Edge,
            ));
        }
    }
    draw(
        ATTITUDE_PNG,
        XyPlot {
            title: "attitude (z-y-x Euler angles)",
            x_label: "time (s)",
            y_label: "angle (deg)",
            series: &attitude,
            markers: &[],
            vertical_lines: &events,
            equal_aspect: false,
        },
        500,
    )?;

    // AoA per AP: fed, dropped, truth.
    let labels: Vec<[String; 3]> = fig
        .aoa
        .iter()
        .map(|a| {
            [
                format!("{} fed", a.name),
                format!("{} dropped", a.name),
                format!("{} truth", a.name),
            ]
        })
        .collect();
    let dropped_points: Vec<Points> = fig
        .aoa
        .iter()
        .map(|a| [a.dropped.as_slice(), &a.dropped_without_aoa].concat())
        .collect();
    let mut aoa = Vec::new();
    for ((a, [fed, dropped, true_label]), dropped_at) in
        fig.aoa.iter().zip(&labels).zip(&dropped_points)
    {
        aoa.push(series(fed, &a.fed, SeriesStyle::Dots));
        if !dropped_at.is_empty() {
            aoa.push(series(dropped, dropped_at, SeriesStyle::Dots));
        }
        if !a.truth.is_empty() {
            aoa.push(series(true_label, &a.truth, SeriesStyle::Line));
        }
    }
    draw(
        AOA_PNG,
        XyPlot {
            title: "AoA per packet (dropped ones at their AoA, or the predicted one)",
            x_label: "time (s)",
            y_label: "AoA (deg)",
            series: &aoa,
            markers: &[],
            vertical_lines: &events,
            equal_aspect: false,
        },
        500,
    )?;

    // The position σ.
    let sigma_names = ["σ x", "σ y", "σ z"];
    let sigma: Vec<Series> = (0..3)
        .map(|k| series(sigma_names[k], &fig.sigma_m[k], SeriesStyle::Line))
        .collect();
    draw(
        SIGMA_PNG,
        XyPlot {
            title: "position σ the estimator reports (covariance.csv)",
            x_label: "time (s)",
            y_label: "σ (m)",
            series: &sigma,
            markers: &[],
            vertical_lines: &events,
            equal_aspect: false,
        },
        450,
    )?;

    // With a truth: the error per axis in its ±σ band.
    if let Some(t) = truth {
        let lower: Vec<Points> = fig.sigma_m.iter().map(|s| negated(s)).collect();
        let error_names = ["error x", "error y", "error z"];
        let band_names = ["±σ x", "±σ y", "±σ z"];
        let mut error = Vec::new();
        for k in 0..3 {
            error.push(series(error_names[k], &t.error_m[k], SeriesStyle::Line));
            error.push(series(band_names[k], &fig.sigma_m[k], SeriesStyle::Edge));
            error.push(series(
                "",
                lower.get(k).unwrap_or(&empty),
                SeriesStyle::Edge,
            ));
        }
        draw(
            POSITION_ERROR_PNG,
            XyPlot {
                title: "position error after alignment, per axis, in its ±σ band",
                x_label: "time (s)",
                y_label: "error (m)",
                series: &error,
                markers: &[],
                vertical_lines: &events,
                equal_aspect: false,
            },
            550,
        )?;
    }
    Ok(written)
}
