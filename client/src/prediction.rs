//! The [`Prediction`] a call returns (read in place from the response) and the view of
//! one agent's samples ([`AgentPrediction`]).

use std::fmt;
use std::marker::PhantomData;

use iceoryx2::response::Response;

use crate::ipc::ClientIpc;
use crate::protocol::ResponseHeader;

/// An owned response (no lifetime); see [`Prediction`].
pub(crate) type RawResponse = Response<ClientIpc, [u32], ResponseHeader>;

/// A batch of predicted trajectories, read in place from shared memory (or, over zenoh,
/// from the client's own buffer). It borrows the client: drop it before the next call.
///
/// Layout as [`cliff::predict::TrajectoryBatch`]: `agents x k` samples of `steps`
/// positions each, every sample with its valid length (a CLiFF-LHMP sample ends where
/// the map has no data).
pub struct Prediction<'c> {
    body: Body<'c>,
}

/// Where a [`Prediction`]'s data lives.
enum Body<'c> {
    /// The response in shared memory; the [`Prediction`] borrows the client that
    /// received it for `'c`.
    Shm(RawResponse, PhantomData<&'c mut ()>),
    Buffered(ResponseHeader, &'c [u32]),
}

impl fmt::Debug for Prediction<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Prediction")
            .field("request_id", &self.request_id())
            .field("shape", &self.shape())
            .finish()
    }
}

/// The parts of a checked response payload.
pub(crate) struct Parts<'a> {
    pub positions: &'a [[f32; 2]],
    pub lens: &'a [u32],
    /// Empty when the response carries no scores.
    pub scores: &'a [f32],
}

/// Split a payload whose length was checked against `h` (by the client, before the
/// payload is read).
pub(crate) fn split_payload<'a>(h: &ResponseHeader, payload: &'a [u32]) -> Parts<'a> {
    let samples = (h.agents as usize) * (h.k as usize);
    let points = samples * (h.steps as usize);
    let (pos, rest) = payload.split_at(points * 2);
    let (lens, scores) = rest.split_at(samples.min(rest.len()));
    Parts {
        positions: bytemuck::cast_slice(pos),
        lens,
        scores: bytemuck::cast_slice(scores),
    }
}

/// The sample with the highest score (the first of equals), as
/// [`TrajectoryBatch::best_sample`](cliff::predict::TrajectoryBatch::best_sample).
pub(crate) fn best_of(scores: &[f32]) -> Option<usize> {
    let mut best = None;
    for (s, v) in scores.iter().enumerate() {
        if best.is_none_or(|b: usize| *v > scores[b]) {
            best = Some(s);
        }
    }
    best
}

impl<'c> Prediction<'c> {
    /// A prediction read in place from a (checked) response in shared memory.
    pub(crate) fn in_shared_memory(response: RawResponse) -> Self {
        Prediction {
            body: Body::Shm(response, PhantomData),
        }
    }

    /// A prediction of a (checked) response header whose payload is in the client's own
    /// buffer (zenoh).
    pub(crate) fn buffered(header: ResponseHeader, payload: &'c [u32]) -> Self {
        Prediction {
            body: Body::Buffered(header, payload),
        }
    }

    fn header(&self) -> &ResponseHeader {
        match &self.body {
            Body::Shm(r, _) => r.user_header(),
            Body::Buffered(h, _) => h,
        }
    }

    fn payload(&self) -> &[u32] {
        match &self.body {
            Body::Shm(r, _) => r.payload(),
            Body::Buffered(_, p) => p,
        }
    }

    /// The request id this answers (checked against the request by the client).
    pub fn request_id(&self) -> u64 {
        self.header().request_id
    }

    /// The version of the map that answered ([`ResponseHeader::map_version`]): 0 for the
    /// map as loaded, one more for every learned version a learning daemon swapped in.
    pub fn map_version(&self) -> u32 {
        self.header().map_version
    }

    /// `(agents, k, steps)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        let h = self.header();
        (h.agents as usize, h.k as usize, h.steps as usize)
    }

    /// All positions, sample-major (NaN past each sample's valid length).
    pub fn positions(&self) -> &[[f32; 2]] {
        split_payload(self.header(), self.payload()).positions
    }

    /// The valid length of every sample (`agents x k`).
    pub fn lens(&self) -> &[u32] {
        split_payload(self.header(), self.payload()).lens
    }

    /// True when the response carries scores ([`ResponseHeader::flags`]): the request asked for
    /// them ([`Request::scores`](crate::Request::scores)) or its method scores its samples
    /// (`Method::Improved`).
    pub fn has_scores(&self) -> bool {
        self.header().has_scores()
    }

    /// The score of every sample (`agents x k`, sample `a * k + s`), when the response
    /// carries scores ([`has_scores`](Self::has_scores)); empty otherwise. A score is the
    /// log-likelihood of the sample under the map ([`cliff::predict::Options::scores`]):
    /// compare the samples of one response.
    pub fn scores(&self) -> &[f32] {
        split_payload(self.header(), self.payload()).scores
    }

    /// The score of sample `s` of agent `a`, when the response carries scores.
    pub fn score(&self, a: usize, s: usize) -> Option<f32> {
        let k = self.shape().1;
        if s >= k {
            return None;
        }
        self.scores().get(a * k + s).copied()
    }

    /// The sample of agent `a` with the highest score (the first of equals), when the
    /// response carries scores and `a` is in range.
    pub fn best_sample(&self, a: usize) -> Option<usize> {
        let k = self.shape().1;
        best_of(self.scores().get(a * k..(a + 1) * k)?)
    }

    /// The predictions for agent `a` (panics when `a` is out of range).
    pub fn agent(&self, a: usize) -> AgentPrediction<'_> {
        let (agents, k, steps) = self.shape();
        assert!(a < agents, "agent {a} of {agents}");
        let parts = split_payload(self.header(), self.payload());
        AgentPrediction {
            index: a,
            steps,
            positions: &parts.positions[a * k * steps..(a + 1) * k * steps],
            lens: &parts.lens[a * k..(a + 1) * k],
            scores: parts.scores.get(a * k..(a + 1) * k).unwrap_or(&[]),
        }
    }

    /// Iterate over the agents, in request order.
    pub fn agents(&self) -> impl ExactSizeIterator<Item = AgentPrediction<'_>> + '_ {
        (0..self.shape().0).map(move |a| self.agent(a))
    }

    /// Copy into a [`TrajectoryBatch`](cliff::predict::TrajectoryBatch) (for keeping the
    /// result beyond the next call), with the scores when the response carries them.
    pub fn to_batch(&self, out: &mut cliff::predict::TrajectoryBatch) {
        let (a, k, s) = self.shape();
        out.reshape(a, k, s);
        let m = out.as_mut();
        m.positions.copy_from_slice(self.positions());
        m.lens.copy_from_slice(self.lens());
        let scores = self.has_scores().then(|| self.scores());
        // a checked response holds one score per sample of its shape
        out.set_scores(scores)
            .expect("a checked response has a score per sample");
    }
}

/// The `k` samples predicted for one agent.
#[derive(Debug, Clone, Copy)]
pub struct AgentPrediction<'p> {
    index: usize,
    steps: usize,
    positions: &'p [[f32; 2]],
    lens: &'p [u32],
    scores: &'p [f32],
}

impl<'p> AgentPrediction<'p> {
    /// The agent's index in the request.
    pub fn index(&self) -> usize {
        self.index
    }

    /// Number of samples (`k`).
    pub fn len(&self) -> usize {
        self.lens.len()
    }

    /// True when `k` is zero (never for an accepted request).
    pub fn is_empty(&self) -> bool {
        self.lens.is_empty()
    }

    /// The valid positions of sample `s`, one per `dt`.
    pub fn sample(&self, s: usize) -> &'p [[f32; 2]] {
        let start = s * self.steps;
        &self.positions[start..start + self.lens[s] as usize]
    }

    /// Iterate over the samples (each a slice of valid positions).
    pub fn samples(&self) -> impl ExactSizeIterator<Item = &'p [[f32; 2]]> + use<'p> {
        let this = *self;
        (0..self.lens.len()).map(move |s| this.sample(s))
    }

    /// The samples' scores (empty when the response carries none).
    pub fn scores(&self) -> &'p [f32] {
        self.scores
    }

    /// The sample with the highest score (the first of equals), when the response
    /// carries scores.
    pub fn best_sample(&self) -> Option<usize> {
        best_of(self.scores)
    }
}
