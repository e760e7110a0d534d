//! Occupancy over a time window: the chance that anyone is in a cell at some time
//! between two times.

use super::kernel::spread;
use super::layers::Scratch;
use super::tile::{CellBox, extent, reach_box};
use super::{GridSpec, Occupancy, OccupancyError, Samples, Settings, Stopped};
use crate::math::Simd;

impl Occupancy {
    /// One layer: the probability that each cell holds someone at some time in
    /// `[from, to]` (seconds after the prediction's start, within [`Samples::span`]).
    ///
    /// The samples are read at `from`, at every half step strictly between (positions
    /// interpolated between steps) and at `to`. For
    /// one person, each sample's path covers a cell with the largest mass its kernel
    /// puts there at any of those times, and the person's probability is the weighted
    /// mean of that over the samples: the fraction of the predicted futures whose
    /// person passes through the cell. (Taking the largest of the person's
    /// probabilities over the times instead would miss that different futures pass at
    /// different times; adding them up would count one pass several times.) People
    /// are combined as independent. [`coverage`](Self::coverage) tells, per person, the
    /// fraction of samples with a position somewhere in the window.
    pub fn window(
        &mut self,
        samples: &Samples<'_>,
        grid: &GridSpec,
        from: f64,
        to: f64,
        settings: &Settings,
    ) -> Result<(), OccupancyError> {
        let (agents, k, _) = samples.shape();
        let ends = [from, to];
        self.prepare(samples, grid, &ends, settings, 1, agents)?;
        self.window = true;
        let first = samples.time_index(0, from)?;
        samples.time_index(1, to)?;
        if to < from {
            return Err(OccupancyError::Time {
                index: 1,
                time: to,
                why: format!("the window ends before it starts ({from} s)"),
            });
        }
        let sc = &mut self.scratch;
        sc.index.clear();
        sc.index.push(first);
        // every half step: a walker moves about a third of the kernel's least sigma
        let half = samples.dt() / 2.0;
        let mut i = (from / half).floor() as usize + 1;
        while (i as f64) * half < to - 1e-6 * half {
            let t = i as f64 * half;
            if t > from + 1e-6 * half {
                sc.index.push(samples.time_index(0, t)?);
            }
            i += 1;
        }
        if to > from {
            sc.index.push(samples.time_index(1, to)?);
        }
        sc.splat
            .sample
            .size_for(grid)
            .map_err(|_| OccupancyError::TooLarge {
                layers: 1,
                cells: grid.cells(),
            })?;
        sc.sigmas.clear();
        sc.sigmas.resize(sc.index.len(), 0.0);
        let layer = &mut self.cells[..grid.cells()];
        layer.fill(1.0);
        for a in 0..agents {
            // the kernel's width at each time, from the samples there, and the box of
            // cells the kernels reach at any time
            let mut area: Option<CellBox> = None;
            for wi in 0..sc.index.len() {
                sc.points.clear();
                for s in 0..k {
                    if let Some(p) = samples.at(a, s, sc.index[wi], settings.stopped) {
                        sc.points.push(p);
                    }
                }
                let sigma = settings.sigma(spread(&sc.points), sc.points.len()) as f32;
                sc.sigmas[wi] = sigma;
                let reach = settings.truncate as f32 * sigma;
                if let Some(b) =
                    extent(&sc.points).and_then(|(lo, hi)| reach_box(grid, lo, hi, reach))
                {
                    match &mut area {
                        Some(area) => area.join(b),
                        None => area = Some(b),
                    }
                }
            }
            let mut any = 0;
            for s in 0..k {
                if sc
                    .index
                    .iter()
                    .any(|&ti| samples.at(a, s, ti, settings.stopped).is_some())
                {
                    any += 1;
                }
            }
            self.coverage[a] = any as f32 / k as f32;
            let Some(area) = area else {
                continue;
            };
            let w = match settings.stopped {
                Stopped::Renormalise => 1.0 / any as f32,
                Stopped::Drop | Stopped::Hold => 1.0 / k as f32,
            };
            window_person(samples, a, grid, settings, w, area, sc, layer);
        }
        for v in layer.iter_mut() {
            *v = 1.0 - *v;
        }
        Ok(())
    }
}

/// Fold person `a` into the window's layer: each sample's kernels at the window's
/// times (`sc.index`, widths `sc.sigmas`) raised into the sample's tile, the samples'
/// tiles added up (each weighing `w`) on the person's tile over `area`, and each
/// cell's chance of emptiness multiplied by the person's chance of not passing there.
/// On AVX2 + FMA when the process runs on it ([`Simd::active`]): the same operations,
/// eight cells at a time.
#[allow(clippy::too_many_arguments)]
fn window_person(
    samples: &Samples<'_>,
    a: usize,
    grid: &GridSpec,
    settings: &Settings,
    w: f32,
    area: CellBox,
    sc: &mut Scratch,
    layer: &mut [f32],
) {
    #[cfg(target_arch = "x86_64")]
    if Simd::active() == Simd::Avx2Fma {
        // SAFETY: the processor has AVX2 and FMA (`Simd::active` checked it)
        return unsafe { window_person_avx2(samples, a, grid, settings, w, area, sc, layer) };
    }
    window_person_body(samples, a, grid, settings, w, area, sc, layer)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn window_person_avx2(
    samples: &Samples<'_>,
    a: usize,
    grid: &GridSpec,
    settings: &Settings,
    w: f32,
    area: CellBox,
    sc: &mut Scratch,
    layer: &mut [f32],
) {
    window_person_body(samples, a, grid, settings, w, area, sc, layer)
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn window_person_body(
    samples: &Samples<'_>,
    a: usize,
    grid: &GridSpec,
    settings: &Settings,
    w: f32,
    area: CellBox,
    sc: &mut Scratch,
    layer: &mut [f32],
) {
    let k = samples.shape().1;
    let sp = &mut sc.splat;
    sp.tile.cover(area);
    sp.sample.cover(area);
    for s in 0..k {
        for wi in 0..sc.index.len() {
            let Some(p) = samples.at(a, s, sc.index[wi], settings.stopped) else {
                continue;
            };
            let sigma = sc.sigmas[wi];
            let reach = settings.truncate as f32 * sigma;
            if sp.kernel.place(grid, p, sigma, reach, area) {
                sp.sample.raise(&sp.kernel);
            }
        }
        sp.sample.move_into(&mut sp.tile, w);
    }
    sp.tile.fold_into(layer, grid.width);
}
