//! A prediction's samples as the occupancy calls read them: positions, valid lengths,
//! the step, and optionally where each person stands at time 0.

use crate::predict::{Point, TrajectoryBatch};

use super::OccupancyError;

/// What a sample that stopped before a time means there.
///
/// A `cliff` sample stops where the map has no data near it (the person walks where
/// nobody was seen, or off the map); `improved`, `motion` and constant velocity reach
/// the horizon. The person still exists after a sample stops, but the map no longer
/// says where: [`Stopped::Renormalise`] spreads the person's whole probability over
/// the samples that reached the time, which keeps every person's occupancy a
/// probability distribution as long as one sample goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Stopped {
    /// The person's probability is spread over the samples that reached the time (each
    /// of `n` reaching samples weighs `1 / n`); when none reached it, the person adds
    /// nothing at that time. The default: the samples that go on are the prediction's
    /// belief about where the person is, and a person's occupancy sums to one (less
    /// what the grid does not hold) whatever the map's coverage.
    #[default]
    Renormalise,
    /// Every sample weighs `1 / k`, and a stopped one adds nothing: the occupancy sums
    /// to the fraction of samples that reached the time (a lower bound).
    Drop,
    /// A stopped sample stays at its last position (each weighs `1 / k`): people who
    /// leave the map's coverage stay where they left it.
    Hold,
}

/// A view of a batch of sampled trajectories for the occupancy calls: `agents x k`
/// samples of `steps` positions each, sample-major (as [`TrajectoryBatch`] and the
/// client's `Prediction` hold them), the valid length of each sample, and the step
/// `dt`. Step `j` of a sample is the position at time `(j + 1) * dt` after the
/// prediction's start; with [`with_starts`](Self::with_starts) each person's position
/// at time 0 is known too, and times between 0 and `dt` are interpolated from it.
#[derive(Debug, Clone, Copy)]
pub struct Samples<'a> {
    positions: &'a [Point],
    lens: &'a [u32],
    agents: usize,
    k: usize,
    steps: usize,
    dt: f64,
    starts: Option<&'a [Point]>,
}

/// Where a time falls among the steps: the step before it (`-1` for the start) and the
/// fraction of the way to the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TimeIndex {
    /// The step at or before the time (`-1`: the start position).
    pub before: isize,
    /// How far towards step `before + 1` the time lies, in [0, 1).
    pub frac: f32,
}

impl<'a> Samples<'a> {
    /// A view of flat buffers: `positions` holds `agents * k * steps` points, `lens`
    /// `agents * k` valid lengths (at most `steps`), `dt` is the step in seconds.
    pub fn new(
        positions: &'a [Point],
        lens: &'a [u32],
        shape: (usize, usize, usize),
        dt: f64,
    ) -> Result<Self, OccupancyError> {
        let (agents, k, steps) = shape;
        let bad = |why: String| Err(OccupancyError::Samples(why));
        let samples = agents.checked_mul(k);
        let points = samples.and_then(|n| n.checked_mul(steps));
        if samples != Some(lens.len()) || points != Some(positions.len()) {
            return bad(format!(
                "{} positions and {} lengths for {agents} agents x {k} samples x {steps} steps",
                positions.len(),
                lens.len()
            ));
        }
        if !(dt.is_finite() && dt > 0.0) {
            return bad(format!("dt {dt} is not a positive number"));
        }
        if let Some(i) = lens.iter().position(|&l| l as usize > steps) {
            return bad(format!(
                "sample {i} claims {} positions of {steps}",
                lens[i]
            ));
        }
        Ok(Self {
            positions,
            lens,
            agents,
            k,
            steps,
            dt,
            starts: None,
        })
    }

    /// A view of a batch predicted at step `dt`.
    pub fn from_batch(batch: &'a TrajectoryBatch, dt: f64) -> Result<Self, OccupancyError> {
        Self::new(batch.positions(), batch.lens(), batch.shape(), dt)
    }

    /// The same samples with each person's position at time 0 (one per agent, for
    /// instance the observed states' positions): times in `[0, dt)` are then
    /// interpolated between it and the first step.
    pub fn with_starts(mut self, starts: &'a [Point]) -> Result<Self, OccupancyError> {
        if starts.len() != self.agents {
            return Err(OccupancyError::Samples(format!(
                "{} start positions for {} agents",
                starts.len(),
                self.agents
            )));
        }
        if let Some(i) = starts
            .iter()
            .position(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(OccupancyError::Samples(format!(
                "start position of agent {i} is not finite"
            )));
        }
        self.starts = Some(starts);
        Ok(self)
    }

    /// `(agents, k, steps)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.agents, self.k, self.steps)
    }

    /// The step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The times the samples cover: from 0 (with start positions) or `dt`, to
    /// `steps * dt`.
    pub fn span(&self) -> (f64, f64) {
        let first = if self.starts.is_some() { 0.0 } else { self.dt };
        (first, self.steps as f64 * self.dt)
    }

    /// Where time `t` falls among the steps, or why it cannot be used (`index` names
    /// it in errors).
    pub(super) fn time_index(&self, index: usize, t: f64) -> Result<TimeIndex, OccupancyError> {
        self.find_time(t).ok_or_else(|| {
            let (first, last) = self.span();
            OccupancyError::Time {
                index,
                time: t,
                why: format!("outside the predicted span [{first}, {last}] s"),
            }
        })
    }

    /// Where time `t` falls among the steps; `None` outside [`span`](Self::span).
    pub(super) fn find_time(&self, t: f64) -> Option<TimeIndex> {
        let (first, last) = self.span();
        let slack = 1e-6 * self.dt;
        if !t.is_finite() || t < first - slack || t > last + slack || self.steps == 0 {
            return None;
        }
        let u = (t / self.dt - 1.0).max(-1.0);
        let mut before = u.floor();
        let mut frac = u - before;
        if frac > 1.0 - 1e-6 {
            before += 1.0;
            frac = 0.0;
        } else if frac < 1e-6 {
            frac = 0.0;
        }
        let before = (before as isize).min(self.steps as isize - 1);
        Some(TimeIndex {
            before,
            frac: frac as f32,
        })
    }

    /// The valid length of sample `s` of agent `a`.
    pub(super) fn len(&self, a: usize, s: usize) -> usize {
        self.lens[a * self.k + s] as usize
    }

    /// The position of sample `s` of agent `a` at a time, under the stop rule; `None`
    /// when the sample has none there (it stopped before, and the rule does not hold
    /// it; or it has no position at all).
    pub(super) fn at(&self, a: usize, s: usize, t: TimeIndex, stopped: Stopped) -> Option<Point> {
        let len = self.len(a, s) as isize;
        let base = (a * self.k + s) * self.steps;
        let start = self.starts.map(|st| st[a]);
        let point = |j: isize| -> Option<Point> {
            if j < 0 {
                start
            } else {
                Some(self.positions[base + j as usize])
            }
        };
        let needed = if t.frac > 0.0 { t.before + 1 } else { t.before };
        if needed < len {
            let p0 = point(t.before)?;
            if t.frac == 0.0 {
                return Some(p0);
            }
            let p1 = point(t.before + 1)?;
            return Some([
                p0[0] + (p1[0] - p0[0]) * t.frac,
                p0[1] + (p1[1] - p0[1]) * t.frac,
            ]);
        }
        match stopped {
            Stopped::Hold => point(len - 1),
            Stopped::Renormalise | Stopped::Drop => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_are_interpolated_between_steps_and_from_the_start() {
        // one agent, two samples of 3 steps at dt 0.5: the first walks +x at 1 m/s,
        // the second stops after one step
        let pos = [
            [0.5, 0.0],
            [1.0, 0.0],
            [1.5, 0.0],
            [0.0, 0.5],
            [f32::NAN; 2],
            [f32::NAN; 2],
        ];
        let lens = [3, 1];
        let s = Samples::new(&pos, &lens, (1, 2, 3), 0.5).unwrap();
        assert_eq!(s.span(), (0.5, 1.5));
        let at = |s: &Samples, samp, t, rule| s.at(0, samp, s.time_index(0, t).unwrap(), rule);
        assert_eq!(at(&s, 0, 0.75, Stopped::Renormalise), Some([0.75, 0.0]));
        assert_eq!(at(&s, 0, 1.5, Stopped::Renormalise), Some([1.5, 0.0]));
        assert_eq!(at(&s, 1, 0.5, Stopped::Renormalise), Some([0.0, 0.5]));
        assert_eq!(at(&s, 1, 0.75, Stopped::Renormalise), None);
        assert_eq!(at(&s, 1, 1.5, Stopped::Drop), None);
        assert_eq!(at(&s, 1, 1.5, Stopped::Hold), Some([0.0, 0.5]));
        assert!(s.time_index(3, 0.25).is_err());
        let e = s.time_index(3, 1.6).unwrap_err().to_string();
        assert!(e.starts_with("time 3 (1.6 s)"), "{e}");
        let starts = [[0.0f32, 0.0]];
        let s = s.with_starts(&starts).unwrap();
        assert_eq!(s.span(), (0.0, 1.5));
        assert_eq!(at(&s, 0, 0.25, Stopped::Renormalise), Some([0.25, 0.0]));
        assert_eq!(at(&s, 1, 0.0, Stopped::Renormalise), Some([0.0, 0.0]));
    }

    #[test]
    fn buffers_of_the_wrong_shape_are_refused() {
        let pos = [[0.0f32; 2]; 6];
        assert!(Samples::new(&pos, &[3, 3], (1, 2, 3), 0.4).is_ok());
        for (lens, shape, dt) in [
            (&[3u32, 3][..], (1, 2, 4), 0.4),
            (&[3, 3, 3][..], (1, 2, 3), 0.4),
            (&[3, 4][..], (1, 2, 3), 0.4),
            (&[3, 3][..], (1, 2, 3), 0.0),
            (&[3, 3][..], (usize::MAX, 2, 3), 0.4),
        ] {
            let e = Samples::new(&pos, lens, shape, dt).unwrap_err().to_string();
            assert!(e.starts_with("samples: "), "{e}");
        }
    }
}
