//! Coarser grids for wide kernels: a person whose kernel is many cells wide is added
//! on a grid whose cells are 2, 4 or 8 times larger, where the kernel is still at least
//! [`MIN_SIGMA_CELLS`] cells wide, into one layer of the chance of emptiness per
//! coarser grid; at the end of a time each coarser layer is interpolated onto the cells
//! of the next finer coarser grid (half as large) and multiplied into its layer, and
//! the finest coarser layer, holding them all, onto the grid's cells (between the
//! coarse cells' centres, less the curvature a mean over a coarse cell carries:
//! [`weights`]). A person's work is then per coarse cell, and the work per cell of the
//! grid is once per time, not once per person or coarser grid.
//!
//! The interpolation keeps a layer's sum (away from the grid's edges); the kernel's cut
//! at `truncate` sigmas falls on coarse cells' edges, which moves a person's total by a
//! fraction of the 0.5 % the cut leaves out. `tests.rs` checks on predicted people that
//! a person's cells stay within 1 % of their largest cell probability of the exact
//! masses (measured 0.77 %) and their total within 0.3 % (measured 0.23 %).

use std::collections::TryReserveError;

use super::GridSpec;
use super::tile::{CellBox, grow};
use crate::math::Simd;

/// How much larger each coarser grid's cells are.
pub(super) const FACTORS: [usize; 3] = [2, 4, 8];

/// The least sigma of a kernel, in coarse cells, for it to be added on a coarser grid.
pub(super) const MIN_SIGMA_CELLS: f64 = 2.0;

/// The coarser grids of a grid, each with its layer of the chance of emptiness (1
/// where nobody was added since the last [`fold_into`](Self::fold_into)) and the box
/// of its cells written since.
#[derive(Debug, Clone, Default)]
pub(super) struct Levels {
    grids: [Option<GridSpec>; 3],
    layers: [Vec<f32>; 3],
    touched: [Option<CellBox>; 3],
    across: Vec<f32>,
    row: Vec<f32>,
}

impl Levels {
    /// The coarser grid for a kernel of width `sigma` (m) on `grid`: the index of the
    /// largest factor that leaves the kernel [`MIN_SIGMA_CELLS`] coarse cells wide,
    /// `None` when even a factor of 2 would not.
    pub fn level_for(grid: &GridSpec, sigma: f64) -> Option<usize> {
        let cells = sigma / grid.resolution;
        FACTORS
            .iter()
            .rposition(|&f| cells >= MIN_SIGMA_CELLS * f as f64)
    }

    /// Size the coarser grids and their layers for `grid` (no allocation when there
    /// is room), all layers 1.
    pub fn size_for(&mut self, grid: &GridSpec) -> Result<(), TryReserveError> {
        for (l, &f) in FACTORS.iter().enumerate() {
            let g = GridSpec {
                origin: grid.origin,
                resolution: grid.resolution * f as f64,
                width: grid.width.div_ceil(f),
                height: grid.height.div_ceil(f),
            };
            grow(&mut self.layers[l], g.cells())?;
            self.layers[l].clear();
            self.layers[l].resize(g.cells(), 1.0);
            self.grids[l] = Some(g);
            self.touched[l] = None;
        }
        // the most: every row of the finest coarser grid (and two beyond each side)
        // interpolated across onto the cells (and a coarse cell beyond each side)
        let rows = grid.height.div_ceil(FACTORS[0]) + 4;
        grow(&mut self.across, rows * (grid.width + 4 * FACTORS[2]))?;
        grow(&mut self.row, grid.width.div_ceil(FACTORS[0]) + 4)?;
        Ok(())
    }

    /// Coarser grid `l` and its layer (`None` before [`size_for`](Self::size_for)).
    pub fn level(&mut self, l: usize) -> Option<(GridSpec, &mut [f32])> {
        Some((self.grids[l]?, &mut self.layers[l]))
    }

    /// Record that the cells of `area` of coarser grid `l` were written.
    pub fn touch(&mut self, l: usize, area: CellBox) {
        match &mut self.touched[l] {
            Some(t) => t.join(area),
            None => self.touched[l] = Some(area),
        }
    }

    /// Multiply each cell of `layer` (on `grid`) by every written coarser layer
    /// interpolated there (each through the finer coarser grids), and set those layers
    /// back to 1. On AVX2 + FMA when the
    /// process runs on it ([`Simd::active`]): the same operations, eight cells at a
    /// time.
    pub fn fold_into(&mut self, layer: &mut [f32], grid: &GridSpec) {
        #[cfg(target_arch = "x86_64")]
        if Simd::active() == Simd::Avx2Fma {
            // SAFETY: the processor has AVX2 and FMA (`Simd::active` checked it)
            return unsafe { self.fold_into_avx2(layer, grid) };
        }
        self.fold_into_body(layer, grid)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn fold_into_avx2(&mut self, layer: &mut [f32], grid: &GridSpec) {
        self.fold_into_body(layer, grid)
    }

    #[inline(always)]
    fn fold_into_body(&mut self, layer: &mut [f32], grid: &GridSpec) {
        // each coarser layer onto the next finer one (their cells half as large),
        // the finest onto the grid: the grid's cells are passed over once
        for l in (0..FACTORS.len()).rev() {
            let (Some(t), Some(g)) = (self.touched[l].take(), self.grids[l]) else {
                continue;
            };
            let (finer, coarser) = self.layers.split_at_mut(l);
            let coarse = &mut coarser[0];
            let (across, row) = (&mut self.across, &mut self.row);
            if l == 0 {
                upsample::<2>(coarse, &g, t, layer, grid, across, row);
            } else if let Some(target) = self.grids[l - 1] {
                let written = upsample::<2>(coarse, &g, t, &mut finer[l - 1], &target, across, row);
                match &mut self.touched[l - 1] {
                    Some(b) => b.join(written),
                    None => self.touched[l - 1] = Some(written),
                }
            }
            for r in t.r0..=t.r1 {
                coarse[r * g.width + t.c0..=r * g.width + t.c1].fill(1.0);
            }
        }
    }
}

/// The weights on the values of four consecutive coarse cells `j - 1 ..= j + 2` that
/// give the mean over a cell `F` times smaller whose centre lies `s` of the way from
/// the centre of `j` to that of `j + 1`: linear interpolation less the curvature the
/// coarse means carry, `kappa` times the second differences interpolated alike, with
/// `kappa = s (1 - s) / 2 + (1 - 1 / F^2) / 24` (a mean over a cell is the value at its
/// centre plus `h^2 f'' / 24`; a chord lies `s (1 - s) h^2 f'' / 2` above the curve).
/// The weights add up to 1, and over a whole row the second differences add up to 0,
/// so a layer's sum is kept.
#[inline(always)]
fn weights<const F: usize>(s: f32) -> [f32; 4] {
    let kappa = s * (1.0 - s) / 2.0 + (1.0 - 1.0 / (F * F) as f32) / 24.0;
    [
        -kappa * (1.0 - s),
        (1.0 - s) - kappa * (3.0 * s - 2.0),
        s - kappa * (1.0 - 3.0 * s),
        -kappa * s,
    ]
}

/// Multiply `layer` by the coarse layer (cells `F` times larger) interpolated onto
/// the cells ([`weights`]; along each coarse row first, into `across`, then down the
/// cells' columns), over the cells where the coarse layer's box `t` (1 around it)
/// reaches; beyond the coarse grid's edge its edge cells hold. The box of cells of
/// `layer` written.
#[inline(always)]
fn upsample<const F: usize>(
    coarse: &[f32],
    g: &GridSpec,
    t: CellBox,
    layer: &mut [f32],
    grid: &GridSpec,
    across: &mut Vec<f32>,
    row: &mut Vec<f32>,
) -> CellBox {
    // the coarse columns c0 - 2 ..= c1 + 2 and rows r0 - 2 ..= r1 + 2 (clamped to the
    // grid); the cells from the centre of coarse column c0 - 1 to that of c1 + 1
    let n = t.c1 - t.c0 + 5;
    let first = (F * t.c0) as isize - (F / 2) as isize; // the centre of c0 - 1, in cells
    let c_lo = first.max(0) as usize;
    let c_hi = (F * (t.c1 + 1) + F / 2).min(grid.width); // exclusive
    let r_lo = (F * t.r0).saturating_sub(F / 2);
    let r_hi = (F * (t.r1 + 1) + F / 2).min(grid.height);
    let side: [[f32; 4]; F] = std::array::from_fn(|m| weights::<F>((m as f32 + 0.5) / F as f32));
    let span = F * (n - 3);
    let rows = t.r1 - t.r0 + 5;
    // (each row of `across` is written whole before it is read)
    if across.len() < rows * span {
        across.resize(rows * span, 0.0);
    }
    // the columns c0 - 2 ..= c1 + 2: those left of the grid as its first, those right
    // of it as its last
    let (left, inside) = (2usize.saturating_sub(t.c0), t.c0.saturating_sub(2));
    let end = (t.c1 + 2).min(g.width - 1);
    let right = n - left - (end + 1 - inside);
    for q in 0..rows {
        let j = (t.r0 + q).saturating_sub(2).min(g.height - 1);
        let src = &coarse[j * g.width..(j + 1) * g.width];
        row.clear();
        row.extend(std::iter::repeat_n(src[0], left));
        row.extend_from_slice(&src[inside..=end]);
        row.extend(std::iter::repeat_n(src[g.width - 1], right));
        let out = &mut across[q * span..(q + 1) * span];
        // the cells between the centres of coarse columns c0 - 2 + k + 1 and + 2: F
        // cells at (m + 0.5) / F of the way
        for (out, v) in out.as_chunks_mut::<F>().0.iter_mut().zip(row.windows(4)) {
            for m in 0..F {
                let x = &side[m];
                out[m] = x[0] * v[0] + x[1] * v[1] + x[2] * v[2] + x[3] * v[3];
            }
        }
    }
    let from = (c_lo as isize - first) as usize;
    let cols = c_hi - c_lo;
    for r in r_lo..r_hi {
        // between the centres of coarse rows j and j + 1: rows j - 1 ..= j + 2 of
        // `across` (which starts at r0 - 2)
        let v = (r as f32 + 0.5) / F as f32 - 0.5;
        let j = v.floor();
        let w = weights::<F>(v - j);
        let q = (j as isize + 1 - t.r0 as isize) as usize;
        let part = |i: usize| &across[(q + i) * span + from..(q + i) * span + from + cols];
        let (a, b, c, d) = (part(0), part(1), part(2), part(3));
        let at = r * grid.width + c_lo;
        for (k, e) in layer[at..at + cols].iter_mut().enumerate() {
            *e *= w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + w[3] * d[k];
        }
    }
    CellBox {
        r0: r_lo,
        r1: r_hi - 1,
        c0: c_lo,
        c1: c_hi - 1,
    }
}
