//! One call of the rollout: its inputs and outputs, and the dispatch to the loop
//! flavour the method and options need (constant velocity, or the CLiFF-LHMP lane loop
//! with or without scores, speed kernel, coasting, follow and candidates).

use super::candidates::{Candidates, rank};
use super::cvm::{cvm_score, roll_cvm};
use super::lanes::{ANY, Extras, Lane, Lanes, PAPER, SPEED};
use super::motion::{
    Bend, bend_to_motion, history_of, last_displacement, map_evidence, motion_score, roll_motion,
    sample_normal,
};
use super::seeds::agent_key;
use super::{BatchMut, Method, Params, Point};
use crate::map::{CliffMap, NeighbourTable};
use crate::math::Simd;
use crate::motion::{History, MotionModel, State};
use glam::DVec2;

/// One call's inputs and outputs, for the flavour dispatch.
pub(super) struct Call<'a, 'b> {
    pub(super) map: &'a CliffMap,
    pub(super) agents: &'a [State],
    /// The agents' observed histories, when the caller has them ([`Method::Motion`] and
    /// [`Method::CvmLast`] read them).
    pub(super) histories: Option<&'a [History]>,
    /// The model of [`Method::Motion`].
    pub(super) motion: &'a MotionModel,
    pub(super) params: &'a Params,
    pub(super) extras: &'a Extras,
    /// The call's seed, and the index in the call of `agents[0]` ([`agent_key`]).
    pub(super) seed: u64,
    pub(super) first_agent: u64,
    pub(super) out: BatchMut<'b>,
    pub(super) scores: Option<&'b mut [f32]>,
    pub(super) scratch: &'a mut Candidates,
}

impl Call<'_, '_> {
    /// Predict with the map lookup `near` (monomorphised per lookup kind so the hot loop
    /// inlines it), which answers from `table` if it is given.
    pub(super) fn run(self, table: Option<&NeighbourTable>, near: impl Fn(DVec2) -> Option<usize>) {
        match self.params.method {
            Method::Cvm | Method::CvmLast => return self.cvm(near),
            Method::Motion => return self.motion(),
            Method::Cliff | Method::Improved => {}
        }
        let e = self.extras;
        let motion = if e.coast_steps > 0 || e.follow > 0.0 || e.trust > 0.0 || e.blend > 0.0 {
            ANY
        } else if e.speed_beta > 0.0 {
            SPEED
        } else {
            PAPER
        };
        // candidates are ranked by their scores
        let scores = self.scores.is_some() || e.candidates > 1;
        match (motion, scores) {
            (PAPER, false) => self.cliff::<PAPER, false>(table, near),
            (PAPER, true) => self.cliff::<PAPER, true>(table, near),
            (SPEED, false) => self.cliff::<SPEED, false>(table, near),
            (SPEED, true) => self.cliff::<SPEED, true>(table, near),
            (_, false) => self.cliff::<ANY, false>(table, near),
            (_, true) => self.cliff::<ANY, true>(table, near),
        }
    }

    pub(super) fn cvm(mut self, near: impl Fn(DVec2) -> Option<usize>) {
        let steps = self.params.steps();
        let k = self.params.k;
        for (a, state) in self.agents.iter().enumerate() {
            let state = &match (self.params.method, self.histories) {
                (Method::CvmLast, Some(h)) => last_displacement(state, &h[a]),
                _ => *state,
            };
            let tracks = &mut self.out.positions[a * k * steps..(a + 1) * k * steps];
            let lens = &mut self.out.lens[a * k..(a + 1) * k];
            for (track, len) in tracks.chunks_exact_mut(steps).zip(lens) {
                roll_cvm(state, self.params.dt, track);
                *len = steps as u32;
            }
            if let Some(scores) = self.scores.as_deref_mut() {
                let v = cvm_score(self.map, &near, state, self.params.dt, steps);
                scores[a * k..(a + 1) * k].fill(v as f32);
            }
        }
    }

    /// The motion model's samples of every agent (`motion.rs`).
    pub(super) fn motion(mut self) {
        let steps = self.params.steps();
        let k = self.params.k;
        let path = &mut self.scratch.bend.path;
        for (a, state) in self.agents.iter().enumerate() {
            let history = history_of(self.histories, a, state);
            path.fill(&self.motion.forecast(&history), self.params.dt, steps);
            let key = agent_key(self.seed, self.first_agent + a as u64);
            let tracks = &mut self.out.positions[a * k * steps..(a + 1) * k * steps];
            let lens = &mut self.out.lens[a * k..(a + 1) * k];
            for (s, (track, len)) in tracks.chunks_exact_mut(steps).zip(lens).enumerate() {
                let z = sample_normal(key, s);
                roll_motion(path, z, track);
                *len = steps as u32;
                if let Some(scores) = self.scores.as_deref_mut() {
                    scores[a * k + s] = motion_score(z);
                }
            }
        }
    }

    /// Roll every CLiFF-LHMP sample of every agent in the flavour `MOTION` ([`PAPER`],
    /// [`SPEED`] or [`ANY`]), `SCORES` (scores on, or candidates to rank).
    fn cliff<const MOTION: u8, const SCORES: bool>(
        self,
        table: Option<&NeighbourTable>,
        near: impl Fn(DVec2) -> Option<usize>,
    ) {
        let Call {
            map,
            agents,
            histories,
            motion,
            params,
            extras,
            seed,
            first_agent,
            out,
            mut scores,
            scratch,
        } = self;
        let steps = params.steps();
        let k = params.k;
        let c = extras.candidates;
        if c > 1 {
            scratch.tracks.resize(c * k * steps, [0.0; 2]);
            scratch.lens.resize(c * k, 0);
            scratch.scores.resize(c * k, 0.0);
            scratch.order.resize(c * k, 0);
            if extras.prune {
                scratch.lanes.resize(c * k, Lane::default());
            }
        }
        for (a, state) in agents.iter().enumerate() {
            let state = &match extras.speed_prior {
                Some(prior) => State {
                    speed: prior.apply(state.speed),
                    ..*state
                },
                None => *state,
            };
            let lanes = Lanes {
                map,
                near: &near,
                observed_speed: agents[a].speed,
                state,
                params,
                extras,
                table,
            };
            let tracks = &mut out.positions[a * k * steps..(a + 1) * k * steps];
            let lens = &mut out.lens[a * k..(a + 1) * k];
            let agent_scores = scores.as_deref_mut().map(|s| &mut s[a * k..(a + 1) * k]);
            let key = agent_key(seed, first_agent + a as u64);
            // the samples bent towards the motion model (`motion.rs`)
            let bend = |tracks: &mut [Point], lens: &mut [u32], bend: &mut Bend| {
                let observed = &agents[a];
                let history = history_of(histories, a, observed);
                bend.path.fill(&motion.forecast(&history), params.dt, steps);
                let step = DVec2::from_angle(observed.heading) * (observed.speed * params.dt);
                bend_to_motion(
                    bend,
                    map_evidence(map, &near, &history),
                    (observed.position, step),
                    params.dt,
                    extras.blend,
                    key,
                    tracks,
                    lens,
                    extras.simd,
                );
            };
            if c == 1 {
                let agent_scores = agent_scores.unwrap_or(&mut []);
                lanes.roll_agent::<MOTION, SCORES>(key, tracks, lens, agent_scores);
                if extras.motion {
                    bend(tracks, lens, &mut scratch.bend);
                }
                if extras.consensus && !agent_scores.is_empty() {
                    consensus(tracks, lens, agent_scores, &mut scratch.centre, extras.simd);
                }
                continue;
            }
            // (pruned: the candidates left, the first `m`)
            let m = if extras.prune {
                {
                    // the likelihood scores are the output's
                    let ranked = agent_scores.is_some() && !extras.consensus;
                    let schedule = super::PRUNE_SCHEDULE;
                    lanes.roll_pruned::<MOTION>(key, schedule, k, steps, ranked, scratch)
                }
            } else {
                lanes.roll_agent::<MOTION, true>(
                    key,
                    &mut scratch.tracks,
                    &mut scratch.lens,
                    &mut scratch.scores,
                );
                c * k
            };
            // keep the k that reach furthest, then the highest-scored (ties: drawn first)
            let (cl, cs) = (&scratch.lens[..m], &scratch.scores[..m]);
            rank(cl, cs, &mut scratch.keys, &mut scratch.order);
            for (s, &i) in scratch.order[..k].iter().enumerate() {
                let i = i as usize;
                tracks[s * steps..(s + 1) * steps]
                    .copy_from_slice(&scratch.tracks[i * steps..(i + 1) * steps]);
                lens[s] = scratch.lens[i];
            }
            if extras.motion {
                bend(tracks, lens, &mut scratch.bend);
            }
            if let Some(out_scores) = agent_scores {
                if extras.consensus {
                    consensus(tracks, lens, out_scores, &mut scratch.centre, extras.simd);
                } else {
                    for (s, &i) in scratch.order[..k].iter().enumerate() {
                        out_scores[s] = scratch.scores[i as usize];
                    }
                }
            }
        }
    }
}

/// [`Rank::Consensus`](super::Rank::Consensus) scores of one agent's samples (`tracks`
/// holds `lens.len()` samples of equal length): minus each sample's mean distance from
/// the samples' mean position at its steps, minus
/// [`CONSENSUS_STEP_PENALTY`](super::CONSENSUS_STEP_PENALTY) per step it does not reach.
/// The same bits on every path (`simd` only lets the compiler use wider registers).
fn consensus(
    tracks: &[Point],
    lens: &[u32],
    scores: &mut [f32],
    centre: &mut Vec<[f64; 2]>,
    simd: Simd,
) {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a rollout's path is one the processor has.
        Simd::Avx2Fma => unsafe { consensus_avx2(tracks, lens, scores, centre) },
        _ => consensus_of(tracks, lens, scores, centre),
    }
}

/// [`consensus`] compiled for AVX2 (four distances to an instruction).
///
/// # Safety
/// The processor must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn consensus_avx2(
    tracks: &[Point],
    lens: &[u32],
    scores: &mut [f32],
    centre: &mut Vec<[f64; 2]>,
) {
    consensus_of(tracks, lens, scores, centre)
}

#[inline(always)]
fn consensus_of(tracks: &[Point], lens: &[u32], scores: &mut [f32], centre: &mut Vec<[f64; 2]>) {
    let steps = tracks.len() / lens.len().max(1);
    // the samples' mean position at each step: each step's sum over the samples that
    // reach it, in the samples' order, divided by their number
    centre.clear();
    centre.resize(steps, [0.0; 2]);
    for (track, &len) in tracks.chunks_exact(steps.max(1)).zip(lens) {
        // (x and y alike: the flat values)
        let (track, sums) = (track.as_flattened(), centre.as_flattened_mut());
        for (c, &v) in sums.iter_mut().zip(&track[..2 * len as usize]) {
            *c += v as f64;
        }
    }
    for (j, c) in centre.iter_mut().enumerate() {
        let n = lens.iter().map(|&l| (l as usize > j) as u32).sum::<u32>();
        if n > 0 {
            c[0] /= n as f64;
            c[1] /= n as f64;
        }
    }
    // the distances' sums four samples at a time, each its own steps in order (the
    // bits of one at a time: the steps past a sample's length add zero to its sum);
    // the distances of four steps of a sample at once, from its consecutive positions
    const W: usize = 4;
    const B: usize = 4;
    for (first, group) in scores.chunks_mut(W).enumerate() {
        // (a group of fewer than four repeats its last sample, with no steps)
        let rows: [&[Point]; W] = std::array::from_fn(|l| {
            let s = W * first + l.min(group.len() - 1);
            &tracks[s * steps..(s + 1) * steps]
        });
        let len: [usize; W] = std::array::from_fn(|l| {
            if l < group.len() {
                lens[W * first + l] as usize
            } else {
                0
            }
        });
        let most = len.iter().copied().max().unwrap_or(0);
        let distance = |p: Point, c: [f64; 2]| {
            // (a square root, not `hypot`: the positions are f32, far from overflow)
            let (dx, dy) = (p[0] as f64 - c[0], p[1] as f64 - c[1]);
            (dx * dx + dy * dy).sqrt()
        };
        let mut sum = [0.0f64; W];
        let mut j = 0;
        while j + B <= most {
            let c = centre[j..j + B].as_flattened();
            // (each step's distances of the four samples side by side)
            let mut d = [[0.0f64; W]; B];
            for l in 0..W {
                // (the squares of x and y alike, then each step's sum and root)
                let row = rows[l][j..j + B].as_flattened();
                let mut sq = [0.0f64; 2 * B];
                for i in 0..2 * B {
                    let v = row[i] as f64 - c[i];
                    sq[i] = v * v;
                }
                for i in 0..B {
                    let v = (sq[2 * i] + sq[2 * i + 1]).sqrt();
                    d[i][l] = if j + i < len[l] { v } else { 0.0 };
                }
            }
            for step in &d {
                for (s, v) in sum.iter_mut().zip(step) {
                    *s += v;
                }
            }
            j += B;
        }
        for (j, &c) in centre[..most].iter().enumerate().skip(j) {
            for l in 0..W {
                let d = distance(rows[l][j], c);
                sum[l] += if j < len[l] { d } else { 0.0 };
            }
        }
        for (l, score) in group.iter_mut().enumerate() {
            let mean = if len[l] > 0 {
                sum[l] / len[l] as f64
            } else {
                0.0
            };
            // positions beyond f64's range (absurd speeds) give no distance: ranked last
            let mean = if mean.is_nan() { f64::INFINITY } else { mean };
            *score = (-mean - (steps - len[l]) as f64 * super::CONSENSUS_STEP_PENALTY) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The consensus scores one sample at a time, as written in their definition.
    fn one_at_a_time(tracks: &[Point], lens: &[u32]) -> Vec<f32> {
        let steps = tracks.len() / lens.len();
        let mut centre = vec![[0.0f64; 3]; steps];
        for (track, &len) in tracks.chunks_exact(steps).zip(lens) {
            for (c, p) in centre.iter_mut().zip(&track[..len as usize]) {
                c[0] += p[0] as f64;
                c[1] += p[1] as f64;
                c[2] += 1.0;
            }
        }
        for c in centre.iter_mut().filter(|c| c[2] > 0.0) {
            c[0] /= c[2];
            c[1] /= c[2];
        }
        let mut scores = Vec::new();
        for (track, &len) in tracks.chunks_exact(steps).zip(lens) {
            let mut sum = 0.0;
            for (c, p) in centre.iter().zip(&track[..len as usize]) {
                let (dx, dy) = (p[0] as f64 - c[0], p[1] as f64 - c[1]);
                sum += (dx * dx + dy * dy).sqrt();
            }
            let mean = if len > 0 { sum / len as f64 } else { 0.0 };
            let mean = if mean.is_nan() { f64::INFINITY } else { mean };
            scores.push(
                (-mean - (steps as u32 - len) as f64 * super::super::CONSENSUS_STEP_PENALTY) as f32,
            );
        }
        scores
    }

    #[test]
    fn consensus_scores_are_each_samples_own_sum_on_every_path() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let steps = 23;
        for n in [1, 3, 4, 5, 8, 20, 21] {
            // lengths from none to all; positions past a sample's length are junk
            let lens: Vec<u32> = (0..n)
                .map(|_| (next() % (steps as u64 + 1)) as u32)
                .collect();
            let mut tracks: Vec<Point> = (0..n * steps)
                .map(|_| {
                    [
                        (next() % 2000) as f32 * 0.013 - 9.0,
                        (next() % 900) as f32 * 0.07,
                    ]
                })
                .collect();
            for (s, &len) in lens.iter().enumerate() {
                for p in &mut tracks[s * steps + len as usize..(s + 1) * steps] {
                    *p = [f32::NAN, f32::INFINITY];
                }
            }
            let want = one_at_a_time(&tracks, &lens);
            for simd in [Simd::Baseline, Simd::Avx2Fma]
                .into_iter()
                .filter(|s| s.available())
            {
                let mut scores = vec![f32::NAN; n];
                consensus(&tracks, &lens, &mut scores, &mut Vec::new(), simd);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&scores), bits(&want), "{n} samples on {simd:?}");
            }
            assert!(want.iter().all(|s| s.is_finite()));
        }
    }
}
