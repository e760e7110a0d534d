//! The caller's grid: where it lies, its cells and their size.

use super::OccupancyError;

/// The most cells one grid may have (2^26, e.g. 8192 x 8192): bounds the cost of a
/// grid that arrives from a request before any work is done.
pub const MAX_CELLS: usize = 1 << 26;

/// A regular grid of square cells in the map's frame, laid out like a ROS
/// `nav_msgs/OccupancyGrid`: `origin` is the outer corner of cell (row 0, column 0),
/// columns go along +x, rows along +y, and a layer is stored row-major (cell
/// `(row, col)` at `row * width + col`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// The corner of cell (0, 0) with the smallest x and y (m).
    pub origin: [f64; 2],
    /// The side of a cell (m).
    pub resolution: f64,
    /// Columns (cells along x).
    pub width: usize,
    /// Rows (cells along y).
    pub height: usize,
}

impl GridSpec {
    /// A grid of `size[0] x size[1]` metres centred on `center` (the number of cells is
    /// rounded up, so the grid covers at least that much).
    pub fn around(center: [f64; 2], size: [f64; 2], resolution: f64) -> Self {
        let width = cells_for(size[0], resolution);
        let height = cells_for(size[1], resolution);
        Self {
            origin: [
                center[0] - width as f64 * resolution / 2.0,
                center[1] - height as f64 * resolution / 2.0,
            ],
            resolution,
            width,
            height,
        }
    }

    /// The grid covering the box from `min` to `max` (for instance a map's extent),
    /// with its origin at `min`.
    pub fn covering(min: [f64; 2], max: [f64; 2], resolution: f64) -> Self {
        Self {
            origin: min,
            resolution,
            width: cells_for(max[0] - min[0], resolution),
            height: cells_for(max[1] - min[1], resolution),
        }
    }

    /// Cells per layer.
    pub fn cells(&self) -> usize {
        self.width * self.height
    }

    /// Check the grid: a positive finite resolution, a finite origin, at least one
    /// cell and at most [`MAX_CELLS`].
    pub fn validate(&self) -> Result<(), OccupancyError> {
        let bad = |why: String| Err(OccupancyError::Grid(why));
        if !(self.resolution.is_finite() && self.resolution > 0.0) {
            return bad(format!(
                "resolution {} is not a positive number",
                self.resolution
            ));
        }
        if !(self.origin[0].is_finite() && self.origin[1].is_finite()) {
            return bad(format!("origin {:?} is not finite", self.origin));
        }
        if self.width == 0 || self.height == 0 {
            return bad(format!("{} x {} cells is empty", self.width, self.height));
        }
        match self.width.checked_mul(self.height) {
            Some(n) if n <= MAX_CELLS => Ok(()),
            _ => bad(format!(
                "{} x {} cells is more than {MAX_CELLS}",
                self.width, self.height
            )),
        }
    }

    /// The cell `(row, col)` holding the point, if the grid holds it.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        let c = ((x - self.origin[0]) / self.resolution).floor();
        let r = ((y - self.origin[1]) / self.resolution).floor();
        if c >= 0.0 && r >= 0.0 && (c as usize) < self.width && (r as usize) < self.height {
            Some((r as usize, c as usize))
        } else {
            None
        }
    }

    /// The centre of cell `(row, col)`.
    pub fn cell_center(&self, row: usize, col: usize) -> [f64; 2] {
        [
            self.origin[0] + (col as f64 + 0.5) * self.resolution,
            self.origin[1] + (row as f64 + 0.5) * self.resolution,
        ]
    }
}

/// Cells to cover `length` metres at `resolution` (at least one; 0 for unusable input,
/// which [`GridSpec::validate`] then refuses).
fn cells_for(length: f64, resolution: f64) -> usize {
    let n = (length / resolution - 1e-9).ceil();
    if n.is_finite() && n >= 1.0 {
        n.min(usize::MAX as f64 / 2.0) as usize
    } else if n.is_finite() && length > 0.0 {
        1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn around_centres_the_grid_and_cells_hold_their_points() {
        let g = GridSpec::around([1.0, -2.0], [20.0, 10.0], 0.1);
        assert_eq!((g.width, g.height), (200, 100));
        assert!((g.origin[0] + 9.0).abs() < 1e-9 && (g.origin[1] + 7.0).abs() < 1e-9);
        assert_eq!(g.cell_of(1.0, -2.0), Some((50, 100)));
        assert_eq!(g.cell_of(-9.0, -7.0), Some((0, 0)));
        assert_eq!(g.cell_of(11.0, -2.0), None);
        assert_eq!(g.cell_of(-9.01, -2.0), None);
        let c = g.cell_center(50, 100);
        assert!((c[0] - 1.05).abs() < 1e-9 && (c[1] + 1.95).abs() < 1e-9);
        g.validate().unwrap();
    }

    #[test]
    fn unusable_grids_are_refused_with_the_reason() {
        let ok = GridSpec::around([0.0, 0.0], [4.0, 4.0], 0.5);
        for (g, word) in [
            (
                GridSpec {
                    resolution: 0.0,
                    ..ok
                },
                "resolution",
            ),
            (
                GridSpec {
                    resolution: f64::NAN,
                    ..ok
                },
                "resolution",
            ),
            (
                GridSpec {
                    origin: [f64::INFINITY, 0.0],
                    ..ok
                },
                "origin",
            ),
            (GridSpec { width: 0, ..ok }, "empty"),
            (
                GridSpec {
                    width: 1 << 20,
                    height: 1 << 20,
                    ..ok
                },
                "more than",
            ),
            (
                GridSpec {
                    width: usize::MAX,
                    height: 3,
                    ..ok
                },
                "more than",
            ),
        ] {
            let e = g.validate().unwrap_err().to_string();
            assert!(e.starts_with("grid: ") && e.contains(word), "{e}");
        }
    }
}
