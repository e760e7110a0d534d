//! A person's box of cells held as a small dense buffer whose rows are a whole number
//! of eight cells long, and one sample's kernel placed on it: the kernels of the
//! person's samples are added (or, for a window, raised) into the tile eight cells at a
//! time, with no partial vector at either end of a row, and the tile is folded into a
//! layer once per person.

use std::collections::TryReserveError;

use super::GridSpec;
use super::kernel::{AxisNormal, LANES, axis_box, axis_span};

/// `n` rounded up to a whole number of [`LANES`].
fn lanes_for(n: usize) -> usize {
    n.div_ceil(LANES) * LANES
}

/// Make room for `n` elements (no allocation when there is).
pub(super) fn grow<T>(v: &mut Vec<T>, n: usize) -> Result<(), TryReserveError> {
    v.try_reserve(n.saturating_sub(v.len()))
}

/// A box of cells, rows and columns inclusive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct CellBox {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

impl CellBox {
    /// Grow to hold `o` too.
    pub fn join(&mut self, o: CellBox) {
        self.r0 = self.r0.min(o.r0);
        self.r1 = self.r1.max(o.r1);
        self.c0 = self.c0.min(o.c0);
        self.c1 = self.c1.max(o.c1);
    }
}

/// The box of cells that kernels of half-width `reach` (m) centred anywhere in the
/// rectangle `[min, max]` reach on the grid, or `None` when none reaches it. It holds
/// the box of every such kernel ([`Kernel::place`]): the edges are the same monotone
/// expressions of the centre.
pub(super) fn reach_box(
    grid: &GridSpec,
    min: [f32; 2],
    max: [f32; 2],
    reach: f32,
) -> Option<CellBox> {
    let res = grid.resolution as f32;
    let (ox, oy) = (grid.origin[0] as f32, grid.origin[1] as f32);
    let (c0, c1) = axis_span(min[0], max[0], reach, ox, res, grid.width)?;
    let (r0, r1) = axis_span(min[1], max[1], reach, oy, res, grid.height)?;
    Some(CellBox { r0, r1, c0, c1 })
}

/// The smallest and largest coordinates of `points` (`None` for no finite point).
pub(super) fn extent(points: &[[f32; 2]]) -> Option<([f32; 2], [f32; 2])> {
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for p in points {
        for a in 0..2 {
            if p[a].is_finite() {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    (lo[0] <= hi[0] && lo[1] <= hi[1]).then_some((lo, hi))
}

/// One sample's kernel on a tile: the box of grid cells it covers, the masses of its
/// rows (`my`, the first `rows`), and the masses of its columns (`mx`, the first
/// `cols`) from its first column (the tile column `lead`) over a whole number of eight
/// cells (zero past the box). `mx` and `my` keep the length [`size_for`](Self::size_for)
/// gave them: a kernel writes its part.
#[derive(Debug, Clone, Default)]
pub(super) struct Kernel {
    pub cells: Option<CellBox>,
    mx: Vec<f32>,
    my: Vec<f32>,
    cols: usize,
    rows: usize,
    lead: usize,
    /// The normal of the last kernel's width on the last grid's cells.
    axis: AxisNormal,
}

impl Kernel {
    /// Room for any kernel on the grid (no allocation when there is).
    pub fn size_for(&mut self, grid: &GridSpec) -> Result<(), TryReserveError> {
        let (cols, rows) = (lanes_for(grid.width) + LANES, lanes_for(grid.height));
        grow(&mut self.mx, cols)?;
        grow(&mut self.my, rows)?;
        self.mx.resize(self.mx.len().max(cols), 0.0);
        self.my.resize(self.my.len().max(rows), 0.0);
        Ok(())
    }

    /// The kernel of width `sigma` (cut at `reach`, m) of a sample at `p`, placed on a
    /// tile covering `area` (which must hold the kernel's box: [`reach_box`] of the
    /// samples); `false` when it misses the grid.
    #[inline(always)]
    pub fn place(
        &mut self,
        grid: &GridSpec,
        p: [f32; 2],
        sigma: f32,
        reach: f32,
        area: CellBox,
    ) -> bool {
        let res = grid.resolution as f32;
        let (ox, oy) = (grid.origin[0] as f32, grid.origin[1] as f32);
        let boxes = axis_box(p[0], reach, ox, res, grid.width).zip(axis_box(
            p[1],
            reach,
            oy,
            res,
            grid.height,
        ));
        let Some(((c0, c1), (r0, r1))) = boxes else {
            self.cells = None;
            return false;
        };
        // the masses over whole registers of cells (the loop has no scalar tail), the
        // cells past the kernel's box then cleared: it is cut at `reach`
        self.lead = c0 - area.c0;
        let cols = c1 - c0 + 1;
        self.cols = lanes_for(cols);
        if self.axis.sigma != sigma || self.axis.resolution != res {
            self.axis = AxisNormal::new(sigma, res);
        }
        let mx = &mut self.mx[..self.cols];
        self.axis.mass(p[0], ox, c0, mx);
        mx[cols..].fill(0.0);
        self.rows = r1 - r0 + 1;
        self.axis
            .mass(p[1], oy, r0, &mut self.my[..lanes_for(self.rows)]);
        self.cells = Some(CellBox { r0, r1, c0, c1 });
        true
    }
}

/// A box of the grid's cells (`area`) held densely, rows of `stride` cells (room for
/// whole registers from any column of the box; the columns past it stay zero);
/// all zero between uses. `touched` is the part written since the tile was last
/// cleared, in tile rows and columns.
#[derive(Debug, Clone, Default)]
pub(super) struct Tile {
    cells: Vec<f32>,
    stride: usize,
    area: Option<CellBox>,
    touched: Option<CellBox>,
}

impl Tile {
    /// Room for any box of the grid, all zero (no allocation when there is room).
    pub fn size_for(&mut self, grid: &GridSpec) -> Result<(), TryReserveError> {
        let n = (lanes_for(grid.width) + 2 * LANES) * grid.height;
        grow(&mut self.cells, n)?;
        self.cells.clear();
        self.cells.resize(n, 0.0);
        self.area = None;
        self.touched = None;
        Ok(())
    }

    /// Cover `area` of the grid (the tile must be clear).
    pub fn cover(&mut self, area: CellBox) {
        debug_assert!(self.touched.is_none());
        self.stride = lanes_for(area.c1 - area.c0 + 1) + 2 * LANES;
        self.area = Some(area);
    }

    fn touch(&mut self, rows: (usize, usize), cols: (usize, usize)) {
        let b = CellBox {
            r0: rows.0,
            r1: rows.1,
            c0: cols.0,
            c1: cols.1,
        };
        match &mut self.touched {
            Some(t) => t.join(b),
            None => self.touched = Some(b),
        }
    }

    /// The kernel's rows and the tile's columns it spans: `(first row, rows, first
    /// column, columns)` in tile cells.
    #[inline(always)]
    fn span(&self, k: &Kernel) -> Option<(usize, usize, usize, usize)> {
        let (area, cells) = (self.area?, k.cells?);
        Some((cells.r0 - area.r0, k.rows, k.lead, k.cols))
    }

    /// Add `w` times the kernel (the outer product of its row and column masses).
    #[inline(always)]
    pub fn add(&mut self, k: &Kernel, w: f32) {
        let Some((r0, rows, c0, cols)) = self.span(k) else {
            return;
        };
        // a kernel's columns held in registers for all its rows
        match cols / LANES {
            1 => self.add_rows::<1>(k, w, r0, rows, c0),
            2 => self.add_rows::<2>(k, w, r0, rows, c0),
            3 => self.add_rows::<3>(k, w, r0, rows, c0),
            4 => self.add_rows::<4>(k, w, r0, rows, c0),
            5 => self.add_rows::<5>(k, w, r0, rows, c0),
            6 => self.add_rows::<6>(k, w, r0, rows, c0),
            _ => self.each_chunk(k, (r0, rows, c0, cols), |fy, o, m| {
                // (through registers: the eight loads, then the eight stores)
                let (wy, mut v) = (w * fy, *o);
                for j in 0..LANES {
                    v[j] += wy * m[j];
                }
                *o = v;
            }),
        }
        self.touch((r0, r0 + rows - 1), (c0, c0 + cols - 1));
    }

    /// [`add`](Self::add) for a kernel `N` registers wide: its column masses loaded
    /// once.
    #[inline(always)]
    fn add_rows<const N: usize>(&mut self, k: &Kernel, w: f32, r0: usize, rows: usize, c0: usize) {
        let mut m = [[0.0f32; LANES]; N];
        for (m, x) in m.iter_mut().zip(k.mx[..N * LANES].as_chunks::<LANES>().0) {
            *m = *x;
        }
        for (r, &fy) in (r0..r0 + rows).zip(&k.my[..rows]) {
            let wy = w * fy;
            let at = r * self.stride + c0;
            let row = self.cells[at..at + N * LANES].as_chunks_mut::<LANES>().0;
            for (o, m) in row.iter_mut().zip(&m) {
                let mut v = *o;
                for j in 0..LANES {
                    v[j] += wy * m[j];
                }
                *o = v;
            }
        }
    }

    /// `f(row mass, eight cells, their column masses)` for each eight cells of the
    /// kernel's span `(first row, rows, first column, columns)` ([`span`](Self::span)).
    #[inline(always)]
    fn each_chunk(
        &mut self,
        k: &Kernel,
        (r0, rows, c0, cols): (usize, usize, usize, usize),
        mut f: impl FnMut(f32, &mut [f32; LANES], &[f32; LANES]),
    ) {
        for (r, &fy) in (r0..r0 + rows).zip(&k.my[..rows]) {
            let row = &mut self.cells[r * self.stride + c0..r * self.stride + c0 + cols];
            for (o, m) in row
                .as_chunks_mut::<LANES>()
                .0
                .iter_mut()
                .zip(k.mx[..cols].as_chunks::<LANES>().0)
            {
                f(fy, o, m);
            }
        }
    }

    /// Raise each cell to the kernel's mass there where that is larger.
    #[inline(always)]
    pub fn raise(&mut self, k: &Kernel) {
        let Some((r0, rows, c0, cols)) = self.span(k) else {
            return;
        };
        self.each_chunk(k, (r0, rows, c0, cols), |fy, o, m| {
            let mut v = *o;
            for j in 0..LANES {
                v[j] = v[j].max(fy * m[j]);
            }
            *o = v;
        });
        self.touch((r0, r0 + rows - 1), (c0, c0 + cols - 1));
    }

    /// Add `w` times this tile's touched cells into `other` (a tile over the same area)
    /// and clear this one.
    #[inline(always)]
    pub fn move_into(&mut self, other: &mut Tile, w: f32) {
        let Some(t) = self.touched.take() else {
            return;
        };
        debug_assert!(other.area == self.area);
        // whole registers: the columns past the kernels are zero
        let last = t.c0 + lanes_for(t.c1 - t.c0 + 1) - 1;
        for r in t.r0..=t.r1 {
            let span = r * self.stride + t.c0..r * self.stride + last + 1;
            let (from, to) = (&mut self.cells[span.clone()], &mut other.cells[span]);
            let (from, to) = (
                from.as_chunks_mut::<LANES>().0,
                to.as_chunks_mut::<LANES>().0,
            );
            for (f, o) in from.iter_mut().zip(to.iter_mut()) {
                let (mut v, u) = (*o, *f);
                for j in 0..LANES {
                    v[j] += w * u[j];
                }
                *o = v;
                *f = [0.0; LANES];
            }
        }
        other.touch((t.r0, t.r1), (t.c0, last));
    }

    /// Multiply each cell of `layer` (a grid layer, row-major) by one minus the tile's
    /// cell over it (the chance that the tile's person is not there), and clear the
    /// tile.
    #[inline(always)]
    pub fn fold_into(&mut self, layer: &mut [f32], width: usize) {
        let (Some(t), Some(area)) = (self.touched.take(), self.area) else {
            return;
        };
        // the columns past the area's last only ever receive zeros (the column masses
        // past a kernel's box are zero): they stay clear
        let last = t.c1.min(area.c1 - area.c0);
        let fold = |e: &mut f32, p: &mut f32| {
            *e *= (1.0 - *p).max(0.0);
            *p = 0.0;
        };
        for r in t.r0..=t.r1 {
            let row = r * self.stride;
            let at = (area.r0 + r) * width + area.c0;
            let tile = &mut self.cells[row + t.c0..=row + last];
            let layer = &mut layer[at + t.c0..=at + last];
            let (tiles, tile_tail) = tile.as_chunks_mut::<LANES>();
            let (layers, layer_tail) = layer.as_chunks_mut::<LANES>();
            // eight cells at a time (through registers), then the rest one by one
            for (e, p) in layers.iter_mut().zip(tiles.iter_mut()) {
                let (mut v, mut q) = (*e, *p);
                for j in 0..LANES {
                    fold(&mut v[j], &mut q[j]);
                }
                (*e, *p) = (v, q);
            }
            for (e, p) in layer_tail.iter_mut().zip(tile_tail.iter_mut()) {
                fold(e, p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::kernel::axis_mass;
    use super::*;

    #[test]
    fn a_tile_adds_kernels_where_they_lie_on_the_grid_and_clears_after_folding() {
        let grid = GridSpec::around([0.0, 0.0], [3.0, 2.0], 0.1);
        let points = [[0.13f32, -0.21], [-0.52, 0.3]];
        let (sigma, reach) = (0.2f32, 0.6f32);
        let (lo, hi) = extent(&points).unwrap();
        let area = reach_box(&grid, lo, hi, reach).unwrap();
        let (mut tile, mut kernel) = (Tile::default(), Kernel::default());
        tile.size_for(&grid).unwrap();
        kernel.size_for(&grid).unwrap();
        tile.cover(area);
        let mut want = vec![0.0f32; grid.cells()];
        for p in points {
            assert!(kernel.place(&grid, p, sigma, reach, area));
            tile.add(&kernel, 0.5);
            // the same kernel on the whole grid, cell by cell
            let b = kernel.cells.unwrap();
            let (mut mx, mut my) = (vec![0.0; b.c1 - b.c0 + 1], vec![0.0; b.r1 - b.r0 + 1]);
            let (ox, oy) = (grid.origin[0] as f32, grid.origin[1] as f32);
            axis_mass(p[0], sigma, ox, 0.1, b.c0, &mut mx);
            axis_mass(p[1], sigma, oy, 0.1, b.r0, &mut my);
            for r in b.r0..=b.r1 {
                for c in b.c0..=b.c1 {
                    want[r * grid.width + c] += 0.5 * my[r - b.r0] * mx[c - b.c0];
                }
            }
        }
        let mut layer = vec![1.0f32; grid.cells()];
        tile.fold_into(&mut layer, grid.width);
        for (i, (&e, &p)) in layer.iter().zip(&want).enumerate() {
            assert!((e - (1.0 - p)).abs() < 1e-7, "cell {i}: {e} vs {}", 1.0 - p);
        }
        assert!(want.iter().sum::<f32>() > 0.9);
        assert!(tile.cells.iter().all(|&v| v == 0.0));
        // a kernel off the grid is not placed
        assert!(!kernel.place(&grid, [5.0, 0.0], sigma, reach, area));
        assert_eq!(reach_box(&grid, [5.0, 0.0], [6.0, 0.0], reach), None);
    }
}
