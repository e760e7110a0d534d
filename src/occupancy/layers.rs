//! The occupancy buffer: one layer per time, each the probability that a cell holds
//! someone then, and the kernel loop that fills it.

use std::ops::Range;

use super::kernel::{axis_box, axis_mass, spread};
use super::samples::TimeIndex;
use super::{GridSpec, OccupancyError, Samples, Settings, Stopped};
use crate::math::Simd;

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
}

/// Reused working space: one person's layer (zero between uses), one sample's layer
/// (window occupancy), the kernel's axis factors, the samples at a time and where the
/// times fall.
#[derive(Debug, Clone, Default)]
pub(super) struct Scratch {
    pub person: Vec<f32>,
    pub sample: Vec<f32>,
    pub mx: Vec<f32>,
    pub my: Vec<f32>,
    pub points: Vec<[f32; 2]>,
    pub index: Vec<TimeIndex>,
    pub sigmas: Vec<f32>,
}

/// A box of cells, rows and columns inclusive; empty when `r0 > r1`.
#[derive(Debug, Clone, Copy)]
pub(super) struct CellBox {
    pub r0: usize,
    pub r1: usize,
    pub c0: usize,
    pub c1: usize,
}

impl CellBox {
    pub const EMPTY: CellBox = CellBox {
        r0: usize::MAX,
        r1: 0,
        c0: usize::MAX,
        c1: 0,
    };

    pub fn is_empty(&self) -> bool {
        self.r0 > self.r1
    }

    pub fn join(&mut self, o: CellBox) {
        self.r0 = self.r0.min(o.r0);
        self.r1 = self.r1.max(o.r1);
        self.c0 = self.c0.min(o.c0);
        self.c1 = self.c1.max(o.c1);
    }
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
        grow(&mut self.scratch.person, cells).map_err(|_| too_large())?;
        let k = samples.shape().1;
        let (_, _, steps) = samples.shape();
        grow(&mut self.coverage, layers * agents).map_err(|_| too_large())?;
        grow(&mut self.scratch.points, k).map_err(|_| too_large())?;
        grow(&mut self.scratch.index, times.len().max(2 * steps + 3)).map_err(|_| too_large())?;
        grow(&mut self.scratch.sigmas, times.len().max(2 * steps + 3)).map_err(|_| too_large())?;
        grow(&mut self.scratch.mx, grid.width).map_err(|_| too_large())?;
        grow(&mut self.scratch.my, grid.height).map_err(|_| too_large())?;
        self.grid = Some(*grid);
        self.times.clear();
        grow(&mut self.times, times.len()).map_err(|_| too_large())?;
        self.times.clear();
        self.times.extend_from_slice(times);
        self.agents = agents;
        self.cells.clear();
        self.cells.resize(total, 1.0);
        self.scratch.person.clear();
        self.scratch.person.resize(cells, 0.0);
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
        self.window = false;
        self.scratch.index.clear();
        for (i, &t) in times.iter().enumerate() {
            let ti = samples.time_index(i, t)?;
            self.scratch.index.push(ti);
        }
        let k = samples.shape().1;
        let n = grid.cells();
        for li in 0..times.len() {
            let ti = self.scratch.index[li];
            let layer = &mut self.cells[li * n..(li + 1) * n];
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
                let sigma = settings.sigma(spread(&sc.points), reached) as f32;
                let bbox = splat_person(grid, settings, sc, w, sigma);
                fold_person(layer, &mut sc.person, grid.width, bbox);
            }
            for v in layer.iter_mut() {
                *v = 1.0 - *v;
            }
        }
        Ok(())
    }
}

/// Add the kernels of the samples in `sc.points` (each weighing `w`, of width
/// `sigma`) into `sc.person`; the box they cover. On AVX2 + FMA when the process runs
/// on it ([`Simd::active`]): the same sums, eight cells at a time.
fn splat_person(
    grid: &GridSpec,
    settings: &Settings,
    sc: &mut Scratch,
    w: f32,
    sigma: f32,
) -> CellBox {
    #[cfg(target_arch = "x86_64")]
    if Simd::active() == Simd::Avx2Fma {
        // SAFETY: the processor has AVX2 and FMA (`Simd::active` checked it)
        return unsafe { splat_person_avx2(grid, settings, sc, w, sigma) };
    }
    splat_person_body(grid, settings, sc, w, sigma)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn splat_person_avx2(
    grid: &GridSpec,
    settings: &Settings,
    sc: &mut Scratch,
    w: f32,
    sigma: f32,
) -> CellBox {
    splat_person_body(grid, settings, sc, w, sigma)
}

#[inline(always)]
fn splat_person_body(
    grid: &GridSpec,
    settings: &Settings,
    sc: &mut Scratch,
    w: f32,
    sigma: f32,
) -> CellBox {
    let mut bbox = CellBox::EMPTY;
    for i in 0..sc.points.len() {
        let p = sc.points[i];
        if let Some(b) = splat(grid, settings, p, sigma, &mut sc.mx, &mut sc.my) {
            add_outer(&mut sc.person, grid.width, b, w, &sc.mx, &sc.my);
            bbox.join(b);
        }
    }
    bbox
}

/// Make room for `n` elements (no allocation when there is).
pub(super) fn grow<T>(v: &mut Vec<T>, n: usize) -> Result<(), std::collections::TryReserveError> {
    v.try_reserve(n.saturating_sub(v.len()))
}

/// The kernel of a sample at `p`: its box of cells on the grid and the axis masses of
/// the box's columns (`mx[..cols]`) and rows (`my[..rows]`); `None` when it misses
/// the grid.
#[inline(always)]
pub(super) fn splat(
    grid: &GridSpec,
    settings: &Settings,
    p: [f32; 2],
    sigma: f32,
    mx: &mut Vec<f32>,
    my: &mut Vec<f32>,
) -> Option<CellBox> {
    let reach = settings.truncate as f32 * sigma;
    let res = grid.resolution as f32;
    let (ox, oy) = (grid.origin[0] as f32, grid.origin[1] as f32);
    let (c0, c1) = axis_box(p[0], reach, ox, res, grid.width)?;
    let (r0, r1) = axis_box(p[1], reach, oy, res, grid.height)?;
    mx.clear();
    mx.resize(c1 - c0 + 1, 0.0);
    my.clear();
    my.resize(r1 - r0 + 1, 0.0);
    axis_mass(p[0], sigma, ox, res, c0, mx);
    axis_mass(p[1], sigma, oy, res, r0, my);
    Some(CellBox { r0, r1, c0, c1 })
}

/// Add `w` times the outer product of the row and column masses over the box.
#[inline(always)]
pub(super) fn add_outer(
    person: &mut [f32],
    width: usize,
    b: CellBox,
    w: f32,
    mx: &[f32],
    my: &[f32],
) {
    for (r, &fy) in (b.r0..=b.r1).zip(my) {
        let wy = w * fy;
        let row = &mut person[r * width + b.c0..=r * width + b.c1];
        for (o, &fx) in row.iter_mut().zip(mx) {
            *o += wy * fx;
        }
    }
}

/// Multiply the layer's chance of emptiness by the person's chance of not being in
/// each cell of the box, and clear the person's layer there.
#[inline]
pub(super) fn fold_person(layer: &mut [f32], person: &mut [f32], width: usize, b: CellBox) {
    if b.is_empty() {
        return;
    }
    for r in b.r0..=b.r1 {
        let span = r * width + b.c0..=r * width + b.c1;
        for (e, p) in layer[span.clone()].iter_mut().zip(&mut person[span]) {
            *e *= (1.0 - *p).max(0.0);
            *p = 0.0;
        }
    }
}
