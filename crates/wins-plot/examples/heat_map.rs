//! Renders a synthetic MUSIC-like spectrum with two peaks to the PNG given as first argument
//! (default `heat_map.png`): `cargo run -p wins-plot --example heat_map -- /tmp/map.png`.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use wins_plot::{HeatMap, Marker, MarkerStyle, PlotError, heat_map_png};

fn main() -> Result<(), PlotError> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "heat_map.png".into());
    let aoa: Vec<f64> = (0..=180).map(|i| -90.0 + i as f64).collect();
    let tof: Vec<f64> = (0..=100).map(|i| i as f64).collect();
    let peaks = [(-20.0, 30.0, 1.0), (35.0, 60.0, 0.4)];
    let mut values = Vec::with_capacity(aoa.len() * tof.len());
    for &t in &tof {
        for &a in &aoa {
            let p: f64 = peaks
                .iter()
                .map(|&(pa, pt, w)| {
                    w / (1e-3 + ((a - pa) / 15.0).powi(2) + ((t - pt) / 10.0).powi(2))
                })
                .sum();
            values.push(10.0 * p.log10());
        }
    }
    let markers = [
        Marker {
            x: -20.0,
            y: 30.0,
            label: "detected peak",
            style: MarkerStyle::Cross,
        },
        Marker {
            x: 35.0,
            y: 60.0,
            label: "detected peak",
            style: MarkerStyle::Cross,
        },
        Marker {
            x: -17.0,
            y: 33.0,
            label: "direct path (truth)",
            style: MarkerStyle::Circle,
        },
    ];
    let map = HeatMap {
        title: "MUSIC spectrum, packet 42",
        x_label: "AoA (deg)",
        y_label: "ToF (ns)",
        colorbar_label: "spectrum (dB)",
        x: &aoa,
        y: &tof,
        values: &values,
        markers: &markers,
    };
    heat_map_png(std::path::Path::new(&path), &map, 800, 600)
}
