//! The reusable, flat buffer of sampled trajectories.

use super::PredictError;

/// A predicted position `[x, y]` in metres (f32 is ample for buildings: micrometres at 100 m).
pub type Point = [f32; 2];

/// A batch of sampled trajectories: `agents x k` samples of `steps` positions each,
/// stored flat (sample-major), plus the valid length of each sample (a CLiFF-LHMP sample
/// stops where the map has no data).
///
/// Reuse one batch between calls: [`reshape`](Self::reshape) keeps the allocation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrajectoryBatch {
    agents: usize,
    k: usize,
    steps: usize,
    positions: Vec<Point>,
    lens: Vec<u32>,
    /// One score per sample when the last call asked for scores, else empty.
    scores: Vec<f32>,
}

/// Mutable views of the two buffers a prediction writes: `positions` holds
/// `agents x k x steps` points and `lens` the `agents x k` valid lengths.
#[derive(Debug)]
pub struct BatchMut<'a> {
    /// Positions, sample-major: sample `a * k + s`, step `j` at `(a * k + s) * steps + j`.
    pub positions: &'a mut [Point],
    /// Valid length of each sample.
    pub lens: &'a mut [u32],
}

impl TrajectoryBatch {
    /// An empty batch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Set the shape, growing the buffers only when they are too small. For shapes from
    /// untrusted input use [`try_reshape`](Self::try_reshape): this one panics when the
    /// size overflows and aborts when the allocation fails.
    pub fn reshape(&mut self, agents: usize, k: usize, steps: usize) {
        self.agents = agents;
        self.k = k;
        self.steps = steps;
        self.positions.resize(agents * k * steps, [f32::NAN; 2]);
        self.lens.resize(agents * k, 0);
    }

    /// Set the shape like [`reshape`](Self::reshape), but report a size that overflows
    /// or cannot be allocated as [`PredictError::TooLarge`] (the batch keeps its old
    /// shape then).
    pub fn try_reshape(
        &mut self,
        agents: usize,
        k: usize,
        steps: usize,
    ) -> Result<(), PredictError> {
        let too_large = || PredictError::TooLarge { agents, k, steps };
        let samples = agents.checked_mul(k).ok_or_else(too_large)?;
        let points = samples.checked_mul(steps).ok_or_else(too_large)?;
        let more_points = points.saturating_sub(self.positions.len());
        let more_lens = samples.saturating_sub(self.lens.len());
        self.positions
            .try_reserve(more_points)
            .map_err(|_| too_large())?;
        self.lens.try_reserve(more_lens).map_err(|_| too_large())?;
        self.reshape(agents, k, steps);
        Ok(())
    }

    /// `(agents, k, steps)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.agents, self.k, self.steps)
    }

    /// All positions, sample-major.
    pub fn positions(&self) -> &[Point] {
        &self.positions
    }

    /// The valid length of every sample.
    pub fn lens(&self) -> &[u32] {
        &self.lens
    }

    /// Valid length of sample `s` of agent `a`.
    pub fn len(&self, a: usize, s: usize) -> usize {
        self.lens[a * self.k + s] as usize
    }

    /// True when the batch holds no samples.
    pub fn is_empty(&self) -> bool {
        self.lens.is_empty()
    }

    /// The valid positions of sample `s` of agent `a`.
    pub fn sample(&self, a: usize, s: usize) -> &[Point] {
        &self.full_sample(a, s)[..self.len(a, s)]
    }

    /// All `steps` positions of sample `s` of agent `a` (NaN past the valid length).
    pub fn full_sample(&self, a: usize, s: usize) -> &[Point] {
        let i = (a * self.k + s) * self.steps;
        &self.positions[i..i + self.steps]
    }

    /// The score of every sample (see [`Options::scores`](super::Options::scores)),
    /// empty when the last prediction did not compute them.
    pub fn scores(&self) -> &[f32] {
        &self.scores
    }

    /// The score of sample `s` of agent `a`, when the last prediction computed scores.
    pub fn score(&self, a: usize, s: usize) -> Option<f32> {
        self.scores.get(a * self.k + s).copied()
    }

    /// The sample of agent `a` with the highest score (the first of equals), when the
    /// last prediction computed scores.
    pub fn best_sample(&self, a: usize) -> Option<usize> {
        let scores = self.scores.get(a * self.k..(a + 1) * self.k)?;
        let mut best = 0;
        for (s, v) in scores.iter().enumerate() {
            if *v > scores[best] {
                best = s;
            }
        }
        Some(best)
    }

    /// Set the scores of a batch filled from elsewhere (a daemon's response, through
    /// [`as_mut`](Self::as_mut)): one per sample of the current shape, or `None` for
    /// none. `Err` names a length that is not `agents x k`.
    pub fn set_scores(&mut self, scores: Option<&[f32]>) -> Result<(), PredictError> {
        let Some(scores) = scores else {
            self.scores.clear();
            return Ok(());
        };
        if scores.len() != self.lens.len() {
            return Err(PredictError::Param {
                name: "scores",
                why: format!(
                    "{} scores for a batch of {} samples",
                    scores.len(),
                    self.lens.len()
                ),
            });
        }
        self.try_size_scores(true)?;
        self.scores.copy_from_slice(scores);
        Ok(())
    }

    /// Size the score buffer for the current shape (`true`) or empty it (`false`).
    pub(super) fn try_size_scores(&mut self, on: bool) -> Result<(), PredictError> {
        if on {
            let n = self.lens.len();
            self.scores
                .try_reserve(n.saturating_sub(self.scores.len()))
                .map_err(|_| PredictError::TooLarge {
                    agents: self.agents,
                    k: self.k,
                    steps: self.steps,
                })?;
            self.scores.resize(n, 0.0);
        } else {
            self.scores.clear();
        }
        Ok(())
    }

    /// Mutable views of the buffers and of the score buffer.
    pub(super) fn parts_mut(&mut self) -> (BatchMut<'_>, &mut [f32]) {
        (
            BatchMut {
                positions: &mut self.positions,
                lens: &mut self.lens,
            },
            &mut self.scores,
        )
    }

    /// Mutable views of the buffers, for [`predict_into`](super::predict_into).
    pub fn as_mut(&mut self) -> BatchMut<'_> {
        BatchMut {
            positions: &mut self.positions,
            lens: &mut self.lens,
        }
    }
}
