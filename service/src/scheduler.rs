//! Requests in progress, cut into chunks that take turns.
//!
//! An accepted request becomes a task: its map, its decoded agents, a
//! [`Rollout`] (the request's generator and options between chunks) and its output
//! buffer (a loaned shared-memory response, or any buffer of `u32` words laid out as the
//! protocol's payload: positions, lengths, and the scores when asked for). The serving loop runs *rounds*: each round takes tasks from the front of
//! the queue, one chunk of whole agents each (about [`Settings::chunk_positions`]
//! predicted positions), until the round holds `chunk_positions x workers` positions;
//! the round's chunks run in parallel on the workers; tasks with agents left go to the
//! back of the queue, and new tasks join at its front. So a small request waits behind
//! at most one round of chunks (about 0.2 ms of work per worker), however large the
//! other requests are, and large requests share the daemon evenly.
//!
//! Each agent draws from a generator of its own (seeded from the request's seed and
//! the agent's place in it), so chunks give the bytes of one call whatever their order:
//! the same request and seed give the same bytes (and scores) as
//! [`cliff::predict::predict_with`]. When a round holds fewer tasks than workers, a task
//! with agents left takes several chunks at once, one per idle worker (each with a
//! rollout of its own, positioned at its first agent): one large request uses every
//! worker.
//!
//! A chunk's size counts positions at their cost: a method that costs a multiple of
//! CLiFF-LHMP per position ([`cost_factor`]) gets chunks that many times smaller.
//!
//! [`Settings::chunk_positions`]: crate::Settings::chunk_positions

use std::collections::VecDeque;
use std::sync::Arc;

use cliff::map::{CliffMap, Lookup};
use cliff::motion::{History, MotionModel, State};
use cliff::predict::preset::cost_factor;
use cliff::predict::{BatchMut, Options, Params, Point, Rollout, Tables};
use cliff_client::protocol::{DecodeScratch, Decoded, Limits, RequestHeader};
use rayon::prelude::*;
use tracing::error;

/// A task's output: the response payload, `agents x k x steps x 2` position words
/// then `agents x k` lengths, then `agents x k` scores when the request asked for them.
pub(crate) trait Output {
    /// The payload words.
    fn words(&mut self) -> &mut [u32];
}

impl Output for Vec<u32> {
    fn words(&mut self) -> &mut [u32] {
        self
    }
}

/// Positions a round must hold before it is split over the workers: waking a sleeping
/// worker costs tens of microseconds, about a thousand positions' work.
const PARALLEL_MIN_POSITIONS: usize = 4000;

/// A grid-scan lookup tests up to this many locations per eighth of a table lookup's
/// cost (measured: a table lookup costs about as much as eight grid cells).
const GRID_TESTS_PER_UNIT: usize = 8;

/// An accepted request in progress.
struct Task {
    map: Arc<CliffMap>,
    params: Params,
    options: Options,
    /// Times the paper's work per position ([`cost_factor`]).
    factor: usize,
    rollout: Rollout,
    /// Rollouts for the task's further chunks of a round (one per other worker).
    helpers: Vec<Rollout>,
    /// Agents the helpers predicted in the last round, for `rollout` to skip.
    skip: usize,
    agents: usize,
    next: usize,
    /// Agents per chunk.
    chunk: usize,
    ok: bool,
}

/// A request slot: decoding buffers, then the task and its output.
pub(crate) struct Slot<O> {
    /// The request's header.
    pub header: RequestHeader,
    /// The decoded agents.
    pub scratch: DecodeScratch,
    /// The rollout of the slot's last request and its helpers, restarted for the next
    /// one (their buffers, e.g. for candidates, are grown once).
    spare: Option<(Rollout, Vec<Rollout>)>,
    task: Option<Task>,
    output: Option<O>,
}

/// A finished request.
pub(crate) struct Finished<'a, O> {
    pub header: &'a RequestHeader,
    pub params: &'a Params,
    /// The payload carries the scores.
    pub scores: bool,
    pub agents: usize,
    pub output: O,
    /// False when the prediction failed (a bug: decoding checks what it checks).
    pub ok: bool,
    /// Other requests in progress: queued, or finished in the same round.
    pub others: usize,
}

/// Requests in progress and the workers that predict them.
pub(crate) struct Scheduler<O> {
    slots: Vec<Slot<O>>,
    free: Vec<usize>,
    queue: VecDeque<usize>,
    round: Vec<usize>,
    done: Vec<usize>,
    jobs: Vec<Chunk<'static>>,
    /// Chunks per task in the round being run (parallel to `round`).
    shares: Vec<usize>,
    /// Slots whose chunk failed in the round being run.
    failed: Vec<usize>,
    pool: Option<rayon::ThreadPool>,
    workers: usize,
    chunk_positions: usize,
    /// The motion model every rollout starts from (`None`: the built-in one).
    motion: Option<Arc<MotionModel>>,
    /// Chunks run in parallel with others (counter).
    pub parallel_chunks: u64,
}

impl<O: Output> Scheduler<O> {
    /// `capacity` requests at once, each within `limits`.
    pub fn new(
        capacity: usize,
        limits: &Limits,
        workers: usize,
        chunk_positions: usize,
    ) -> Result<Self, String> {
        let pool = if workers > 1 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(workers)
                .use_current_thread()
                .thread_name(|i| format!("cliffd-worker-{i}"))
                .build()
                .map_err(|e| format!("cannot start the workers: {e}"))?;
            Some(pool)
        } else {
            None
        };
        Ok(Self {
            slots: (0..capacity)
                .map(|_| Slot {
                    header: RequestHeader::default(),
                    scratch: DecodeScratch::new(limits),
                    spare: None,
                    task: None,
                    output: None,
                })
                .collect(),
            free: (0..capacity).rev().collect(),
            queue: VecDeque::with_capacity(capacity),
            round: Vec::with_capacity(capacity),
            done: Vec::with_capacity(capacity),
            jobs: Vec::with_capacity(capacity * workers.max(1)),
            shares: Vec::with_capacity(capacity),
            failed: Vec::with_capacity(capacity * workers.max(1)),
            pool,
            workers,
            chunk_positions,
            motion: None,
            parallel_chunks: 0,
        })
    }

    /// The same scheduler with the motion model its rollouts start from (the methods
    /// `motion` and `improved`).
    pub fn with_motion_model(mut self, model: Option<Arc<MotionModel>>) -> Self {
        self.motion = model;
        self
    }

    /// The slot the next request decodes into, or `None` when every slot is busy.
    #[inline]
    pub fn free_slot(&mut self) -> Option<&mut Slot<O>> {
        let i = *self.free.last()?;
        Some(&mut self.slots[i])
    }

    /// True while tasks wait for chunks.
    #[inline]
    pub fn busy(&self) -> bool {
        !self.queue.is_empty()
    }

    /// True when finished requests wait for [`take_finished`](Self::take_finished).
    #[inline]
    pub fn has_finished(&self) -> bool {
        !self.done.is_empty()
    }

    /// Requests in progress.
    #[cfg(test)]
    pub fn in_progress(&self) -> usize {
        self.queue.len()
    }

    /// Accept the request decoded into [`free_slot`](Self::free_slot): its agents are in
    /// the slot's scratch, `output` holds the payload for `decoded` and them.
    pub fn admit(&mut self, map: Arc<CliffMap>, decoded: &Decoded, output: O) {
        let Some(i) = self.free.pop() else {
            debug_assert!(false, "admit without a free slot");
            return;
        };
        let (params, options) = (&decoded.params, &decoded.options);
        let slot = &mut self.slots[i];
        let agents = slot.scratch.states().len();
        let factor = cost_factor(params, options);
        let per_agent = params.k * params.steps() * factor;
        // Grid-scan lookups cost more per position than a table's.
        let looks_up = params.method.samples_map() || options.scores;
        let weight = match map.cached_lookup(params.radius) {
            l @ Lookup::Grid(..) if looks_up => 1 + l.max_tests() / GRID_TESTS_PER_UNIT,
            _ => 1,
        };
        let chunk = (self.chunk_positions / per_agent.saturating_mul(weight).max(1)).max(1);
        // Decoding checked the parameters, so the rollout cannot fail; if it did, the
        // request is answered as an internal error.
        let motion = &self.motion;
        let fresh = || {
            Rollout::new(params)
                .and_then(|r| r.with_options(*options))
                .map(|r| r.with_tables(Tables::CachedOnly))
                .map(|r| match motion {
                    Some(m) => r.with_motion_model(m.clone()),
                    None => r,
                })
        };
        let (rollout, helpers) = match slot.spare.take() {
            Some((mut r, helpers)) => (r.restart(params, *options).map(|()| r), helpers),
            None => (
                fresh(),
                (1..self.workers)
                    .filter_map(|_| fresh().ok())
                    .collect::<Vec<_>>(),
            ),
        };
        let (rollout, ok) = match rollout {
            Ok(r) => (r, true),
            Err(e) => {
                error!("request parameters passed decoding but not the predictor: {e}");
                (
                    Rollout::new(&Params::default()).expect("valid defaults"),
                    false,
                )
            }
        };
        slot.task = Some(Task {
            map,
            params: *params,
            options: *options,
            factor,
            rollout,
            helpers,
            skip: 0,
            agents,
            next: 0,
            chunk,
            ok,
        });
        slot.output = Some(output);
        if ok {
            self.queue.push_front(i);
        } else {
            self.done.push(i);
        }
    }

    /// Run one round of chunks; returns the positions predicted (at their cost: times
    /// [`cost_factor`]).
    pub fn run_round(&mut self) -> usize {
        let budget = self.chunk_positions * self.workers;
        let mut positions = 0;
        while let Some(&i) = self.queue.front() {
            let t = self.slots[i]
                .task
                .as_ref()
                .expect("queued slots hold a task");
            let n = t.chunk.min(t.agents - t.next);
            // positions at their cost
            let p = n * t.params.k * t.params.steps() * t.factor;
            if !self.round.is_empty() && positions + p > budget {
                break;
            }
            self.queue.pop_front();
            self.round.push(i);
            positions += p;
        }
        if self.round.is_empty() {
            return 0;
        }
        // Fewer tasks than workers: tasks with agents left take a chunk per idle worker.
        let mut idle = self.workers.saturating_sub(self.round.len());
        self.shares.clear();
        for &i in &self.round {
            let t = self.slots[i]
                .task
                .as_ref()
                .expect("round slots hold a task");
            let chunks = (t.agents - t.next).div_ceil(t.chunk.max(1)).max(1);
            let extra = idle.min(chunks - 1).min(t.helpers.len());
            idle -= extra;
            self.shares.push(1 + extra);
            if extra > 0 {
                // the extra chunks' positions, at their cost
                let n = (t.chunk * extra).min(t.agents - t.next - t.chunk.min(t.agents - t.next));
                positions += n * t.params.k * t.params.steps() * t.factor;
            }
        }
        // Collect the round's chunks (disjoint slots: one mutable borrow each).
        let mut jobs = recycle(std::mem::take(&mut self.jobs));
        {
            let (round, shares) = (&self.round, &self.shares);
            for (i, slot) in self.slots.iter_mut().enumerate() {
                let Some(r) = round.iter().position(|&j| j == i) else {
                    continue;
                };
                let (Some(task), Some(out)) = (slot.task.as_mut(), slot.output.as_mut()) else {
                    continue;
                };
                Chunk::split(
                    task,
                    slot.scratch.states(),
                    slot.scratch.histories(),
                    out.words(),
                    i,
                    shares[r],
                    &mut jobs,
                );
            }
        }
        match &self.pool {
            Some(pool) if jobs.len() > 1 && positions >= PARALLEL_MIN_POSITIONS => {
                self.parallel_chunks += jobs.len() as u64;
                pool.install(|| jobs.par_iter_mut().for_each(|j| j.run()));
            }
            _ => jobs.iter_mut().for_each(|j| j.run()),
        }
        self.failed.clear();
        self.failed
            .extend(jobs.iter().filter(|j| !j.ok).map(|j| j.slot));
        self.jobs = recycle(jobs);
        for &i in &self.failed {
            if let Some(t) = self.slots[i].task.as_mut() {
                t.ok = false;
            }
        }
        // the tasks' rollouts move past the agents their helpers predicted
        for &i in &self.round {
            if let Some(t) = self.slots[i].task.as_mut() {
                t.rollout.skip(std::mem::take(&mut t.skip) as u64);
            }
        }
        // Requeue what has agents left; collect what is done.
        for &i in &self.round {
            let t = self.slots[i]
                .task
                .as_ref()
                .expect("round slots hold a task");
            if t.ok && t.next < t.agents {
                self.queue.push_back(i);
            } else {
                self.done.push(i);
            }
        }
        self.round.clear();
        positions
    }

    /// Hand every finished request to `f` and free its slot.
    pub fn take_finished(&mut self, mut f: impl FnMut(Finished<'_, O>)) {
        // every response of a round counts the others of that round and those queued
        let others = (self.queue.len() + self.done.len()).saturating_sub(1);
        while let Some(i) = self.done.pop() {
            let slot = &mut self.slots[i];
            let (Some(task), Some(output)) = (slot.task.take(), slot.output.take()) else {
                continue;
            };
            f(Finished {
                header: &slot.header,
                params: &task.params,
                scores: task.options.scores,
                agents: task.agents,
                output,
                ok: task.ok,
                others,
            });
            slot.spare = Some((task.rollout, task.helpers));
            self.free.push(i);
        }
    }
}

/// One chunk of a task: its next agents and where their samples go.
struct Chunk<'a> {
    map: &'a CliffMap,
    rollout: &'a mut Rollout,
    states: &'a [State],
    /// The chunk's agents' observed paths (`motion` and `cvm-last` read them).
    histories: &'a [History],
    positions: &'a mut [Point],
    lens: &'a mut [u32],
    /// The chunk's scores (`None` when the request asked for none).
    scores: Option<&'a mut [f32]>,
    /// The task's slot.
    slot: usize,
    /// False once the prediction failed.
    ok: bool,
}

impl<'a> Chunk<'a> {
    /// The task's next `count` chunks (at most one more than it has helpers), pushed to
    /// `jobs`: the first on the task's rollout, the others on its helpers, restarted
    /// and moved to their first agent. The task's next agent moves past them all.
    fn split(
        task: &'a mut Task,
        states: &'a [State],
        histories: &'a [History],
        words: &'a mut [u32],
        slot: usize,
        count: usize,
        jobs: &mut Vec<Chunk<'a>>,
    ) {
        let (k, steps) = (task.params.k, task.params.steps());
        let samples = task.agents * k;
        let (pos_words, rest) = words.split_at_mut(samples * steps * 2);
        let (lens, score_words) = rest.split_at_mut(samples);
        let positions: &mut [Point] = bytemuck::cast_slice_mut(pos_words);
        let all_scores: Option<&mut [f32]> = task
            .options
            .scores
            .then(|| bytemuck::cast_slice_mut(score_words));
        // the slices from the task's next agent on
        let a = task.next;
        let (_, mut positions) = positions.split_at_mut(a * k * steps);
        let (_, mut lens) = lens.split_at_mut(a * k);
        let mut scores = all_scores.map(|s| s.split_at_mut(a * k).1);
        let mut states = &states[a..task.agents];
        let mut histories = &histories[a..task.agents];
        let (params, options) = (task.params, task.options);
        let mut helped = 0;
        let rollouts = std::iter::once(&mut task.rollout).chain(task.helpers.iter_mut());
        for (j, rollout) in rollouts.take(count).enumerate() {
            let n = task.chunk.min(states.len());
            if n == 0 {
                break;
            }
            if j > 0 {
                // a helper: the same call, from this chunk's first agent on
                if rollout.restart(&params, options).is_err() {
                    break;
                }
                rollout.skip(task.next as u64);
                helped += n;
            }
            let (p, rest_p) = positions.split_at_mut(n * k * steps);
            let (l, rest_l) = lens.split_at_mut(n * k);
            let sc = match scores.take() {
                Some(s) => {
                    let (c, rest) = s.split_at_mut(n * k);
                    scores = Some(rest);
                    Some(c)
                }
                None => None,
            };
            let (st, rest_st) = states.split_at(n);
            let (hi, rest_hi) = histories.split_at(n);
            jobs.push(Chunk {
                map: &task.map,
                rollout,
                states: st,
                histories: hi,
                positions: p,
                lens: l,
                scores: sc,
                slot,
                ok: true,
            });
            (positions, lens, states, histories) = (rest_p, rest_l, rest_st, rest_hi);
            task.next += n;
        }
        task.skip = helped;
    }

    fn run(&mut self) {
        let out = BatchMut {
            positions: &mut *self.positions,
            lens: &mut *self.lens,
        };
        let scores = self.scores.as_deref_mut();
        if let Err(e) = self.rollout.predict_agents_observed(
            self.map,
            self.states,
            Some(self.histories),
            out,
            scores,
        ) {
            error!("prediction failed: {e}");
            self.ok = false;
        }
    }
}

/// Reuse a vector's memory for elements of another lifetime (it is empty in between),
/// so that a round builds its chunk list without allocating.
fn recycle<'b>(mut v: Vec<Chunk<'_>>) -> Vec<Chunk<'b>> {
    v.clear();
    // collecting an emptied vector's iterator in place keeps the allocation (same layout)
    v.into_iter().map(|_| unreachable!()).collect()
}

#[cfg(test)]
mod tests {
    use cliff::glam::DVec2;
    use cliff::predict::{Method, TrajectoryBatch, predict, predict_with, predict_with_histories};
    use cliff_client::protocol::payload_words;

    use super::*;

    #[test]
    fn recycled_chunk_vectors_keep_their_memory() {
        let v: Vec<Chunk<'static>> = Vec::with_capacity(16);
        let ptr = v.as_ptr() as usize;
        let w: Vec<Chunk<'_>> = recycle(v);
        assert_eq!((w.capacity(), w.as_ptr() as usize), (16, ptr));
        let back: Vec<Chunk<'static>> = recycle(w);
        assert_eq!((back.capacity(), back.as_ptr() as usize), (16, ptr));
    }

    fn walkers(n: usize) -> Vec<State> {
        (0..n)
            .map(|i| State {
                position: DVec2::new(-12.0 + 0.3 * i as f64, -1.0 + 0.1 * i as f64),
                speed: 1.1,
                heading: 0.05 * i as f64,
                time: 0.0,
            })
            .collect()
    }

    /// Decode and admit a request of `agents` walkers, as the serving loop does.
    fn admit(
        s: &mut Scheduler<Vec<u32>>,
        map: &Arc<CliffMap>,
        agents: usize,
        params: &Params,
    ) -> Vec<State> {
        admit_with(s, map, agents, params, &Options::default()).0
    }

    /// As [`admit`], with options.
    fn admit_with(
        s: &mut Scheduler<Vec<u32>>,
        map: &Arc<CliffMap>,
        agents: usize,
        params: &Params,
        options: &Options,
    ) -> (Vec<State>, Vec<History>) {
        let mut request = cliff_client::Request::new("demo", params).unwrap();
        request.set_options(options);
        for w in walkers(agents) {
            // a row 0.4 s before, on the way there
            let before = w.position - DVec2::from_angle(w.heading) * (w.speed * 0.4);
            let row = |t: f64, p: DVec2| {
                cliff_client::Observation::with_velocity(t, p.x, p.y, w.speed, w.heading)
            };
            request.add_agent([row(-0.4, before), row(0.0, w.position)]);
        }
        let slot = s.free_slot().expect("room");
        slot.header = *request.header();
        let decoded = cliff_client::protocol::decode_request(
            &slot.header,
            request.rows(),
            &Limits::default(),
            &mut slot.scratch,
        )
        .unwrap();
        assert_eq!(&decoded.params, params);
        let scored = options.scores || params.method == Method::Improved;
        assert_eq!(decoded.options.scores, scored);
        let states = slot.scratch.states().to_vec();
        let histories = slot.scratch.histories().to_vec();
        let out = vec![0u32; decoded.payload_words(agents)];
        assert_eq!(
            out.len(),
            payload_words(agents, params.k, params.steps(), scored)
        );
        s.admit(map.clone(), &decoded, out);
        (states, histories)
    }

    /// The payload words of a batch (positions' bits, then lengths, then the scores'
    /// bits when it has scores): NaN-safe equality.
    fn words_of(b: &TrajectoryBatch) -> Vec<u32> {
        let mut w: Vec<u32> = bytemuck::cast_slice(b.positions()).to_vec();
        w.extend_from_slice(b.lens());
        w.extend(b.scores().iter().map(|v| v.to_bits()));
        w
    }

    #[test]
    fn chunked_requests_with_options_give_the_bytes_and_scores_of_predict_with() {
        let map = Arc::new(CliffMap::demo());
        let params = Params {
            k: 12,
            horizon: 16.0,
            seed: 23,
            ..Params::default()
        };
        let cases = [
            Options {
                scores: true,
                ..Options::default()
            },
            Options {
                speed_beta: 2.0,
                coast: 6.0,
                scores: true,
                ..Options::default()
            },
            Options {
                speed_beta: 1.0,
                coast: 16.0,
                scores: false,
                ..Options::default()
            },
        ];
        for (i, options) in cases.iter().enumerate() {
            for method in Method::ALL {
                let params = Params { method, ..params };
                // chunks of one agent (480 positions): 7 rounds
                let mut s = Scheduler::<Vec<u32>>::new(2, &Limits::default(), 1, 480).unwrap();
                let (states, histories) = admit_with(&mut s, &map, 7, &params, options);
                let mut got = None;
                let mut rounds = 0;
                while s.busy() {
                    s.run_round();
                    rounds += 1;
                    s.take_finished(|f| {
                        assert!(f.ok);
                        // the improved preset scores its samples
                        let scored = options.scores || method == Method::Improved;
                        assert_eq!(f.scores, scored);
                        got = Some(f.output);
                    });
                }
                assert_eq!(rounds, 7, "case {i} {method}");
                let mut whole = TrajectoryBatch::new();
                predict_with_histories(&map, &states, &histories, &params, options, &mut whole)
                    .unwrap();
                let scored = options.scores || method == Method::Improved;
                assert_eq!(whole.scores().is_empty(), !scored);
                let got = got.expect("finished");
                assert!(got == words_of(&whole), "case {i} {method}: differs");
            }
        }
    }

    #[test]
    fn one_large_request_is_shared_among_the_workers_with_the_bytes_of_one_call() {
        let map = Arc::new(CliffMap::demo());
        // 3 workers, chunks of about 2,000 positions
        let mut s = Scheduler::<Vec<u32>>::new(2, &Limits::default(), 3, 2000).unwrap();
        for (params, options) in [
            (
                Params {
                    k: 20,
                    seed: 31,
                    ..Params::default()
                },
                Options::default(),
            ),
            (
                Params {
                    // one agent a chunk, three chunks a round above the parallel minimum
                    method: Method::Improved,
                    k: 8,
                    seed: 2,
                    ..Params::default()
                },
                Options::default(),
            ),
            (
                Params {
                    k: 8,
                    seed: 4,
                    ..Params::default()
                },
                Options {
                    speed_beta: 1.0,
                    coast: 2.0,
                    scores: true,
                    ..Options::default()
                },
            ),
        ] {
            // 30 agents (the default limit 32); the slot's rollouts are reused
            let before = s.parallel_chunks as usize;
            let (states, _) = admit_with(&mut s, &map, 30, &params, &options);
            let mut rounds = 0;
            let mut words = None;
            while s.busy() {
                s.run_round();
                rounds += 1;
                s.take_finished(|f| {
                    assert!(f.ok);
                    words = Some(f.output.clone());
                });
            }
            assert!(s.slots.iter().all(|t| t.task.is_none()));
            // every round but the last ran three chunks at once
            let per_agent = params.k * params.steps() * cost_factor(&params, &options);
            let chunk = (2000 / per_agent).max(1);
            assert_eq!(rounds, 30usize.div_ceil(3 * chunk), "{params:?}");
            assert!(
                s.parallel_chunks as usize - before >= 3 * (rounds - 1),
                "{params:?}"
            );
            let mut whole = TrajectoryBatch::new();
            predict_with(&map, &states, &params, &options, &mut whole).unwrap();
            assert!(words.unwrap() == words_of(&whole), "{params:?} {options:?}");
        }
    }

    #[test]
    fn chunked_requests_give_the_bytes_of_one_call_and_small_ones_finish_first() {
        let map = Arc::new(CliffMap::demo());
        let big = Params {
            k: 20,
            horizon: 12.0,
            seed: 11,
            ..Params::default()
        };
        let small = Params { seed: 5, ..big };
        // chunks of 2 agents (1200 positions): the big request takes two chunks a round
        // (one per worker) while alone, one beside the small one: 6 rounds
        let mut s = Scheduler::<Vec<u32>>::new(4, &Limits::default(), 2, 1200).unwrap();
        let big_states = admit(&mut s, &map, 20, &big);
        let mut small_states = Vec::new();
        let mut finished = Vec::new();
        let mut rounds = 0;
        while s.busy() {
            if rounds == 3 {
                small_states = admit(&mut s, &map, 1, &small);
            }
            s.run_round();
            rounds += 1;
            s.take_finished(|f| {
                assert!(f.ok);
                finished.push((rounds, f.agents, f.output.clone(), *f.params));
            });
        }
        // the small one, admitted after round 3, finished in round 4
        assert_eq!(
            finished.iter().map(|f| (f.0, f.1)).collect::<Vec<_>>(),
            vec![(4, 1), (6, 20)]
        );
        for (_, agents, words, params) in &finished {
            let states = if *agents == 1 {
                &small_states
            } else {
                &big_states
            };
            let mut whole = TrajectoryBatch::new();
            predict(&map, states, params, &mut whole).unwrap();
            assert!(words == &words_of(&whole), "{agents} agents differ");
        }
    }

    #[test]
    fn a_round_shares_its_budget_and_every_task_progresses() {
        let map = Arc::new(CliffMap::demo());
        let p = Params {
            k: 10,
            horizon: 4.0,
            ..Params::default()
        }; // 100 positions per agent
        let mut s = Scheduler::<Vec<u32>>::new(4, &Limits::default(), 2, 300).unwrap();
        for _ in 0..3 {
            admit(&mut s, &map, 9, &p); // 3 chunks of 3 agents each
        }
        // budget of 2 workers: two chunks (600 positions) per round
        assert_eq!(s.run_round(), 600);
        assert_eq!(s.run_round(), 600);
        assert_eq!(s.in_progress(), 3);
        let mut others = Vec::new();
        while s.busy() {
            s.run_round();
            s.take_finished(|f| {
                assert!(f.ok && f.agents == 9);
                others.push(f.others);
            });
        }
        // each response says how many other requests were still in progress
        assert_eq!(others.len(), 3);
        assert!(others[0] >= 1 && others[2] == 0, "{others:?}");
        assert!(others.windows(2).all(|w| w[0] >= w[1]), "{others:?}");
        assert!(
            s.parallel_chunks == 0,
            "rounds under the threshold run serially"
        );
    }
}
