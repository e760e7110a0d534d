//! Per-radius candidate lists: the fast path of [`CliffMap::best_near`](super::CliffMap::best_near).
//!
//! For a given sampling radius, every grid cell (and a margin of cells around the map)
//! lists the locations that can lie within the radius of some point of the cell, sorted
//! by observation ratio (largest first, then by index). The location CLiFF-LHMP samples
//! from is then the first candidate that is actually within the radius.
//!
//! Each cell is further split into `n x n` sub-cells (n = 16, 8 or 4: the finest whose
//! table fits [`MAX_SUB_CELLS`]). A sub-cell stores its answer as a pair: a location to
//! test and the answer when the test fails. Where one location is the answer for every
//! point of the sub-cell (the usual case), or none is near any of its points, the test
//! is a sentinel that always fails; on the edge of one location's circle the test is
//! that location. A query is then one table load and one distance test, and its only
//! branches (nothing near, scan) are rarely taken. Only sub-cells where more circles
//! meet scan the cell's candidates.

use glam::DVec2;

use super::grid::GridIndex;

/// Largest sub-cell table (entries of 8 bytes) one radius gets: 16 MiB.
pub const MAX_SUB_CELLS: usize = 2 << 20;
/// Sub-cells per cell along each axis, as powers of two, finest first.
const SUB_SHIFTS: [u32; 3] = [4, 3, 2];
/// Sub-cell code: no location is near any point of the sub-cell.
const NONE_NEAR: u32 = u32::MAX;
/// Sub-cell code: the answer varies within the sub-cell; scan the cell's candidates.
const SCAN: u32 = u32::MAX - 1;

/// A sub-cell's answer: `test` if it is strictly within the radius of the query point,
/// else `otherwise` (a location index, [`NONE_NEAR`] or [`SCAN`]).
#[derive(Debug, Clone, Copy)]
struct SubCell {
    /// Index into [`NeighbourTable::points`]; the last point is a sentinel at infinity.
    test: u32,
    otherwise: u32,
}
/// Safety margin (m) for deciding a sub-cell's answer, larger than any rounding.
const MARGIN: f64 = 1e-9;
/// Largest number of candidate entries built.
const MAX_ENTRIES: usize = 16_000_000;

#[derive(Debug, Clone, Copy)]
struct Candidate {
    position: DVec2,
    index: u32,
}

/// Candidate lists for one radius.
#[derive(Debug)]
pub struct NeighbourTable {
    radius: f64,
    r2: f64,
    origin: DVec2,
    inv_sub: f64,
    /// Half the sub-cells per cell along an axis (the sub-cell grid is offset by it).
    half_sub: f64,
    /// log2 of the sub-cells per cell along an axis.
    shift: u32,
    nx: usize,
    /// Sub-cells along x and y, and the same as floats (for the range check).
    snx: usize,
    sub_dims: DVec2,
    offsets: Vec<u32>,
    candidates: Vec<Candidate>,
    /// The map's location positions, then the sentinel (never within the radius).
    points: Vec<DVec2>,
    sub: Vec<SubCell>,
}

impl NeighbourTable {
    /// Build the table for `radius`, giving up (with [`TableError::TooLarge`]) as soon
    /// as it would take more than `max_bytes` (or more than [`MAX_SUB_CELLS`] sub-cells
    /// and 16 million candidate entries whatever the budget), so that the time spent on a
    /// table that is not kept stays bounded too.
    pub(super) fn build(
        grid: &GridIndex,
        positions: &[DVec2],
        ratios: &[f64],
        radius: f64,
        max_bytes: usize,
    ) -> Result<Self, TableError> {
        let too_large = TableError::TooLarge {
            radius,
            limit: max_bytes,
        };
        if !(radius.is_finite() && radius > 0.0) {
            return Err(TableError::BadRadius { radius });
        }
        let step = grid.step();
        let margin_f = (radius / step).ceil() + 1.0;
        if margin_f > 1e6 {
            return Err(too_large);
        }
        let margin = margin_f as usize;
        let (gx, gy) = grid.dims();
        let nx = gx + 2 * margin;
        let ny = gy + 2 * margin;
        let cells = nx.checked_mul(ny).ok_or(too_large)?;
        let shift = *SUB_SHIFTS
            .iter()
            .find(|&&s| cells.saturating_mul(1 << (2 * s)) <= MAX_SUB_CELLS)
            .ok_or(too_large)?;
        let sub_n = 1usize << shift;
        // Sizes known before the candidate lists: sub-cells, offsets, points.
        let fixed = cells * sub_n * sub_n * size_of::<SubCell>()
            + (cells + 1) * size_of::<u32>()
            + (positions.len() + 1) * size_of::<DVec2>();
        if fixed > max_bytes {
            return Err(too_large);
        }
        let max_entries = ((max_bytes - fixed) / size_of::<Candidate>()).min(MAX_ENTRIES);
        let origin = grid.origin() - DVec2::splat(margin as f64 * step);
        let r2 = radius * radius;
        let mut offsets = Vec::with_capacity(nx * ny + 1);
        let mut candidates = Vec::new();
        let mut cell_list: Vec<u32> = Vec::new();
        // A cell (cx, cy) holds the points whose nearest cell centre it is:
        // the square of side `step` around origin + (cx, cy) * step.
        let half = 0.5 * step;
        for cy in 0..ny {
            for cx in 0..nx {
                offsets.push(candidates.len() as u32);
                let centre = origin + DVec2::new(cx as f64, cy as f64) * step;
                cell_list.clear();
                // Superset query: everything within radius + half-diagonal of the centre.
                grid.for_each_candidate(
                    centre,
                    radius + half * std::f64::consts::SQRT_2 + 1e-9,
                    |i| {
                        // Exact test: distance from the location to the cell square.
                        let d = (positions[i] - centre).abs() - DVec2::splat(half);
                        let d = d.max(DVec2::ZERO);
                        if d.length_squared() < r2 + 1e-12 {
                            cell_list.push(i as u32);
                        }
                    },
                );
                cell_list.sort_by(|&a, &b| {
                    ratios[b as usize]
                        .total_cmp(&ratios[a as usize])
                        .then(a.cmp(&b))
                });
                candidates.extend(cell_list.iter().map(|&i| Candidate {
                    position: positions[i as usize],
                    index: i,
                }));
                if candidates.len() > max_entries {
                    return Err(too_large);
                }
            }
        }
        offsets.push(candidates.len() as u32);
        // Resolve the sub-cells.
        let h = step / sub_n as f64;
        let snx = nx * sub_n;
        let sentinel = u32::try_from(positions.len())
            .ok()
            .filter(|&s| s < SCAN)
            .ok_or(too_large)?;
        let mut sub = Vec::with_capacity(snx * ny * sub_n);
        let (lo_r2, hi_r2) = (
            (radius - MARGIN).max(0.0).powi(2),
            (radius + MARGIN).powi(2),
        );
        for sy in 0..ny * sub_n {
            for sx in 0..snx {
                let cell = (sy >> shift) * nx + (sx >> shift);
                let list = &candidates[offsets[cell] as usize..offsets[cell + 1] as usize];
                // The sub-cell is the square of side h around `centre`.
                let centre = origin
                    + DVec2::new(
                        sx as f64 + 0.5 - sub_n as f64 / 2.0,
                        sy as f64 + 0.5 - sub_n as f64 / 2.0,
                    ) * h;
                let half = DVec2::splat(h / 2.0);
                let min_d2 = |q: DVec2| {
                    ((q - centre).abs() - half)
                        .max(DVec2::ZERO)
                        .length_squared()
                };
                let max_d2 = |q: DVec2| ((q - centre).abs() + half).length_squared();
                // The candidates (by ratio) that can be near some point of the sub-cell.
                let mut reachable = list.iter().filter(|c| min_d2(c.position) < hi_r2);
                let certain = |c: &Candidate| max_d2(c.position) < lo_r2;
                let (test, otherwise) = match reachable.next() {
                    None => (sentinel, NONE_NEAR),
                    Some(c) if certain(c) => (sentinel, c.index),
                    Some(c) => match reachable.next() {
                        None => (c.index, NONE_NEAR),
                        Some(d) if certain(d) => (c.index, d.index),
                        Some(_) => (sentinel, SCAN),
                    },
                };
                sub.push(SubCell { test, otherwise });
            }
        }
        Ok(Self {
            radius,
            r2,
            origin,
            inv_sub: sub_n as f64 / step,
            half_sub: sub_n as f64 / 2.0,
            shift,
            nx,
            snx,
            sub_dims: DVec2::new(snx as f64, (ny * sub_n) as f64),
            offsets,
            candidates,
            points: positions
                .iter()
                .copied()
                .chain([DVec2::splat(f64::INFINITY)])
                .collect(),
            sub,
        })
    }

    /// The radius this table answers for.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Bytes the table holds.
    pub fn memory_bytes(&self) -> usize {
        self.offsets.len() * size_of::<u32>()
            + self.candidates.len() * size_of::<Candidate>()
            + self.points.len() * size_of::<DVec2>()
            + self.sub.len() * size_of::<SubCell>()
    }

    /// The longest candidate list of a cell: the most distance tests one query can make.
    pub fn max_scan(&self) -> usize {
        self.offsets
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .max()
            .unwrap_or(0)
    }

    /// The location with the largest observation ratio strictly within the radius of
    /// `p` (ties: the lowest index), as [`CliffMap::best_near`](super::CliffMap::best_near).
    ///
    /// The usual answer is one table load and one distance test, inlined into the
    /// prediction loop; sub-cells where several circles meet scan their cell's
    /// candidates out of line.
    #[inline(always)]
    pub fn best_near(&self, p: DVec2) -> Option<usize> {
        let f = (p - self.origin) * self.inv_sub + DVec2::splat(self.half_sub);
        if !(f.x >= 0.0 && f.y >= 0.0 && f.x < self.sub_dims.x && f.y < self.sub_dims.y) {
            // Outside the map and its margin (or NaN): nothing can be near.
            return None;
        }
        // In range (checked above), so the truncating conversions are exact floors.
        let (sx, sy) = (f.x as u32 as usize, f.y as u32 as usize);
        let cell = self.sub[sy * self.snx + sx];
        let test = self.points[cell.test as usize];
        // The pair's location if the point is within its circle, else the fallback.
        let code = if test.distance_squared(p) < self.r2 {
            cell.test
        } else {
            cell.otherwise
        };
        match code {
            NONE_NEAR => None,
            SCAN => self.scan(p, sx, sy),
            i => Some(i as usize),
        }
    }

    /// The first candidate of sub-cell `(sx, sy)`'s cell within the radius of `p`.
    #[inline(never)]
    fn scan(&self, p: DVec2, sx: usize, sy: usize) -> Option<usize> {
        let cell = (sy >> self.shift) * self.nx + (sx >> self.shift);
        let (a, b) = (self.offsets[cell] as usize, self.offsets[cell + 1] as usize);
        self.candidates[a..b]
            .iter()
            .find(|c| c.position.distance_squared(p) < self.r2)
            .map(|c| c.index as usize)
    }
}

/// Why a neighbour table was not built.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TableError {
    /// The radius is not a positive number.
    #[error("radius {radius} is not a positive number")]
    BadRadius {
        /// The radius asked for.
        radius: f64,
    },
    /// The table would be larger than the budget (or than a table can be at all).
    #[error("the table for radius {radius} m needs more than {limit} bytes")]
    TooLarge {
        /// The radius asked for.
        radius: f64,
        /// The size it exceeded (bytes).
        limit: usize,
    },
}
