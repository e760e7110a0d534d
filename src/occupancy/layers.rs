//! The occupancy buffer: one layer per time, each the probability that a cell holds
//! someone then, and the kernel loop that fills it.

use std::ops::Range;

use super::kernel::{silverman_root, spread};
use super::levels::{FACTORS, Levels};
use super::samples::TimeIndex;
use super::tile::{CellBox, Kernel, Tile, extent, grow, reach_box};
use super::{GridSpec, OccupancyError, Samples, Settings, Stopped};
use crate::math::Simd;

/// Where kernels are added up: one person's tile (and one sample's, for window
/// occupancy) and a sample's kernel.
#[derive(Debug, Clone, Default)]
pub(super) struct Splat {
    pub tile: Tile,
    pub sample: Tile,
    pub kernel: Kernel,
}

/// Occupancy over a grid: for each of a list of times (or for one time window, see
/// [`window`](Self::window)) the probability that each cell holds at least one person,
/// stored `layers x height x width` (a layer row-major like the grid), as f32.
///
/// One person's probability for a cell is the mass their samples' kernels put on it
/// ([`Settings`]); people are independent, so a cell is empty with the product of
/// each person's chance of not being in it, and occupied with one minus that product.
/// The buffer and its scratch space are reused: once they have held a call of a size,
/// calls up to that size do not allocate.
#[derive(Debug, Clone, Default)]
pub struct Occupancy {
    pub(super) grid: Option<GridSpec>,
    pub(super) times: Vec<f64>,
    pub(super) window: bool,
    pub(super) agents: usize,
    pub(super) cells: Vec<f32>,
    pub(super) coverage: Vec<f32>,
    pub(super) scratch: Scratch,
    /// Every person on the grid's own cells (no coarser grids): what tests compare
    /// the coarser grids with.
    pub(super) exact: bool,
}

/// Reused working space: the tiles and a sample's kernel, the coarser grids' layers,
/// the samples at a time and where the times fall.
#[derive(Debug, Clone, Default)]
pub(super) struct Scratch {
    pub splat: Splat,
    pub levels: Levels,
    pub points: Vec<[f32; 2]>,
    pub index: Vec<TimeIndex>,
    pub sigmas: Vec<f32>,
    /// One layer's chance of emptiness while its people are folded in (the layer of
    /// the buffer is written once, at the end).
    pub empty: Vec<f32>,
}

impl Occupancy {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// The probability that each cell holds someone at each of `times` (seconds after
    /// the prediction's start, each within [`Samples::span`]), for every person of the
    /// samples.
    pub fn compute(
        &mut self,
        samples: &Samples<'_>,
        grid: &GridSpec,
        times: &[f64],
        settings: &Settings,
    ) -> Result<(), OccupancyError> {
        let agents = samples.shape().0;
        self.layers_for(samples, grid, times, settings, 0..agents)
    }

    /// The same for person `agent` alone: the probability that each cell holds that
    /// person (what calibration compares with where the person was).
    pub fn compute_agent(
        &mut self,
        samples: &Samples<'_>,
        agent: usize,
        grid: &GridSpec,
        times: &[f64],
        settings: &Settings,
    ) -> Result<(), OccupancyError> {
        let agents = samples.shape().0;
        if agent >= agents {
            return Err(OccupancyError::Samples(format!(
                "agent {agent} of {agents}"
            )));
        }
        self.layers_for(samples, grid, times, settings, agent..agent + 1)
    }

    /// The grid of the last call.
    pub fn grid(&self) -> Option<&GridSpec> {
        self.grid.as_ref()
    }

    /// The times of the last call's layers (for a window, its two ends).
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// True when the last call was [`window`](Self::window): one layer for the span
    /// between the two [`times`](Self::times).
    pub fn is_window(&self) -> bool {
        self.window
    }

    /// Layers of the last call (times, or 1 for a window).
    pub fn layers(&self) -> usize {
        if self.window { 1 } else { self.times.len() }
    }

    /// Every layer, `layers x height x width`, row-major.
    pub fn cells(&self) -> &[f32] {
        &self.cells
    }

    /// Layer `i`, `height x width`, row-major.
    pub fn layer(&self, i: usize) -> &[f32] {
        let n = self.grid.map_or(0, |g| g.cells());
        &self.cells[i * n..(i + 1) * n]
    }

    /// The probability that cell `(row, col)` holds someone in layer `i`.
    pub fn at(&self, i: usize, row: usize, col: usize) -> f32 {
        let g = self.grid.expect("no occupancy computed yet");
        self.layer(i)[row * g.width + col]
    }

    /// The fraction of person `agent`'s samples that have a position at layer `i`'s
    /// time (for a window: at some time within it) under the stop rule; 0 means the
    /// person added nothing to that layer. Indexed by the agents of the last call (for
    /// [`compute_agent`](Self::compute_agent), 0).
    pub fn coverage(&self, i: usize, agent: usize) -> f32 {
        self.coverage[i * self.agents + agent]
    }

    /// Check the input, size the buffers (no allocation when they are large enough)
    /// and record the call's grid and times.
    pub(super) fn prepare(
        &mut self,
        samples: &Samples<'_>,
        grid: &GridSpec,
        times: &[f64],
        settings: &Settings,
        layers: usize,
        agents: usize,
    ) -> Result<(), OccupancyError> {
        grid.validate()?;
        settings.validate()?;
        let cells = grid.cells();
        let too_large = || OccupancyError::TooLarge { layers, cells };
        let total = layers.checked_mul(cells).ok_or_else(too_large)?;
        grow(&mut self.cells, total).map_err(|_| too_large())?;
        self.scratch
            .splat
            .tile
            .size_for(grid)
            .map_err(|_| too_large())?;
        self.scratch
            .splat
            .kernel
            .size_for(grid)
            .map_err(|_| too_large())?;
        let k = samples.shape().1;
        let (_, _, steps) = samples.shape();
        grow(&mut self.coverage, layers * agents).map_err(|_| too_large())?;
        grow(&mut self.scratch.points, k).map_err(|_| too_large())?;
        grow(&mut self.scratch.index, times.len().max(2 * steps + 3)).map_err(|_| too_large())?;
        grow(&mut self.scratch.sigmas, times.len().max(2 * steps + 3)).map_err(|_| too_large())?;
        self.grid = Some(*grid);
        self.times.clear();
        grow(&mut self.times, times.len()).map_err(|_| too_large())?;
        self.times.clear();
        self.times.extend_from_slice(times);
        self.agents = agents;
        // (each layer is set to 1 before its people are folded in)
        self.cells.resize(total, 1.0);
        self.coverage.clear();
        self.coverage.resize(layers * agents, 0.0);
        Ok(())
    }

    fn layers_for(
        &mut self,
        samples: &Samples<'_>,
        grid: &GridSpec,
        times: &[f64],
        settings: &Settings,
        agents: Range<usize>,
    ) -> Result<(), OccupancyError> {
        self.prepare(samples, grid, times, settings, times.len(), agents.len())?;
        let too_large = || OccupancyError::TooLarge {
            layers: times.len(),
            cells: grid.cells(),
        };
        self.scratch
            .levels
            .size_for(grid)
            .map_err(|_| too_large())?;
        grow(&mut self.scratch.empty, grid.cells()).map_err(|_| too_large())?;
        self.scratch.empty.resize(grid.cells(), 1.0);
        self.window = false;
        self.scratch.index.clear();
        for (i, &t) in times.iter().enumerate() {
            let ti = samples.time_index(i, t)?;
            self.scratch.index.push(ti);
        }
        let k = samples.shape().1;
        let n = grid.cells();
        // Silverman's factor for the last number of samples that reached a time
        let mut root = (0, 0.0);
        for li in 0..times.len() {
            let ti = self.scratch.index[li];
            let mut empty = std::mem::take(&mut self.scratch.empty);
            let layer = &mut empty[..n];
            layer.fill(1.0);
            for (ai, a) in agents.clone().enumerate() {
                let sc = &mut self.scratch;
                sc.points.clear();
                for s in 0..k {
                    if let Some(p) = samples.at(a, s, ti, settings.stopped) {
                        sc.points.push(p);
                    }
                }
                let reached = sc.points.len();
                self.coverage[li * agents.len() + ai] = reached as f32 / k as f32;
                if reached == 0 {
                    continue;
                }
                let w = match settings.stopped {
                    Stopped::Renormalise => 1.0 / reached as f32,
                    Stopped::Drop | Stopped::Hold => 1.0 / k as f32,
                };
                if root.0 != reached {
                    root = (reached, silverman_root(reached));
                }
                let sigma = settings.sigma_rooted(spread(&sc.points), reached, root.1);
                let level = Levels::level_for(grid, sigma).filter(|_| !self.exact);
                match level.and_then(|l| Some((l, sc.levels.level(l)?))) {
                    Some((l, (coarse, layer))) => {
                        // on the coarser grid: a cell there holds FACTORS[l]^2 cells
                        let f = FACTORS[l] as f32;
                        let (p, s) = (&sc.points, &mut sc.splat);
                        let w = w / (f * f);
                        let area = fold_person(&coarse, settings, p, s, w, sigma as f32, layer);
                        if let Some(area) = area {
                            sc.levels.touch(l, area);
                        }
                    }
                    None => {
                        let (p, s) = (&sc.points, &mut sc.splat);
                        fold_person(grid, settings, p, s, w, sigma as f32, layer);
                    }
                }
            }
            self.scratch.levels.fold_into(layer, grid);
            occupied(layer, &mut self.cells[li * n..(li + 1) * n]);
            self.scratch.empty = empty;
        }
        Ok(())
    }
}

/// Fold one person into `layer` (on `grid`): the kernels of the samples at `points` (each
/// weighing `w`, of width `sigma`) are added up on the person's tile, and each cell's
/// chance of emptiness is multiplied by the person's chance of not being there. On
/// AVX2 + FMA when the process runs on it ([`Simd::active`]): the same operations,
/// eight cells at a time (no fused multiply-adds, so the bits are those of the
/// baseline). The box of cells the person's kernels reach, if any.
#[allow(clippy::too_many_arguments)]
fn fold_person(
    grid: &GridSpec,
    settings: &Settings,
    points: &[[f32; 2]],
    sp: &mut Splat,
    w: f32,
    sigma: f32,
    layer: &mut [f32],
) -> Option<CellBox> {
    #[cfg(target_arch = "x86_64")]
    if Simd::active() == Simd::Avx2Fma {
        // SAFETY: the processor has AVX2 and FMA (`Simd::active` checked it)
        return unsafe { fold_person_avx2(grid, settings, points, sp, w, sigma, layer) };
    }
    fold_person_body(grid, settings, points, sp, w, sigma, layer)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn fold_person_avx2(
    grid: &GridSpec,
    settings: &Settings,
    points: &[[f32; 2]],
    sp: &mut Splat,
    w: f32,
    sigma: f32,
    layer: &mut [f32],
) -> Option<CellBox> {
    fold_person_body(grid, settings, points, sp, w, sigma, layer)
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn fold_person_body(
    grid: &GridSpec,
    settings: &Settings,
    points: &[[f32; 2]],
    sp: &mut Splat,
    w: f32,
    sigma: f32,
    layer: &mut [f32],
) -> Option<CellBox> {
    let reach = settings.truncate as f32 * sigma;
    let (lo, hi) = extent(points)?;
    let area = reach_box(grid, lo, hi, reach)?;
    sp.tile.cover(area);
    for &p in points {
        if sp.kernel.place(grid, p, sigma, reach, area) {
            sp.tile.add(&sp.kernel, w);
        }
    }
    sp.tile.fold_into(layer, grid.width);
    Some(area)
}

/// `out = max(0, 1 - empty)` cell by cell: the chance that a cell is occupied from its
/// chance of emptiness (which the interpolation from coarser grids may leave a
/// rounding above 1). On AVX2 when the process runs on it ([`Simd::active`]), `out`
/// written past the cache (the buffer's layers are read after the call, not in it).
fn occupied(empty: &[f32], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if Simd::active() == Simd::Avx2Fma {
        // SAFETY: the processor has AVX2 (`Simd::active` checked it)
        return unsafe { occupied_avx2(empty, out) };
    }
    for (o, &e) in out.iter_mut().zip(empty) {
        *o = (1.0 - e).max(0.0);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn occupied_avx2(empty: &[f32], out: &mut [f32]) {
    use std::arch::x86_64::*;
    let n = out.len().min(empty.len());
    // the cells before the first 32-byte boundary of `out` and after the last whole
    // register one by one; the registers between streamed
    let lead = out.as_ptr().align_offset(32).min(n);
    let body = lead + (n - lead) / 8 * 8;
    let one_by_one = |o: &mut f32, e: f32| *o = (1.0 - e).max(0.0);
    for i in (0..lead).chain(body..n) {
        one_by_one(&mut out[i], empty[i]);
    }
    let (one, zero) = (_mm256_set1_ps(1.0), _mm256_setzero_ps());
    for i in (lead..body).step_by(8) {
        // SAFETY: `i + 8 <= body <= n` cells of both; `out + i` is 32-byte aligned
        unsafe {
            let e = _mm256_loadu_ps(empty.as_ptr().add(i));
            let o = _mm256_max_ps(_mm256_sub_ps(one, e), zero);
            _mm256_stream_ps(out.as_mut_ptr().add(i), o);
        }
    }
    _mm_sfence();
}
