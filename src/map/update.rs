//! Online updates of CLiFF-maps (Zhu et al. 2024, "Fast online learning of
//! CLiFF-maps"; section 5 of `cliffmap-building.md`).
//!
//! An [`OnlineMap`] keeps, per node, its effective observation count `W` and a mixture
//! whose weights, means and covariances are the normalised sufficient statistics of
//! the data seen so far (`N_j = pi_j`, `S_j = N_j mu_j`, `T_j = N_j (Sigma_j + mu_j
//! mu_j^T)`), so a map file plus one count scale is the whole state. A batch of
//! observations updates it without the old data:
//!
//! 1. every node decays: `W <- lambda W`;
//! 2. the samples of a node (every observation within the radius, as in building)
//!    that no component explains (squared Mahalanobis distance above a gate for every
//!    component, with the scoring floor on covariances) are fitted with a fresh
//!    mixture (mean shift + EM) whose components are appended with weight
//!    `n_unexplained / (W + n)`;
//! 3. the other samples update the existing components by stepwise EM with
//!    `gamma = n / (W + n)`: `N, S, T <- N, S, T + gamma (new - old)` with the
//!    responsibilities of the new samples under the current mixture;
//! 4. covariances are kept positive definite, mean directions wrapped, near-duplicate
//!    components (Bhattacharyya distance below a threshold) merged by moment matching,
//!    components whose weight decayed below a floor pruned, and the number of
//!    components per node capped (merging the closest pair), so that a node does not
//!    grow without bound; `W <- W + n`.
//!
//! Nodes without a location get one when they have gathered enough samples for a
//! mixture: a node's samples too few to fit are kept (the newest [`SEED_SAMPLES`]: the
//! latest batch's first, a batch's own in their canonical order; at most
//! [`SEED_BUDGET`] over all nodes) and joined by the next batches' until they fit, as a
//! batch build over all the data would have fitted them. Nodes without new data only
//! decay. Observation ratios are `W / max W`. The map's speed prior
//! ([`CliffMap::speed_prior`]) is carried over unchanged.
//!
//! **Damping** ([`UpdateParams::max_move`]): an update that would move a location's
//! mixture further than the bound, measured as the total-variation distance between
//! the mixtures before and after ([`movement`](super::movement)), is damped: the new
//! mixture becomes the blend `(1 - a) old + a new` (the components of both, weights
//! scaled, then merged and capped as above) with the largest `a` found that keeps the
//! move within the bound, and the node's counts grow by `a n` instead of `n`. New
//! locations have no mixture to move and are not damped.
//!
//! ```
//! use cliff::map::build::{BuildParams, Observation};
//! use cliff::map::update::{OnlineMap, UpdateParams};
//! use glam::DVec2;
//! let walk = |theta: f64| -> Vec<Observation> {
//!     (0..300).map(|i| Observation {
//!         position: DVec2::new(-0.9 + 0.006 * i as f64, 0.0),
//!         theta: cliff::math::wrap_2pi(theta + 0.01 * ((i % 21) as f64 - 10.0)),
//!         rho: 1.0 + 0.01 * ((i % 17) as f64 - 8.0),
//!     }).collect()
//! };
//! let mut online = OnlineMap::build(&walk(0.0), &BuildParams::default(), UpdateParams::default()).unwrap();
//! // The flow turns around: a new component appears at theta = pi.
//! online.update(&walk(std::f64::consts::PI)).unwrap();
//! let map = online.to_map().unwrap();
//! let loc = &map.locations()[map.nearest(DVec2::ZERO, 0.5).unwrap()];
//! assert!(loc.components.iter().any(|c| (c.theta - std::f64::consts::PI).abs() < 0.1));
//! ```

use std::collections::BTreeMap;
use std::f64::consts::TAU;

use glam::DVec2;
use rayon::prelude::*;

use super::build::{
    BuildError, BuildParams, Built, FitParams, Lattice, Observation, build_map, check_observations,
    fit_mixture, split,
};
use super::mixture::{cap_components, merge_near_duplicates};
use super::movement::total_variation;
use super::stats::{Gauss2, eig_sym, floor_eigenvalues};
use super::{CliffMap, Component, Location, MapError};
use crate::math::{wrap_2pi, wrap_pi};
use crate::motion::SpeedPrior;

/// Options of online updates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateParams {
    /// Decay of the effective count per update, `lambda` in `(0, 1]` (1: keep all data
    /// with equal weight).
    pub decay: f64,
    /// A node collects the observations within this distance (m); `None`: the grid step.
    pub radius: Option<f64>,
    /// A sample is unexplained when its squared Mahalanobis distance to every component
    /// exceeds this (13.8: outside the 99.9 % ellipse of a 2-D normal).
    pub gate: f64,
    /// Components closer than this Bhattacharyya distance are merged.
    pub merge_distance: f64,
    /// Largest number of components per node.
    pub max_components: usize,
    /// Components whose weight falls below this are pruned.
    pub min_weight: f64,
    /// Covariance eigenvalues are kept at least this large.
    pub cov_floor: f64,
    /// Fitting of fresh mixtures.
    pub fit: FitParams,
    /// Damping: the largest move of a location's mixture in one update, as a
    /// total-variation distance in `(0, 1]` ([`movement`](super::movement)); `None`: no
    /// damping.
    pub max_move: Option<f64>,
}

impl Default for UpdateParams {
    fn default() -> Self {
        Self {
            decay: 0.5,
            radius: None,
            gate: 13.8,
            merge_distance: 0.1,
            max_components: 10,
            min_weight: 1e-3,
            cov_floor: 1e-8,
            fit: FitParams::default(),
            max_move: None,
        }
    }
}

impl UpdateParams {
    fn check(&self) -> Result<(), BuildError> {
        let bad = |m: String| Err(BuildError::InvalidParam(m));
        if !(self.decay > 0.0 && self.decay <= 1.0) {
            return bad(format!("decay {} must be in (0, 1]", self.decay));
        }
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0)
        {
            return bad(format!("radius {r} m must be positive"));
        }
        if !(self.gate > 0.0
            && self.merge_distance >= 0.0
            && self.min_weight >= 0.0
            && self.min_weight < 1.0)
        {
            return bad(
                "gate must be positive, merge distance and minimum weight not negative".into(),
            );
        }
        if self.max_components == 0 {
            return bad("max_components must be at least 1".into());
        }
        if let Some(m) = self.max_move
            && !(m > 0.0 && m <= 1.0)
        {
            return bad(format!("largest move {m} must be in (0, 1]"));
        }
        if !(self.cov_floor > 0.0 && self.cov_floor.is_finite()) {
            return bad(format!(
                "covariance floor {} must be positive",
                self.cov_floor
            ));
        }
        self.fit.check()
    }
}

/// What one update did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct UpdateReport {
    /// Observations in the batch.
    pub observations: usize,
    /// Existing locations that received samples.
    pub updated: usize,
    /// New locations.
    pub created: usize,
    /// Components appended from fresh mixtures of unexplained samples.
    pub added: usize,
    /// Components merged into another.
    pub merged: usize,
    /// Components pruned for a weight below the floor.
    pub pruned: usize,
    /// Locations whose update was damped ([`UpdateParams::max_move`]).
    pub damped: usize,
}

/// Per-node state: effective counts and the normalised mixture.
#[derive(Debug, Clone, PartialEq)]
struct NodeState {
    /// Effective count of moving samples.
    w: f64,
    /// Effective count of all samples (standing included).
    w_all: f64,
    /// Components; weights sum to one.
    comps: Vec<Component>,
}

/// Most samples kept for one node without a location, the newest (module docs).
pub const SEED_SAMPLES: usize = 64;

/// Most samples kept for nodes without a location altogether (4 MiB of samples); a node
/// whose samples would exceed it keeps none.
pub const SEED_BUDGET: usize = 1 << 18;

/// The samples of a node without a location, too few for a mixture so far.
#[derive(Debug, Clone, Default, PartialEq)]
struct Seed {
    /// Moving samples (theta, rho), oldest first.
    samples: Vec<[f64; 2]>,
    /// All observations (standing included).
    total: f64,
}

/// A CLiFF-map with the state needed for online updates (see the module docs).
#[derive(Debug, Clone)]
pub struct OnlineMap {
    lattice: Lattice,
    radius: f64,
    params: UpdateParams,
    nodes: BTreeMap<(i64, i64), NodeState>,
    /// Nodes without a location that have samples.
    seeds: BTreeMap<(i64, i64), Seed>,
    /// Samples in `seeds`.
    seeded: usize,
    speed_prior: Option<SpeedPrior>,
}

/// What an update made of one node of the batch.
enum NodeOutcome {
    Updated(NodeState, NodeChange),
    Created(NodeState),
    /// Still too few samples: the node's seed now.
    Seeded(Seed),
}

#[derive(Default)]
struct NodeChange {
    added: usize,
    merged: usize,
    pruned: usize,
    /// The share of the update kept (1: not damped).
    kept: f64,
}

impl OnlineMap {
    /// Build a map from observations in batch (see [`build_map`]) and keep its counts.
    pub fn build(
        obs: &[Observation],
        build: &BuildParams,
        params: UpdateParams,
    ) -> Result<Self, BuildError> {
        let built = build_map(obs, build)?;
        let params = UpdateParams {
            radius: Some(params.radius.unwrap_or(build.radius)),
            ..params
        };
        Self::from_built(&built, params)
    }

    /// Start from a batch-built map with its sample counts.
    pub fn from_built(built: &Built, params: UpdateParams) -> Result<Self, BuildError> {
        let counts: Vec<f64> = built.counts.iter().map(|&c| c as f64).collect();
        let totals: Vec<f64> = built.totals.iter().map(|&c| c as f64).collect();
        Self::with_counts(&built.map, &counts, &totals, params)
    }

    /// Start from a map whose observation ratio 1 stands for `count_scale` moving
    /// samples (the busiest node's count when the map was built).
    pub fn from_map(
        map: &CliffMap,
        count_scale: f64,
        params: UpdateParams,
    ) -> Result<Self, BuildError> {
        if !(count_scale.is_finite() && count_scale > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "count scale {count_scale} must be positive"
            )));
        }
        let counts: Vec<f64> = map
            .locations()
            .iter()
            .map(|l| l.observation_ratio * count_scale)
            .collect();
        let totals: Vec<f64> = map
            .locations()
            .iter()
            .zip(&counts)
            .map(|(l, &c)| {
                if l.motion_ratio > 0.0 {
                    c / l.motion_ratio
                } else {
                    c
                }
            })
            .collect();
        Self::with_counts(map, &counts, &totals, params)
    }

    fn with_counts(
        map: &CliffMap,
        counts: &[f64],
        totals: &[f64],
        params: UpdateParams,
    ) -> Result<Self, BuildError> {
        params.check()?;
        let step = map.grid().step();
        let first = map.locations()[0].position;
        let origin = DVec2::new(first.x.rem_euclid(step), first.y.rem_euclid(step));
        let lattice = Lattice { origin, step };
        let mut nodes = BTreeMap::new();
        for ((loc, &w), &w_all) in map.locations().iter().zip(counts).zip(totals) {
            let f = (loc.position - origin) / step;
            let key = (f.x.round() as i64, f.y.round() as i64);
            let total: f64 = loc.components.iter().map(|c| c.weight).sum();
            let comps = loc
                .components
                .iter()
                .map(|c| Component {
                    cov: floor_eigenvalues(c.cov, params.cov_floor),
                    weight: c.weight / total,
                    ..*c
                })
                .collect();
            nodes.insert(
                key,
                NodeState {
                    w,
                    w_all: w_all.max(w),
                    comps,
                },
            );
        }
        Ok(Self {
            lattice,
            radius: params.radius.unwrap_or(step),
            params,
            nodes,
            seeds: BTreeMap::new(),
            seeded: 0,
            speed_prior: map.speed_prior(),
        })
    }

    /// Nodes without a location that keep samples, and how many samples they keep
    /// together (module docs).
    pub fn seeds(&self) -> (usize, usize) {
        (self.seeds.len(), self.seeded)
    }

    /// The speed prior the maps of [`OnlineMap::to_map`] carry (the start map's).
    pub fn speed_prior(&self) -> Option<SpeedPrior> {
        self.speed_prior
    }

    /// The count an observation ratio of 1 stands for (the largest effective count).
    pub fn count_scale(&self) -> f64 {
        self.nodes.values().map(|n| n.w).fold(0.0, f64::max)
    }

    /// Moving samples of the busiest node of `obs` on this map's nodes (a sensible
    /// count scale for a map of unknown counts: it weighs the map like this batch).
    pub fn busiest_node(&self, obs: &[Observation]) -> Result<usize, BuildError> {
        check_observations(obs)?;
        let nodes = split(obs, self.lattice, self.radius)?;
        Ok((0..nodes.len())
            .map(|i| nodes.samples_of(i).len())
            .max()
            .unwrap_or(0))
    }

    /// Rescale every node's effective counts so that the largest is `scale`.
    pub fn set_count_scale(&mut self, scale: f64) -> Result<(), BuildError> {
        let old = self.count_scale();
        if !(scale.is_finite() && scale > 0.0 && old > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "count scale {scale} must be positive"
            )));
        }
        let f = scale / old;
        for n in self.nodes.values_mut() {
            n.w *= f;
            n.w_all *= f;
        }
        Ok(())
    }

    /// Change the damping bound of the next updates ([`UpdateParams::max_move`]).
    pub fn set_max_move(&mut self, max_move: Option<f64>) -> Result<(), BuildError> {
        let params = UpdateParams {
            max_move,
            ..self.params
        };
        params.check()?;
        self.params = params;
        Ok(())
    }

    /// Number of locations.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the map has no locations.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Update the map from a batch of observations (see the module docs).
    pub fn update(&mut self, obs: &[Observation]) -> Result<UpdateReport, BuildError> {
        check_observations(obs)?;
        let p = self.params;
        for n in self.nodes.values_mut() {
            n.w *= p.decay;
            n.w_all *= p.decay;
        }
        let split = split(obs, self.lattice, self.radius)?;
        let results: Vec<Option<NodeOutcome>> = (0..split.len())
            .into_par_iter()
            .map(|i| {
                let x = split.samples_of(i);
                let total = split.totals[i] as f64;
                match self.nodes.get(&split.keys[i]) {
                    Some(state) => {
                        let mut s = state.clone();
                        let ch = if x.is_empty() {
                            NodeChange {
                                kept: 1.0,
                                ..NodeChange::default()
                            }
                        } else {
                            let mut ch = update_node(&mut s, x, &p);
                            ch.kept = match p.max_move {
                                Some(bound) => damp(&state.comps, &mut s.comps, bound, &p),
                                None => 1.0,
                            };
                            ch
                        };
                        s.w += ch.kept * x.len() as f64;
                        s.w_all += ch.kept * total;
                        Some(NodeOutcome::Updated(s, ch))
                    }
                    None => {
                        // the samples kept from earlier batches, then this batch's (joined
                        // only where some were kept)
                        let seed = self.seeds.get(&split.keys[i]);
                        let joined;
                        let samples = match seed {
                            Some(seed) => {
                                joined = [seed.samples.as_slice(), x].concat();
                                joined.as_slice()
                            }
                            None if x.is_empty() => return None,
                            None => x,
                        };
                        let total = total + seed.map_or(0.0, |s| s.total);
                        let comps = fit_mixture(samples, &p.fit);
                        if comps.is_empty() {
                            let newest = samples.len().saturating_sub(SEED_SAMPLES);
                            return Some(NodeOutcome::Seeded(Seed {
                                samples: samples[newest..].to_vec(),
                                total,
                            }));
                        }
                        let mut s = NodeState {
                            w: samples.len() as f64,
                            w_all: total.max(samples.len() as f64),
                            comps,
                        };
                        normalise(&mut s.comps);
                        Some(NodeOutcome::Created(s))
                    }
                }
            })
            .collect();
        let mut report = UpdateReport {
            observations: obs.len(),
            ..UpdateReport::default()
        };
        for (i, r) in results.into_iter().enumerate() {
            let key = split.keys[i];
            let (s, ch) = match r {
                None => continue,
                Some(NodeOutcome::Seeded(seed)) => {
                    let before = self.seeds.remove(&key).map_or(0, |s| s.samples.len());
                    self.seeded -= before;
                    if self.seeded + seed.samples.len() <= SEED_BUDGET {
                        self.seeded += seed.samples.len();
                        self.seeds.insert(key, seed);
                    }
                    continue;
                }
                Some(NodeOutcome::Created(s)) => {
                    if let Some(seed) = self.seeds.remove(&key) {
                        self.seeded -= seed.samples.len();
                    }
                    report.created += 1;
                    (s, NodeChange::default())
                }
                Some(NodeOutcome::Updated(s, ch)) => {
                    report.updated += 1;
                    if ch.kept < 1.0 {
                        report.damped += 1;
                    }
                    (s, ch)
                }
            };
            report.added += ch.added;
            report.merged += ch.merged;
            report.pruned += ch.pruned;
            self.nodes.insert(key, s);
        }
        Ok(report)
    }

    /// The current map.
    pub fn to_map(&self) -> Result<CliffMap, MapError> {
        let max_w = self.count_scale();
        let locations = self
            .nodes
            .iter()
            .map(|(&key, n)| Location {
                position: self.lattice.position(key),
                components: n.comps.clone(),
                motion_ratio: if n.w_all > 0.0 {
                    (n.w / n.w_all).min(1.0)
                } else {
                    1.0
                },
                observation_ratio: if max_w > 0.0 { n.w / max_w } else { 0.0 },
            })
            .collect();
        let mut map = CliffMap::with_grid_step(locations, Some(self.lattice.step))?;
        map.set_speed_prior(self.speed_prior)?;
        Ok(map)
    }
}

fn normalise(comps: &mut [Component]) {
    let total: f64 = comps.iter().map(|c| c.weight).sum();
    if total > 0.0 {
        for c in comps {
            c.weight /= total;
        }
    }
}

/// Scoring-floor covariance for the explained/unexplained gate.
const GATE_FLOOR: f64 = 1e-4;

/// One node's update from its moving samples `x` (`s.w` already decayed).
fn update_node(s: &mut NodeState, x: &[[f64; 2]], p: &UpdateParams) -> NodeChange {
    let n = x.len() as f64;
    let gamma = n / (s.w + n);
    let mut ch = NodeChange::default();
    // Which samples does the current mixture explain?
    let gates: Vec<Gauss2> = s
        .comps
        .iter()
        .filter_map(|c| Gauss2::new([c.theta, c.rho], floor_eigenvalues(c.cov, GATE_FLOOR), 1.0))
        .collect();
    let explained = |x: &[f64; 2]| {
        gates.iter().any(|g| {
            let d = wrap_pi(x[0] - g.mu[0]);
            g.maha(d, x[1] - g.mu[1]) <= p.gate
        })
    };
    let (mut inside, outside): (Vec<[f64; 2]>, Vec<[f64; 2]>) =
        x.iter().partition(|x| explained(x));
    let mut fresh = if outside.len() >= p.fit.min_samples {
        fit_mixture(&outside, &p.fit)
    } else {
        Vec::new()
    };
    let n_out = if fresh.is_empty() {
        inside.extend_from_slice(&outside);
        0.0
    } else {
        outside.len() as f64
    };
    // Stepwise EM on the explained samples: statistics relative to each old mean.
    let gauss: Vec<Option<Gauss2>> = s
        .comps
        .iter()
        .map(|c| Gauss2::new([c.theta, c.rho], c.cov, c.weight))
        .collect();
    let mut acc = vec![[0.0f64; 6]; s.comps.len()];
    let mut terms = vec![0.0f64; 3 * s.comps.len()];
    for xi in &inside {
        let mut m = f64::NEG_INFINITY;
        for (j, g) in gauss.iter().enumerate() {
            for k in 0..3 {
                terms[3 * j + k] = match g {
                    Some(g) => {
                        let dt = xi[0] - g.mu[0] + TAU * (1.0 - k as f64);
                        g.log_norm - 0.5 * g.maha(dt, xi[1] - g.mu[1])
                    }
                    None => f64::NEG_INFINITY,
                };
                m = m.max(terms[3 * j + k]);
            }
        }
        if !m.is_finite() {
            continue;
        }
        let mut sum = 0.0;
        for t in terms.iter_mut() {
            *t = (*t - m).exp();
            sum += *t;
        }
        for (j, c) in s.comps.iter().enumerate() {
            for k in 0..3 {
                let r = terms[3 * j + k] / sum;
                if r < 1e-300 {
                    continue;
                }
                let dt = xi[0] - c.theta + TAU * (1.0 - k as f64);
                let dr = xi[1] - c.rho;
                let a = &mut acc[j];
                a[0] += r;
                a[1] += r * dt;
                a[2] += r * dr;
                a[3] += r * dt * dt;
                a[4] += r * dt * dr;
                a[5] += r * dr * dr;
            }
        }
    }
    for (c, a) in s.comps.iter_mut().zip(&acc) {
        let n_new = a[0] / n;
        let big_n = (1.0 - gamma) * c.weight + gamma * n_new;
        if big_n > 1e-300 {
            let st = gamma * a[1] / n;
            let sr = gamma * a[2] / n;
            let (mt, mr) = (st / big_n, sr / big_n);
            let t = |old: f64, new: f64| ((1.0 - gamma) * c.weight * old + gamma * new / n) / big_n;
            let cov = [
                t(c.cov[0], a[3]) - mt * mt,
                t(c.cov[1], a[4]) - mt * mr,
                t(c.cov[2], a[4]) - mt * mr,
                t(c.cov[3], a[5]) - mr * mr,
            ];
            c.theta = wrap_2pi(c.theta + mt);
            c.rho = (c.rho + mr).max(0.0);
            c.cov = floor_eigenvalues(cov, p.cov_floor);
        }
        c.weight = big_n;
    }
    // Fresh components for the unexplained samples.
    if !fresh.is_empty() {
        normalise(&mut fresh);
        let share = gamma * n_out / n;
        for mut f in fresh {
            f.weight *= share;
            f.cov = floor_eigenvalues(f.cov, p.cov_floor);
            s.comps.push(f);
            ch.added += 1;
        }
    }
    tidy(&mut s.comps, p, &mut ch);
    ch
}

/// Damp a node's update (`old` its mixture before, `new` after) so that it moves at most
/// `bound` (total variation): `new` becomes the tidied blend `(1 - a) old + a new` with
/// `a` shrunk until the move is within the bound (after six tries, the old mixture).
/// Gives back `a` (1: not damped).
fn damp(old: &[Component], new: &mut Vec<Component>, bound: f64, p: &UpdateParams) -> f64 {
    let moved = total_variation(old, new);
    if moved <= bound {
        return 1.0;
    }
    let mut a = bound / moved;
    for _ in 0..6 {
        let mut blend: Vec<Component> = old
            .iter()
            .map(|c| Component {
                weight: c.weight * (1.0 - a),
                ..*c
            })
            .chain(new.iter().map(|c| Component {
                weight: c.weight * a,
                ..*c
            }))
            .collect();
        normalise(&mut blend);
        tidy(&mut blend, p, &mut NodeChange::default());
        let moved = total_variation(old, &blend);
        if moved <= bound {
            *new = blend;
            return a;
        }
        // merging moved it further than the blend alone: shrink in proportion, with room
        a *= 0.9 * bound / moved;
    }
    *new = old.to_vec();
    0.0
}

/// Merge near-duplicates, prune tiny weights, cap the count (the lightest component is
/// merged into its closest neighbour until the node fits, so strong flows keep their
/// shape); weights renormalised and covariances kept positive definite.
fn tidy(comps: &mut Vec<Component>, p: &UpdateParams, ch: &mut NodeChange) {
    ch.merged += merge_near_duplicates(comps, p.merge_distance);
    ch.merged += cap_components(comps, p.max_components);
    let before = comps.len();
    let total: f64 = comps.iter().map(|c| c.weight).sum();
    if comps.len() > 1 {
        let keep_at_least = comps.iter().map(|c| c.weight).fold(0.0, f64::max);
        comps.retain(|c| c.weight >= p.min_weight * total || c.weight == keep_at_least);
    }
    ch.pruned += before - comps.len();
    normalise(comps);
    for c in comps.iter_mut() {
        c.cov = floor_eigenvalues(c.cov, p.cov_floor);
        debug_assert!(eig_sym(c.cov).1 > 0.0);
        c.theta = wrap_2pi(c.theta);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::mixture::{bhattacharyya, merge};

    fn comp(theta: f64, rho: f64, v: f64, w: f64) -> Component {
        Component {
            theta,
            rho,
            cov: [v, 0.0, 0.0, v],
            weight: w,
        }
    }

    fn batch(seed: u64, n: usize, flows: &[(f64, f64)]) -> Vec<Observation> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let z = Normal::new(0.0, 1.0).unwrap();
        (0..n)
            .map(|i| {
                let (t, r) = flows[i % flows.len()];
                Observation {
                    position: DVec2::new(2.0 * z.sample(&mut rng), 2.0 * z.sample(&mut rng)),
                    theta: wrap_2pi(t + 0.2 * z.sample(&mut rng)),
                    rho: (r + 0.1 * z.sample(&mut rng)).abs() + 0.01,
                }
            })
            .collect()
    }

    #[test]
    fn updates_keep_the_maps_speed_prior() {
        let built = OnlineMap::build(
            &batch(1, 2000, &[(0.3, 1.2)]),
            &BuildParams::default(),
            UpdateParams::default(),
        )
        .unwrap();
        let mut map = built.to_map().unwrap();
        assert_eq!(map.speed_prior(), None);
        let prior = SpeedPrior {
            mean: 1.2,
            keep: 0.6,
            pairs: 500,
        };
        map.set_speed_prior(Some(prior)).unwrap();
        let mut online = OnlineMap::from_map(&map, 100.0, UpdateParams::default()).unwrap();
        online.update(&batch(2, 500, &[(3.0, 0.9)])).unwrap();
        assert_eq!(online.to_map().unwrap().speed_prior(), Some(prior));
    }

    #[test]
    fn a_place_gets_a_location_once_its_samples_over_several_updates_are_enough() {
        let mut online = OnlineMap::build(
            &batch(1, 2000, &[(0.3, 1.2)]),
            &BuildParams::default(),
            UpdateParams::default(),
        )
        .unwrap();
        // one walker a batch at (30, 30), far from every location, heading about 1 rad
        let far = DVec2::new(30.0, 30.0);
        let one = |i: usize| Observation {
            position: far,
            theta: 1.0 + 0.05 * ((i * 7 % 5) as f64 - 2.0),
            rho: 1.0 + 0.05 * ((i * 3 % 4) as f64 - 1.5),
        };
        // Each batch alone is one sample, too few for a mixture (at least
        // `FitParams::min_samples`); the nodes within the radius of (30, 30) keep them
        // until, together, they fit.
        assert!(FitParams::default().min_samples > 1);
        let mut places = 0;
        let mut updates = 0;
        while online.to_map().unwrap().nearest(far, 0.5).is_none() {
            assert!(updates < 10, "no location after {updates} updates");
            assert_eq!(online.seeds(), (places, places * updates));
            let r = online.update(&[one(updates)]).unwrap();
            updates += 1;
            if updates == 1 {
                places = online.seeds().0;
                assert!(places >= 1);
            }
            assert!(r.created == 0 || r.created == places, "{r:?}");
        }
        assert!(updates >= FitParams::default().min_samples);
        let map = online.to_map().unwrap();
        let loc = &map.locations()[map.nearest(far, 0.5).expect("a location at last")];
        assert!((loc.components[0].theta - 1.0).abs() < 0.1, "{loc:?}");
        assert_eq!(online.seeds(), (0, 0));
    }

    #[test]
    fn updates_keep_invariants_and_bounded_size() {
        let build = BuildParams::default();
        let p = UpdateParams {
            max_components: 4,
            ..UpdateParams::default()
        };
        let mut m = OnlineMap::build(&batch(1, 4000, &[(0.05, 1.2)]), &build, p).unwrap();
        // Flows come and go, one across direction 0.
        let flows: [&[(f64, f64)]; 4] = [
            &[(6.2, 1.0), (3.0, 0.8)],
            &[(1.5, 1.4)],
            &[(4.6, 0.6), (0.1, 1.1), (2.2, 1.0)],
            &[(3.0, 0.8), (5.0, 1.5)],
        ];
        for round in 0..12 {
            let r = m
                .update(&batch(100 + round, 3000, flows[round as usize % 4]))
                .unwrap();
            assert!(r.updated > 0);
            let map = m.to_map().unwrap();
            for loc in map.locations() {
                assert!(loc.components.len() <= 4, "{:?}", loc.components.len());
                let total: f64 = loc.components.iter().map(|c| c.weight).sum();
                assert!((total - 1.0).abs() < 1e-9, "{total}");
                for c in &loc.components {
                    assert!((0.0..TAU).contains(&c.theta), "{c:?}");
                    assert!(c.rho >= 0.0);
                    let (_, small) = eig_sym(c.cov);
                    assert!(small > 0.0 && (c.cov[1] - c.cov[2]).abs() < 1e-12, "{c:?}");
                }
            }
            assert!(map.report().clamped_covariances == 0);
        }
        // The last flows dominate the busiest location.
        let map = m.to_map().unwrap();
        let loc = &map.locations()[map.nearest(DVec2::ZERO, 0.5).unwrap()];
        let near = |t: f64| {
            loc.components
                .iter()
                .filter(|c| wrap_pi(c.theta - t).abs() < 0.3)
                .map(|c| c.weight)
                .sum::<f64>()
        };
        assert!(near(3.0) > 0.2 && near(5.0) > 0.2, "{:?}", loc.components);
    }

    #[test]
    fn merge_across_zero_keeps_moments() {
        let a = comp(0.1, 1.0, 0.01, 0.5);
        let b = comp(TAU - 0.1, 1.2, 0.01, 0.5);
        let m = merge(&a, &b);
        assert!(wrap_pi(m.theta).abs() < 1e-12, "{m:?}");
        assert!((m.rho - 1.1).abs() < 1e-12);
        // within variance 0.01 plus between-spread 0.1^2
        assert!(
            (m.cov[0] - 0.02).abs() < 1e-12 && (m.cov[3] - 0.02).abs() < 1e-12,
            "{m:?}"
        );
        assert!((m.cov[1] + 0.01).abs() < 1e-12, "{m:?}");
        assert!((m.weight - 1.0).abs() < 1e-12);
    }

    #[test]
    fn tidy_merges_duplicates_prunes_and_caps() {
        let p = UpdateParams {
            max_components: 2,
            ..UpdateParams::default()
        };
        let mut ch = NodeChange::default();
        let mut c = vec![
            comp(1.0, 1.0, 0.01, 0.4),
            comp(1.001, 1.0, 0.01, 0.3),  // duplicate of the first
            comp(4.0, 1.0, 0.01, 0.2995), // far
            comp(2.5, 1.0, 0.01, 0.0005), // tiny
        ];
        tidy(&mut c, &p, &mut ch);
        assert_eq!(c.len(), 2, "{c:?}");
        assert_eq!(ch.merged + ch.pruned, 2);
        let total: f64 = c.iter().map(|c| c.weight).sum();
        assert!((total - 1.0).abs() < 1e-12);
        assert!(c.iter().any(|c| (c.theta - 1.0).abs() < 0.01));
        assert!(c.iter().any(|c| (c.theta - 4.0).abs() < 0.01));
    }

    #[test]
    fn bhattacharyya_is_zero_for_equal_and_grows_apart() {
        let a = comp(6.2, 1.0, 0.02, 1.0);
        assert!(bhattacharyya(&a, &a).abs() < 1e-12);
        let b = comp(0.2, 1.0, 0.02, 1.0); // 0.283 rad across zero
        let c = comp(1.0, 1.0, 0.02, 1.0);
        assert!(bhattacharyya(&a, &b) < bhattacharyya(&a, &c));
        assert!((bhattacharyya(&a, &b) - 0.125 * (TAU - 6.0_f64).powi(2) / 0.02).abs() < 1e-9);
    }
}
