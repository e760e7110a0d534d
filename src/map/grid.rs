//! A dense grid index over map locations.
//!
//! CLiFF-map locations sit on a regular grid, so each grid cell holds at most one
//! location. A radius query visits only the `(2m + 1)^2` cells around the query point
//! with `m = ceil(radius / step)`, never the whole map.

use glam::DVec2;

use super::{
    FREE_GRID_CELLS, MAX_COORDINATE, MAX_GRID_CELLS, MAX_GRID_CELLS_PER_LOCATION, MAX_GRID_STEP,
    MIN_GRID_STEP, MapError,
};

const EMPTY: u32 = u32::MAX;

/// Maps grid cells to location indices.
#[derive(Debug, Clone)]
pub struct GridIndex {
    origin: DVec2,
    step: f64,
    nx: usize,
    ny: usize,
    cells: Vec<u32>,
}

/// Tolerance, as a share of the step, for a coordinate to count as on the grid.
const ON_GRID_TOLERANCE: f64 = 1e-3;

fn infer_step(values: impl Iterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(|a, b| a.total_cmp(b));
    v.windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 1e-6)
        .min_by(|a, b| a.total_cmp(b))
}

impl GridIndex {
    /// Index `positions` on a grid of `step` metres (inferred from the smallest
    /// spacing of the coordinates when `None`; 1 m for a single location).
    ///
    /// Fails when a position is not finite or beyond [`MAX_COORDINATE`], when the step is
    /// not in [[`MIN_GRID_STEP`], [`MAX_GRID_STEP`]], when the bounding box holds more than
    /// [`MAX_GRID_CELLS`] cells at that step (or more than [`FREE_GRID_CELLS`] and more
    /// than [`MAX_GRID_CELLS_PER_LOCATION`] per location), when a position is off the
    /// grid, or when two positions share a cell.
    pub fn new(positions: &[DVec2], step: Option<f64>) -> Result<Self, MapError> {
        if positions.is_empty() {
            return Err(MapError::Empty);
        }
        let step = match step {
            Some(s) => s,
            None => {
                let sx = infer_step(positions.iter().map(|p| p.x));
                let sy = infer_step(positions.iter().map(|p| p.y));
                match (sx, sy) {
                    (Some(a), Some(b)) => a.min(b),
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => 1.0,
                }
                // Coordinates are printed with a few decimals: snap to micrometres.
                .mul_add(1e6, 0.0)
                .round()
                    / 1e6
            }
        };
        let at = |index: usize, message: String| MapError::Location {
            index,
            x: positions[index].x,
            y: positions[index].y,
            message,
        };
        if let Some(i) = positions
            .iter()
            .position(|p| !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE))
        {
            return Err(at(
                i,
                format!("position is not finite or beyond {MAX_COORDINATE} m from the origin"),
            ));
        }
        if !(step.is_finite() && (MIN_GRID_STEP..=MAX_GRID_STEP).contains(&step)) {
            return Err(at(
                0,
                format!("grid step {step:?} m is not in [{MIN_GRID_STEP}, {MAX_GRID_STEP}] m"),
            ));
        }
        let lo = positions
            .iter()
            .fold(DVec2::splat(f64::INFINITY), |a, p| a.min(*p));
        let hi = positions
            .iter()
            .fold(DVec2::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
        // Counted in floating point: positions are bounded and the step is not tiny, so
        // these are exact small integers or, for absurd maps, large but finite numbers.
        let fnx = ((hi.x - lo.x) / step).round() + 1.0;
        let fny = ((hi.y - lo.y) / step).round() + 1.0;
        let budget = positions
            .len()
            .saturating_mul(MAX_GRID_CELLS_PER_LOCATION)
            .clamp(FREE_GRID_CELLS, MAX_GRID_CELLS);
        if fnx * fny > budget as f64 {
            // Name the location farthest from the first one: the likely stray.
            let p0 = positions[0];
            let far = (0..positions.len())
                .max_by(|&a, &b| {
                    let da = (positions[a] - p0).abs().max_element();
                    let db = (positions[b] - p0).abs().max_element();
                    da.total_cmp(&db).then(b.cmp(&a))
                })
                .unwrap_or(0);
            return Err(at(
                far,
                format!(
                    "the map's bounding box x {} .. {}, y {} .. {} m is {fnx} x {fny} cells \
                     at grid step {step} m, more than {budget} (for {} locations)",
                    lo.x,
                    hi.x,
                    lo.y,
                    hi.y,
                    positions.len()
                ),
            ));
        }
        let (nx, ny) = (fnx as usize, fny as usize);
        let mut cells = vec![EMPTY; nx * ny];
        for (i, p) in positions.iter().enumerate() {
            let fx = (p.x - lo.x) / step;
            let fy = (p.y - lo.y) / step;
            let (cx, cy) = (fx.round(), fy.round());
            if (fx - cx).abs() > ON_GRID_TOLERANCE || (fy - cy).abs() > ON_GRID_TOLERANCE {
                return Err(MapError::Location {
                    index: i,
                    x: p.x,
                    y: p.y,
                    message: format!("off the grid (step {step} m from ({}, {}))", lo.x, lo.y),
                });
            }
            let cell = &mut cells[cy as usize * nx + cx as usize];
            if *cell != EMPTY {
                return Err(MapError::Location {
                    index: i,
                    x: p.x,
                    y: p.y,
                    message: format!("same grid cell as location {}", *cell),
                });
            }
            *cell = i as u32;
        }
        Ok(Self {
            origin: lo,
            step,
            nx,
            ny,
            cells,
        })
    }

    /// The grid step (m).
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The position of grid cell (0, 0).
    pub fn origin(&self) -> DVec2 {
        self.origin
    }

    /// Number of cells along x and y.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// The most locations [`for_each_candidate`](Self::for_each_candidate) can visit
    /// for `radius`: the cells whose centres lie in a square of side `2 r` around the
    /// point (`r` = radius in cells), at most `floor(2 r) + 1` along each axis and one
    /// location per cell, capped by the grid's size.
    pub fn max_candidates(&self, radius: f64) -> usize {
        let r = radius / self.step + ON_GRID_TOLERANCE;
        if r.is_nan() || r < 0.0 {
            return 0;
        }
        let side = |n: usize| ((2.0 * r).floor() + 1.0).min(n as f64) as usize;
        side(self.nx) * side(self.ny)
    }

    /// Call `f` with every location whose cell lies within `radius` (plus half a cell)
    /// of `p` along both axes: a superset of the locations within `radius`.
    #[inline]
    pub fn for_each_candidate(&self, p: DVec2, radius: f64, mut f: impl FnMut(usize)) {
        let inv = 1.0 / self.step;
        let fx = (p.x - self.origin.x) * inv;
        let fy = (p.y - self.origin.y) * inv;
        // Widened by the on-grid tolerance: positions may sit that far from their cell.
        let r = radius * inv + ON_GRID_TOLERANCE;
        if !(fx.is_finite() && fy.is_finite() && r.is_finite()) {
            return;
        }
        // Cells whose centre is within r of p along each axis.
        let x0 = (fx - r).ceil().max(0.0);
        let x1 = (fx + r).floor().min(self.nx as f64 - 1.0);
        let y0 = (fy - r).ceil().max(0.0);
        let y1 = (fy + r).floor().min(self.ny as f64 - 1.0);
        if x0 > x1 || y0 > y1 {
            return;
        }
        let (x0, x1, y0, y1) = (x0 as usize, x1 as usize, y0 as usize, y1 as usize);
        for cy in y0..=y1 {
            let row = &self.cells[cy * self.nx + x0..=cy * self.nx + x1];
            for &c in row {
                if c != EMPTY {
                    f(c as usize);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn infers_step_and_finds_candidates_only_nearby() {
        let pts: Vec<DVec2> = (0..10)
            .flat_map(|i| {
                (0..10).map(move |j| DVec2::new(-3.25 + 0.5 * i as f64, 1.75 + 0.5 * j as f64))
            })
            .collect();
        let g = GridIndex::new(&pts, None).unwrap();
        assert!((g.step() - 0.5).abs() < 1e-12);
        assert_eq!(g.dims(), (10, 10));
        let p = DVec2::new(-1.0, 3.0);
        let mut got = vec![];
        g.for_each_candidate(p, 0.7071, |i| got.push(i));
        // every true neighbour is a candidate, and candidates are few
        for (i, q) in pts.iter().enumerate() {
            if q.distance(p) < 0.7071 {
                assert!(got.contains(&i));
            }
        }
        assert!(got.len() <= 9, "{}", got.len());
        // far outside: nothing
        let mut n = 0;
        g.for_each_candidate(DVec2::new(100.0, 100.0), 1.0, |_| n += 1);
        assert_eq!(n, 0);
        g.for_each_candidate(DVec2::new(f64::NAN, 0.0), 1.0, |_| n += 1);
        assert_eq!(n, 0);
    }

    #[test]
    fn bounds_positions_steps_and_cell_counts() {
        let msg =
            |pts: &[DVec2], step: Option<f64>| GridIndex::new(pts, step).unwrap_err().to_string();
        // x = 1e20 used to overflow the cell count and index out of bounds
        let e = msg(&[DVec2::ZERO, DVec2::new(1e20, 0.0)], None);
        assert!(e.contains("location 1") && e.contains("beyond"), "{e}");
        let e = msg(&[DVec2::ZERO, DVec2::new(1e20, 0.0)], Some(0.5));
        assert!(e.contains("location 1") && e.contains("beyond"), "{e}");
        // a step of 1e300 m used to be accepted
        let e = msg(&[DVec2::ZERO], Some(1e300));
        assert!(e.contains("grid step 1e300 m is not in"), "{e}");
        for step in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-4, 1001.0] {
            assert!(msg(&[DVec2::ZERO], Some(step)).contains("grid step"));
        }
        assert!(GridIndex::new(&[DVec2::ZERO], Some(MIN_GRID_STEP)).is_ok());
        assert!(GridIndex::new(&[DVec2::ZERO], Some(MAX_GRID_STEP)).is_ok());
        // bounding box too large for the step: names the stray location
        let e = msg(
            &[DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1e4, 1e4)],
            Some(1.0),
        );
        assert!(e.contains("location 2") && e.contains("cells"), "{e}");
        // the largest grid that passes: 4096 x 4096 = 2^24 cells, for 4096 locations
        let mut pts: Vec<DVec2> = (0..4096).map(|i| DVec2::new(i as f64, 0.0)).collect();
        pts[1] = DVec2::new(1.0, 4095.0);
        let g = GridIndex::new(&pts, Some(1.0)).unwrap();
        assert_eq!(g.dims(), (4096, 4096));
        pts.push(DVec2::new(4096.0, 0.0));
        let e = msg(&pts, Some(1.0));
        assert!(e.contains("4097 x 4096 cells"), "{e}");
        // two locations get 2^16 cells, not more
        assert!(GridIndex::new(&[DVec2::ZERO, DVec2::splat(255.0)], Some(1.0)).is_ok());
        let e = msg(&[DVec2::ZERO, DVec2::new(256.0, 255.0)], Some(1.0));
        assert!(
            e.contains("257 x 256 cells") && e.contains("more than 65536 (for 2 locations)"),
            "{e}"
        );
    }

    #[test]
    fn rejects_off_grid_and_duplicates() {
        let e = GridIndex::new(
            &[DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(1.5, 0.3)],
            Some(1.0),
        )
        .unwrap_err();
        assert!(e.to_string().contains("off the grid"), "{e}");
        assert!(e.to_string().contains("location 2"), "{e}");
        let e = GridIndex::new(&[DVec2::ZERO, DVec2::ZERO], Some(1.0)).unwrap_err();
        assert!(e.to_string().contains("same grid cell"), "{e}");
    }
}
