//! Input checks for [`HeatMap`], done once before any drawing.

use crate::{HeatMap, PlotError, ShapeProblem};

/// Smallest accepted image width in pixels (room for the axes and the colour bar).
pub const MIN_IMAGE_WIDTH: u32 = 320;
/// Smallest accepted image height in pixels.
pub const MIN_IMAGE_HEIGHT: u32 = 200;
/// Largest accepted image width or height in pixels (bounds the RGB buffer to 48 MiB).
pub const MAX_IMAGE_SIDE: u32 = 4096;

/// A checked heat map: cell edges along both axes and the finite value range.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Grid {
    /// `nx + 1` cell edges along x, strictly increasing.
    pub x_edges: Vec<f64>,
    /// `ny + 1` cell edges along y, strictly increasing.
    pub y_edges: Vec<f64>,
    /// Smallest finite value.
    pub lo: f64,
    /// Largest finite value.
    pub hi: f64,
}

fn shape(field: &'static str, problem: ShapeProblem) -> PlotError {
    PlotError::Shape { field, problem }
}

/// Checks the image size.
pub(crate) fn check_size(width: u32, height: u32) -> Result<(), PlotError> {
    let side_ok = |v: u32, min: u32| (min..=MAX_IMAGE_SIDE).contains(&v);
    if side_ok(width, MIN_IMAGE_WIDTH) && side_ok(height, MIN_IMAGE_HEIGHT) {
        Ok(())
    } else {
        Err(PlotError::ImageSize { width, height })
    }
}

/// Edges half-way between grid points, extended by half a spacing at both ends.
fn cell_edges(field: &'static str, c: &[f64]) -> Result<Vec<f64>, PlotError> {
    if c.len() < 2 {
        return Err(shape(
            field,
            ShapeProblem::TooShort {
                len: c.len(),
                min: 2,
            },
        ));
    }
    if let Some(index) = c.iter().position(|v| !v.is_finite()) {
        return Err(shape(field, ShapeProblem::NonFinite { index }));
    }
    if let Some(w) = c.windows(2).position(|w| w[1] <= w[0]) {
        return Err(shape(field, ShapeProblem::NotIncreasing { index: w + 1 }));
    }
    let n = c.len();
    let mut edges = Vec::with_capacity(n + 1);
    // Half-way points written as a + (b - a) / 2 overflow for huge a, b; a / 2 + b / 2 does not.
    edges.push(c[0] - (c[1] / 2.0 - c[0] / 2.0));
    edges.extend(c.windows(2).map(|w| w[0] / 2.0 + w[1] / 2.0));
    edges.push(c[n - 1] + (c[n - 1] / 2.0 - c[n - 2] / 2.0));
    let first = edges[0];
    let last = edges[n];
    let strictly_increasing = edges.windows(2).all(|w| w[1] > w[0]);
    if !(first.is_finite() && last.is_finite() && (last - first).is_finite() && strictly_increasing)
    {
        return Err(shape(field, ShapeProblem::BadCellEdges));
    }
    Ok(edges)
}

/// Checks every field of `map` and returns the cell edges and value range.
pub(crate) fn check(map: &HeatMap) -> Result<Grid, PlotError> {
    let x_edges = cell_edges("x", map.x)?;
    let y_edges = cell_edges("y", map.y)?;
    let expected = map.x.len().saturating_mul(map.y.len());
    if map.values.len() != expected {
        let len = map.values.len();
        return Err(shape(
            "values",
            ShapeProblem::LengthMismatch { len, expected },
        ));
    }
    let (lo, hi) = map
        .values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return Err(shape("values", ShapeProblem::NoFiniteValue));
    }
    if let Some(index) = map
        .markers
        .iter()
        .position(|m| !(m.x.is_finite() && m.y.is_finite()))
    {
        return Err(shape("markers", ShapeProblem::NonFinite { index }));
    }
    Ok(Grid {
        x_edges,
        y_edges,
        lo,
        hi,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Marker, MarkerStyle};

    fn map<'a>(
        x: &'a [f64],
        y: &'a [f64],
        values: &'a [f64],
        markers: &'a [Marker<'a>],
    ) -> HeatMap<'a> {
        HeatMap {
            title: "t",
            x_label: "x",
            y_label: "y",
            colorbar_label: "c",
            x,
            y,
            values,
            markers,
        }
    }

    fn problem(r: Result<Grid, PlotError>) -> (&'static str, ShapeProblem) {
        match r {
            Err(PlotError::Shape { field, problem }) => (field, problem),
            other => panic!("expected a shape error, got {other:?}"),
        }
    }

    #[test]
    fn good_map_gives_edges_and_range() {
        let v = [1.0, f64::NAN, -2.0, f64::INFINITY, 5.0, 0.0];
        let g = check(&map(&[0.0, 1.0, 3.0], &[10.0, 20.0], &v, &[])).unwrap();
        assert_eq!(g.x_edges, vec![-0.5, 0.5, 2.0, 4.0]);
        assert_eq!(g.y_edges, vec![5.0, 15.0, 25.0]);
        assert_eq!((g.lo, g.hi), (-2.0, 5.0));
    }

    #[test]
    fn short_axes_are_rejected() {
        let r = check(&map(&[0.0], &[0.0, 1.0], &[1.0, 2.0], &[]));
        assert_eq!(problem(r), ("x", ShapeProblem::TooShort { len: 1, min: 2 }));
        let r = check(&map(&[0.0, 1.0], &[], &[], &[]));
        assert_eq!(problem(r), ("y", ShapeProblem::TooShort { len: 0, min: 2 }));
    }

    #[test]
    fn non_increasing_axes_are_rejected() {
        let v = [0.0; 6];
        let r = check(&map(&[0.0, 1.0, 1.0], &[0.0, 1.0], &v, &[]));
        assert_eq!(problem(r), ("x", ShapeProblem::NotIncreasing { index: 2 }));
        let r = check(&map(&[0.0, 1.0], &[0.0, -1.0, 2.0], &v, &[]));
        assert_eq!(problem(r), ("y", ShapeProblem::NotIncreasing { index: 1 }));
        let r = check(&map(&[0.0, f64::NAN, 2.0], &[0.0, 1.0], &v, &[]));
        assert_eq!(problem(r), ("x", ShapeProblem::NonFinite { index: 1 }));
    }

    #[test]
    fn bad_cell_edges_are_rejected() {
        let r = check(&map(&[-f64::MAX, f64::MAX], &[0.0, 1.0], &[0.0; 4], &[]));
        assert_eq!(problem(r), ("x", ShapeProblem::BadCellEdges));
        // Subnormal spacing: half of 5e-324 rounds to 0, so two edges coincide.
        let tiny = [0.0, 5e-324, 1e-323];
        let r = check(&map(&[0.0, 1.0], &tiny, &[0.0; 6], &[]));
        assert_eq!(problem(r), ("y", ShapeProblem::BadCellEdges));
    }

    #[test]
    fn wrong_value_count_is_rejected() {
        let r = check(&map(&[0.0, 1.0, 2.0], &[0.0, 1.0], &[0.0; 5], &[]));
        assert_eq!(
            problem(r),
            (
                "values",
                ShapeProblem::LengthMismatch {
                    len: 5,
                    expected: 6
                }
            )
        );
    }

    #[test]
    fn all_nan_values_are_rejected() {
        let v = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        let r = check(&map(&[0.0, 1.0], &[0.0, 1.0], &v, &[]));
        assert_eq!(problem(r), ("values", ShapeProblem::NoFiniteValue));
    }

    #[test]
    fn non_finite_marker_is_rejected() {
        let m = |x: f64| Marker {
            x,
            y: 0.0,
            label: "",
            style: MarkerStyle::Circle,
        };
        let markers = [m(0.5), m(f64::NAN)];
        let r = check(&map(&[0.0, 1.0], &[0.0, 1.0], &[0.0; 4], &markers));
        assert_eq!(
            problem(r),
            ("markers", ShapeProblem::NonFinite { index: 1 })
        );
    }

    #[test]
    fn image_size_limits() {
        assert!(check_size(MIN_IMAGE_WIDTH, MIN_IMAGE_HEIGHT).is_ok());
        assert!(check_size(MAX_IMAGE_SIDE, MAX_IMAGE_SIDE).is_ok());
        assert!(matches!(
            check_size(0, 600),
            Err(PlotError::ImageSize {
                width: 0,
                height: 600
            })
        ));
        assert!(check_size(800, MIN_IMAGE_HEIGHT - 1).is_err());
        assert!(check_size(MAX_IMAGE_SIDE + 1, 600).is_err());
    }
}
