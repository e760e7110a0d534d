//! Building CLiFF-maps from velocity observations.
//!
//! Follows `cliffmap-building.md` (the original MATLAB pipeline): observations are
//! split to grid nodes (every observation within `radius` of a node feeds it), mean
//! shift finds the initial components of each node, and EM fits the semi-wrapped
//! Gaussian mixture. Nodes are independent and fitted in parallel (rayon); the result
//! does not depend on the number of threads, nor on the order of the observations:
//! each node's samples are put in one canonical order before fitting, so the same
//! observations in any order (tracks shuffled, rows grouped by time) give the same map,
//! bit for bit.
//!
//! ```
//! use cliff::map::build::{build_map, BuildParams, Observation};
//! use glam::DVec2;
//! // People walking east (theta 0) at about 1.2 m/s through (0, 0).
//! let obs: Vec<Observation> = (0..200)
//!     .map(|i| Observation {
//!         position: DVec2::new(-0.9 + 0.009 * i as f64, 0.1 * ((i % 5) as f64 - 2.0)),
//!         theta: cliff::math::wrap_2pi(0.05 * ((i * 7 % 11) as f64 - 5.0)),
//!         rho: 1.2 + 0.02 * ((i * 3 % 13) as f64 - 6.0),
//!     })
//!     .collect();
//! let built = build_map(&obs, &BuildParams::default()).unwrap();
//! let loc = &built.map.locations()[built.map.nearest(DVec2::ZERO, 0.5).unwrap()];
//! assert!((loc.components[0].rho - 1.2).abs() < 0.05);
//! ```

mod em;
mod mean_shift;

use glam::DVec2;
use rayon::prelude::*;

pub use em::{EmComponent, EmOutcome, EmParams, em};
pub use mean_shift::{Bandwidth, Centre, MeanShift, Seekers, group, seek_modes};

use super::stats::CircularLinearStats;
use super::{CliffMap, Component, Location, MapError};
use crate::math::wrap_2pi;
use crate::tracks::Track;

/// One velocity observation: where, which direction, how fast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Position (m).
    pub position: DVec2,
    /// Direction of motion (rad, `[0, 2pi)`).
    pub theta: f64,
    /// Speed (m/s); 0 means standing still (no direction).
    pub rho: f64,
}

/// Every row of the tracks as an observation (direction wrapped to `[0, 2pi)`),
/// standing rows included (the builder counts them for the motion ratio).
pub fn observations_from_tracks(tracks: &[Track]) -> Vec<Observation> {
    tracks
        .iter()
        .flat_map(|t| t.rows.iter())
        .map(|r| Observation {
            position: r.position,
            theta: wrap_2pi(r.angle),
            rho: r.speed,
        })
        .collect()
}

/// [`observations_from_tracks`] with the timestamp of every row (s, as in the files),
/// for [`build_map_set`](crate::map::build_map_set).
pub fn timed_observations_from_tracks(tracks: &[Track]) -> (Vec<Observation>, Vec<f64>) {
    let times = tracks
        .iter()
        .flat_map(|t| t.rows.iter())
        .map(|r| r.t)
        .collect();
    (observations_from_tracks(tracks), times)
}

/// How one node's mixture is fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitParams {
    /// A node with fewer moving samples gets no mixture (the original: 3).
    pub min_samples: usize,
    /// How mean shift sums its kernel.
    pub mean_shift: MeanShift,
    /// Largest number of mean-shift iterations per seeker (the original has none).
    pub mean_shift_max_iter: usize,
    /// EM stopping rules.
    pub em: EmParams,
}

impl Default for FitParams {
    fn default() -> Self {
        Self {
            min_samples: 3,
            mean_shift: MeanShift::default(),
            mean_shift_max_iter: 500,
            em: EmParams::default(),
        }
    }
}

/// Options of [`build_map`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuildParams {
    /// Grid step (m); nodes sit on whole multiples of it.
    pub grid: f64,
    /// A node collects every observation within this distance (m).
    pub radius: f64,
    /// Per-node fitting.
    pub fit: FitParams,
}

impl Default for BuildParams {
    fn default() -> Self {
        Self {
            grid: 1.0,
            radius: 1.0,
            fit: FitParams::default(),
        }
    }
}

/// Why a map could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// An option is out of range.
    #[error("invalid option: {0}")]
    InvalidParam(String),
    /// An observation holds a non-finite or negative value.
    #[error("observation {index}: {message}")]
    BadObservation {
        /// Index in the observation list.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// No node had enough moving observations for a mixture.
    #[error(
        "no location got a mixture ({observations} observations, {moving} moving; a node needs {min} within the radius)"
    )]
    NoLocations {
        /// Observations given.
        observations: usize,
        /// Of which moving.
        moving: usize,
        /// Samples a node needs.
        min: usize,
    },
    /// The built map is invalid (should not happen).
    #[error(transparent)]
    Map(#[from] MapError),
}

/// Figures of a build, for reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BuildSummary {
    /// Observations given.
    pub observations: usize,
    /// Of which standing (speed 0), not used for mixtures.
    pub standing: usize,
    /// Grid nodes with at least one observation within the radius.
    pub nodes: usize,
    /// Nodes with enough moving samples to be fitted.
    pub fitted: usize,
    /// Locations of the map (fitted nodes with at least one component left).
    pub locations: usize,
    /// Components of the map.
    pub components: usize,
    /// Moving samples of the busiest node (the count an observation ratio of 1 means).
    pub max_count: usize,
}

/// A built map with its per-location sample counts.
#[derive(Debug, Clone)]
pub struct Built {
    /// The map.
    pub map: CliffMap,
    /// Moving samples of each location, in map order.
    pub counts: Vec<usize>,
    /// All samples (standing included) of each location, in map order.
    pub totals: Vec<usize>,
    /// Figures of the build.
    pub summary: BuildSummary,
}

/// Node `(i, j)` sits at `origin + step * (i, j)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Lattice {
    pub origin: DVec2,
    pub step: f64,
}

impl Lattice {
    pub fn position(&self, key: (i64, i64)) -> DVec2 {
        self.origin + self.step * DVec2::new(key.0 as f64, key.1 as f64)
    }
}

/// Observations split to nodes: nodes in x-major order, each with its moving samples in
/// canonical order (whatever the order of the observations).
#[derive(Debug, Clone, Default)]
pub(crate) struct Nodes {
    pub keys: Vec<(i64, i64)>,
    /// Start of each node's samples in `samples` (plus an end entry).
    pub starts: Vec<usize>,
    /// Moving samples (theta, rho).
    pub samples: Vec<[f64; 2]>,
    /// All observations (standing included) of each node.
    pub totals: Vec<usize>,
}

impl Nodes {
    pub fn len(&self) -> usize {
        self.keys.len()
    }
    pub fn samples_of(&self, i: usize) -> &[[f64; 2]] {
        &self.samples[self.starts[i]..self.starts[i + 1]]
    }
}

/// Largest number of lattice cells the splitter allocates.
const MAX_CELLS: usize = 50_000_000;

/// Split observations to the nodes of `lattice` within `radius` (inclusive).
pub(crate) fn split(
    obs: &[Observation],
    lattice: Lattice,
    radius: f64,
) -> Result<Nodes, BuildError> {
    if obs.is_empty() {
        return Ok(Nodes {
            starts: vec![0],
            ..Nodes::default()
        });
    }
    let s = lattice.step;
    let rel = |p: DVec2| (p - lattice.origin) / s;
    let rr = radius / s;
    let (mut lo, mut hi) = ((i64::MAX, i64::MAX), (i64::MIN, i64::MIN));
    for o in obs {
        let f = rel(o.position);
        lo.0 = lo.0.min((f.x - rr).ceil() as i64);
        lo.1 = lo.1.min((f.y - rr).ceil() as i64);
        hi.0 = hi.0.max((f.x + rr).floor() as i64);
        hi.1 = hi.1.max((f.y + rr).floor() as i64);
    }
    // Saturating: absurd coordinates give an absurd grid, refused below.
    let nx = hi.0.saturating_sub(lo.0).saturating_add(1).max(0) as usize;
    let ny = hi.1.saturating_sub(lo.1).saturating_add(1).max(0) as usize;
    if nx.saturating_mul(ny) > MAX_CELLS {
        return Err(BuildError::InvalidParam(format!(
            "a grid of {nx} x {ny} nodes at step {s} m is too large (at most {MAX_CELLS})"
        )));
    }
    let r2 = radius * radius;
    // Visit the nodes within the radius of each observation: cell = ix * ny + iy.
    let visit = |o: &Observation, f: &mut dyn FnMut(usize)| {
        let p = rel(o.position);
        let (x0, x1) = ((p.x - rr).ceil() as i64, (p.x + rr).floor() as i64);
        let (y0, y1) = ((p.y - rr).ceil() as i64, (p.y + rr).floor() as i64);
        for ix in x0..=x1 {
            for iy in y0..=y1 {
                if lattice.position((ix, iy)).distance_squared(o.position) <= r2 {
                    f((ix - lo.0) as usize * ny + (iy - lo.1) as usize);
                }
            }
        }
    };
    let mut moving = vec![0u32; nx * ny];
    let mut total = vec![0u32; nx * ny];
    for o in obs {
        let m = o.rho > 0.0;
        visit(o, &mut |c| {
            total[c] += 1;
            if m {
                moving[c] += 1;
            }
        });
    }
    let mut nodes = Nodes::default();
    let mut fill = vec![0usize; nx * ny];
    let mut at = 0usize;
    for c in 0..nx * ny {
        if total[c] > 0 {
            nodes
                .keys
                .push(((c / ny) as i64 + lo.0, (c % ny) as i64 + lo.1));
            nodes.starts.push(at);
            nodes.totals.push(total[c] as usize);
            fill[c] = at;
            at += moving[c] as usize;
        }
    }
    nodes.starts.push(at);
    nodes.samples = vec![[0.0; 2]; at];
    for o in obs {
        if o.rho > 0.0 {
            let x = [o.theta, o.rho];
            visit(o, &mut |c| {
                nodes.samples[fill[c]] = x;
                fill[c] += 1;
            });
        }
    }
    canonical_order(&mut nodes);
    Ok(nodes)
}

/// Put each node's samples in one canonical order: by the bits of the direction, then
/// of the speed (a total order; samples it calls equal are the same bits). The fit's
/// sums then see the same numbers in the same order whichever order the observations
/// came in (which track first, which reader, rows grouped by track or by time), so the
/// same observations give the same map, bit for bit. Sorting node by node, in
/// parallel, costs about 2 % of an online update and nothing measurable of a build.
fn canonical_order(nodes: &mut Nodes) {
    let mut rest = nodes.samples.as_mut_slice();
    let mut per_node = Vec::with_capacity(nodes.keys.len());
    for w in nodes.starts.windows(2) {
        let (node, after) = rest.split_at_mut(w[1] - w[0]);
        per_node.push(node);
        rest = after;
    }
    // directions and speeds are not negative: their bits order them as numbers
    let key = |x: &[f64; 2]| (u128::from(x[0].to_bits()) << 64) | u128::from(x[1].to_bits());
    per_node
        .into_par_iter()
        .with_min_len(8)
        .for_each(|node| node.sort_unstable_by_key(key));
}

/// Check observations: finite position, direction and speed, speed not negative.
pub(crate) fn check_observations(obs: &[Observation]) -> Result<(), BuildError> {
    for (index, o) in obs.iter().enumerate() {
        let message = if !o.position.is_finite() {
            "position is not finite"
        } else if !o.theta.is_finite() {
            "direction is not finite"
        } else if !(o.rho.is_finite() && o.rho >= 0.0) {
            "speed is negative or not finite"
        } else {
            continue;
        };
        return Err(BuildError::BadObservation {
            index,
            message: message.into(),
        });
    }
    Ok(())
}

impl FitParams {
    pub(crate) fn check(&self) -> Result<(), BuildError> {
        let bad = |m: String| Err(BuildError::InvalidParam(m));
        if self.min_samples < 2 {
            return bad(format!("min_samples {} is below 2", self.min_samples));
        }
        if let MeanShift::Binned { theta_bin, rho_bin } = self.mean_shift
            && !(theta_bin > 0.0 && rho_bin > 0.0 && theta_bin.is_finite() && rho_bin.is_finite())
        {
            return bad(format!(
                "bin sizes {theta_bin} rad x {rho_bin} m/s must be positive"
            ));
        }
        if self.mean_shift_max_iter == 0 || self.em.max_iter == 0 {
            return bad("iteration caps must be at least 1".into());
        }
        if !(self.em.abs_tol >= 0.0 && self.em.rel_tol >= 0.0) {
            return bad("EM tolerances must not be negative".into());
        }
        Ok(())
    }
}

impl BuildParams {
    /// Check the options, naming the first bad one.
    pub fn check(&self) -> Result<(), BuildError> {
        if !(self.grid.is_finite() && self.grid > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "grid step {} m must be positive",
                self.grid
            )));
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "radius {} m must be positive",
                self.radius
            )));
        }
        self.fit.check()
    }
}

/// Initial components from mean shift: one per cluster of at least two samples whose
/// circular-linear covariance is usable; EM starts one decade below its variances.
pub fn initial_components(samples: &[[f64; 2]], p: &FitParams) -> Vec<EmComponent> {
    let h = Bandwidth::of(samples);
    let seekers = seek_modes(samples, h, p.mean_shift, p.mean_shift_max_iter);
    let (centres, of_seeker) = group(&seekers, h);
    // Samples of each centre (counting sort).
    let mut start = vec![0usize; centres.len() + 1];
    for &s in &seekers.of_sample {
        start[of_seeker[s as usize] as usize + 1] += 1;
    }
    for i in 0..centres.len() {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut idx = vec![0usize; samples.len()];
    for (i, &s) in seekers.of_sample.iter().enumerate() {
        let c = of_seeker[s as usize] as usize;
        idx[fill[c]] = i;
        fill[c] += 1;
    }
    let mut comps = Vec::new();
    for (c, centre) in centres.iter().enumerate() {
        if centre.members < 2 {
            continue;
        }
        let members = &idx[start[c]..start[c + 1]];
        let st = CircularLinearStats::of(members.iter().map(|&i| &samples[i]));
        let cov = st.cov();
        let det = cov[0] * cov[3] - cov[1] * cov[2];
        if cov.iter().any(|v| !v.is_finite())
            || cov[0] <= 1e-10
            || cov[3] <= 1e-10
            || det.is_nan()
            || det <= 0.0
        {
            continue;
        }
        let decade_below = |v: f64| 10f64.powf(v.log10().floor() - 1.0);
        comps.push(EmComponent {
            mu: centre.point,
            cov: [decade_below(cov[0]), 0.0, 0.0, decade_below(cov[3])],
            weight: 0.0,
        });
    }
    let w = 1.0 / comps.len() as f64;
    for c in &mut comps {
        c.weight = w;
    }
    comps
}

/// Fit the semi-wrapped mixture of one node: mean shift, then EM on all samples.
/// Empty when there are fewer than `min_samples` samples or no component survives.
pub fn fit_mixture(samples: &[[f64; 2]], p: &FitParams) -> Vec<Component> {
    if samples.len() < p.min_samples {
        return Vec::new();
    }
    let init = initial_components(samples, p);
    if init.is_empty() {
        return Vec::new();
    }
    let (comps, _) = em(samples, init, &p.em);
    comps
        .into_iter()
        .map(|c| Component {
            theta: c.mu[0],
            rho: c.mu[1].max(0.0),
            cov: c.cov,
            weight: c.weight,
        })
        .collect()
}

/// Build a map from observations (see the module documentation).
pub fn build_map(obs: &[Observation], params: &BuildParams) -> Result<Built, BuildError> {
    build_map_with_progress(obs, params, &|_| {})
}

/// [`build_map`], calling `progress(total)` once per node with enough samples (from
/// worker threads) after it is fitted, with the number of such nodes.
pub fn build_map_with_progress(
    obs: &[Observation],
    params: &BuildParams,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Built, BuildError> {
    params.check()?;
    check_observations(obs)?;
    let lattice = Lattice {
        origin: DVec2::ZERO,
        step: params.grid,
    };
    let nodes = split(obs, lattice, params.radius)?;
    let fit = &params.fit;
    let count = |i: usize| nodes.starts[i + 1] - nodes.starts[i];
    let fitted = (0..nodes.len())
        .filter(|&i| count(i) >= fit.min_samples)
        .count();
    // Busiest nodes first (a long node started last would leave the other threads
    // idle); results go back to node order, so the map does not depend on scheduling.
    let mut order: Vec<usize> = (0..nodes.len())
        .filter(|&i| count(i) >= fit.min_samples)
        .collect();
    order.sort_by_key(|&i| std::cmp::Reverse(count(i)));
    let fitted_mixtures: Vec<(usize, Vec<Component>)> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|i| {
            let m = fit_mixture(nodes.samples_of(i), fit);
            progress(fitted);
            (i, m)
        })
        .collect();
    let mut mixtures: Vec<Vec<Component>> = vec![Vec::new(); nodes.len()];
    for (i, m) in fitted_mixtures {
        mixtures[i] = m;
    }
    let max_count = (0..nodes.len()).map(count).max().unwrap_or(0);
    let moving = obs.iter().filter(|o| o.rho > 0.0).count();
    let mut locations = Vec::new();
    let mut counts = Vec::new();
    let mut totals = Vec::new();
    for (i, comps) in mixtures.into_iter().enumerate() {
        if comps.is_empty() {
            continue;
        }
        locations.push(Location {
            position: lattice.position(nodes.keys[i]),
            components: comps,
            motion_ratio: count(i) as f64 / nodes.totals[i] as f64,
            observation_ratio: count(i) as f64 / max_count as f64,
        });
        counts.push(count(i));
        totals.push(nodes.totals[i]);
    }
    if locations.is_empty() {
        return Err(BuildError::NoLocations {
            observations: obs.len(),
            moving,
            min: fit.min_samples,
        });
    }
    let summary = BuildSummary {
        observations: obs.len(),
        standing: obs.len() - moving,
        nodes: nodes.len(),
        fitted,
        locations: locations.len(),
        components: locations.iter().map(|l| l.components.len()).sum(),
        max_count,
    };
    let map = CliffMap::with_grid_step(locations, Some(params.grid))?;
    Ok(Built {
        map,
        counts,
        totals,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ob(x: f64, y: f64) -> Observation {
        Observation {
            position: DVec2::new(x, y),
            theta: 1.0,
            rho: 1.0,
        }
    }

    #[test]
    fn split_feeds_every_node_within_the_radius() {
        let lattice = Lattice {
            origin: DVec2::ZERO,
            step: 1.0,
        };
        let mut standing = ob(0.5, 0.0);
        standing.rho = 0.0;
        let nodes = split(&[ob(0.5, 0.0), standing], lattice, 1.0).unwrap();
        // (0.5, 0) is within 1 m of (0, 0) and (1, 0); (0, 1), (1, 1) etc. are 1.118 m away.
        assert_eq!(nodes.keys, vec![(0, 0), (1, 0)]);
        assert_eq!(nodes.totals, vec![2, 2]);
        assert_eq!(nodes.samples_of(0).len(), 1);
        // Inclusive radius: a node exactly 1 m away counts.
        let nodes = split(&[ob(0.0, 0.0)], lattice, 1.0).unwrap();
        assert_eq!(nodes.len(), 5);
    }

    #[test]
    fn absurd_extent_is_an_error_not_a_panic() {
        let lattice = Lattice {
            origin: DVec2::ZERO,
            step: 1.0,
        };
        let e = split(&[ob(-1e300, 0.0), ob(1e300, 0.0)], lattice, 1.0).unwrap_err();
        assert!(e.to_string().contains("too large"), "{e}");
        let e = build_map(&[ob(0.0, 0.0), ob(f64::NAN, 0.0)], &BuildParams::default()).unwrap_err();
        assert!(
            e.to_string()
                .contains("observation 1: position is not finite"),
            "{e}"
        );
    }
}
