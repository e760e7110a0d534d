//! Occupancy over a time window: the chance that anyone is in a cell at some time
//! between two times.

use super::kernel::spread;
use super::layers::{CellBox, fold_person, splat};
use super::{GridSpec, Occupancy, OccupancyError, Samples, Settings, Stopped};

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
        grow_sample(&mut sc.sample, grid.cells())?;
        sc.sigmas.clear();
        sc.sigmas.resize(sc.index.len(), 0.0);
        let layer = &mut self.cells[..grid.cells()];
        for a in 0..agents {
            // the kernel's width at each time, from the samples there
            let mut any = 0;
            for wi in 0..sc.index.len() {
                sc.points.clear();
                for s in 0..k {
                    if let Some(p) = samples.at(a, s, sc.index[wi], settings.stopped) {
                        sc.points.push(p);
                    }
                }
                sc.sigmas[wi] = settings.sigma(spread(&sc.points), sc.points.len()) as f32;
            }
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
            if any == 0 {
                continue;
            }
            let w = match settings.stopped {
                Stopped::Renormalise => 1.0 / any as f32,
                Stopped::Drop | Stopped::Hold => 1.0 / k as f32,
            };
            let mut bbox = CellBox::EMPTY;
            for s in 0..k {
                let mut sbox = CellBox::EMPTY;
                for wi in 0..sc.index.len() {
                    let Some(p) = samples.at(a, s, sc.index[wi], settings.stopped) else {
                        continue;
                    };
                    let Some(b) = splat(grid, settings, p, sc.sigmas[wi], &mut sc.mx, &mut sc.my)
                    else {
                        continue;
                    };
                    max_outer(&mut sc.sample, grid.width, b, &sc.mx, &sc.my);
                    sbox.join(b);
                }
                if sbox.is_empty() {
                    continue;
                }
                move_weighted(&mut sc.person, &mut sc.sample, grid.width, sbox, w);
                bbox.join(sbox);
            }
            fold_person(layer, &mut sc.person, grid.width, bbox);
        }
        for v in layer.iter_mut() {
            *v = 1.0 - *v;
        }
        Ok(())
    }
}

/// Size the sample layer (all zeros) for `cells` cells.
fn grow_sample(v: &mut Vec<f32>, cells: usize) -> Result<(), OccupancyError> {
    super::layers::grow(v, cells).map_err(|_| OccupancyError::TooLarge { layers: 1, cells })?;
    v.clear();
    v.resize(cells, 0.0);
    Ok(())
}

/// Raise each cell of the box to the outer product of the row and column masses.
fn max_outer(sample: &mut [f32], width: usize, b: CellBox, mx: &[f32], my: &[f32]) {
    for (r, &fy) in (b.r0..=b.r1).zip(my) {
        let row = &mut sample[r * width + b.c0..=r * width + b.c1];
        for (o, &fx) in row.iter_mut().zip(mx) {
            *o = o.max(fy * fx);
        }
    }
}

/// Add `w` times the sample's layer into the person's over the box, and clear the
/// sample's layer there.
fn move_weighted(person: &mut [f32], sample: &mut [f32], width: usize, b: CellBox, w: f32) {
    for r in b.r0..=b.r1 {
        let span = r * width + b.c0..=r * width + b.c1;
        for (p, s) in person[span.clone()].iter_mut().zip(&mut sample[span]) {
            *p += w * *s;
            *s = 0.0;
        }
    }
}
