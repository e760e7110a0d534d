//! Scoring a map on held-out observations: the mean log-likelihood of the observed
//! velocities under the mixture of the nearest location ("Quality measure" in
//! `cliffmap-building.md`).
//!
//! Each moving observation is scored at the nearest location strictly within the
//! radius, under that location's semi-wrapped mixture (winding numbers -1, 0, 1) with
//! weights renormalised and covariance eigenvalues floored at 1e-4 (a near-singular
//! component would otherwise dominate). Observations with speed 0 are skipped;
//! observations with no location in reach are counted as unmatched.
//!
//! ```
//! use cliff::map::{CliffMap, score::{score, ScoreParams}, build::Observation};
//! let map = CliffMap::demo();
//! let obs = [Observation { position: glam::DVec2::new(0.0, -1.0), theta: 0.0, rho: 1.3 }];
//! let s = score(&map, &obs, &ScoreParams::default()).unwrap();
//! assert_eq!(s.observations, 1);
//! ```

use rayon::prelude::*;
use serde::Serialize;

use super::build::{BuildError, Observation, check_observations};
use super::stats::{Gauss2, floor_eigenvalues};
use super::{CliffMap, MapSet};

/// Options of [`score`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreParams {
    /// An observation is scored at the nearest location strictly within this distance (m).
    pub radius: f64,
    /// Covariance eigenvalues are raised to at least this for scoring.
    pub eigenvalue_floor: f64,
    /// Log-likelihoods below this count as badly explained.
    pub bad_below: f64,
}

impl Default for ScoreParams {
    fn default() -> Self {
        Self {
            radius: 1.0,
            eigenvalue_floor: 1e-4,
            bad_below: -10.0,
        }
    }
}

/// The score of a map on a set of observations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScoreReport {
    /// Moving observations considered (speed > 0).
    pub observations: usize,
    /// Observations with speed 0, skipped.
    pub standing: usize,
    /// Moving observations with no location within the radius.
    pub unmatched: usize,
    /// Mean log-likelihood over the matched observations (NaN when none).
    pub mean_log_likelihood: f64,
    /// Median log-likelihood over the matched observations (NaN when none).
    pub median_log_likelihood: f64,
    /// Share of the matched observations scoring below `bad_below`.
    pub share_below: f64,
    /// The threshold of `share_below`.
    pub bad_below: f64,
    /// The radius used (m).
    pub radius: f64,
}

/// Per-location mixtures prepared for density evaluation.
pub struct Scorer<'a> {
    map: &'a CliffMap,
    start: Vec<usize>,
    gauss: Vec<Gauss2>,
    params: ScoreParams,
}

impl<'a> Scorer<'a> {
    /// Prepare `map` for scoring.
    pub fn new(map: &'a CliffMap, params: &ScoreParams) -> Result<Self, BuildError> {
        if !(params.radius.is_finite() && params.radius > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "radius {} m must be positive",
                params.radius
            )));
        }
        if !(params.eigenvalue_floor.is_finite() && params.eigenvalue_floor > 0.0) {
            return Err(BuildError::InvalidParam(format!(
                "eigenvalue floor {} must be positive",
                params.eigenvalue_floor
            )));
        }
        let mut start = vec![0];
        let mut gauss = Vec::new();
        for loc in map.locations() {
            let total: f64 = loc.components.iter().map(|c| c.weight).sum();
            for c in &loc.components {
                if c.weight <= 0.0 {
                    continue;
                }
                let cov = floor_eigenvalues(c.cov, params.eigenvalue_floor);
                // A floored covariance is positive definite.
                if let Some(g) = Gauss2::new([c.theta, c.rho], cov, c.weight / total) {
                    gauss.push(g);
                }
            }
            start.push(gauss.len());
        }
        Ok(Self {
            map,
            start,
            gauss,
            params: *params,
        })
    }

    /// Log-likelihood of one moving observation at the nearest location within the
    /// radius; `None` when there is none.
    pub fn log_likelihood(&self, o: &Observation) -> Option<f64> {
        let i = self.map.nearest(o.position, self.params.radius)?;
        Some(log_mixture(
            &self.gauss[self.start[i]..self.start[i + 1]],
            o.theta,
            o.rho,
        ))
    }
}

/// Log density of a weighted mixture at (theta, rho).
pub(crate) fn log_mixture(gauss: &[Gauss2], theta: f64, rho: f64) -> f64 {
    let mut m = f64::NEG_INFINITY;
    let mut buf = [0.0f64; 16];
    let small = gauss.len() <= buf.len();
    let mut v: Vec<f64> = Vec::new();
    for (j, g) in gauss.iter().enumerate() {
        let l = g.log_density_wrapped(theta, rho);
        if small {
            buf[j] = l;
        } else {
            v.push(l);
        }
        m = m.max(l);
    }
    let vals: &[f64] = if small { &buf[..gauss.len()] } else { &v };
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + vals.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
}

/// Score `map` on `obs` (see the module documentation).
pub fn score(
    map: &CliffMap,
    obs: &[Observation],
    params: &ScoreParams,
) -> Result<ScoreReport, BuildError> {
    check_observations(obs)?;
    let scorer = Scorer::new(map, params)?;
    let moving: Vec<&Observation> = obs.iter().filter(|o| o.rho > 0.0).collect();
    let lls: Vec<Option<f64>> = moving
        .par_iter()
        .map(|o| scorer.log_likelihood(o))
        .collect();
    Ok(summarise(obs.len(), lls, params))
}

/// Score a time-of-day set on `obs`, each observation under the map of its time
/// (`times[i]` for `obs[i]`, the data's clock; see [`MapSet::at`]). For a set without
/// slices, the same as [`score`] with its map.
pub fn score_set(
    set: &MapSet,
    obs: &[Observation],
    times: &[f64],
    params: &ScoreParams,
) -> Result<ScoreReport, BuildError> {
    check_observations(obs)?;
    if times.len() != obs.len() {
        return Err(BuildError::InvalidParam(format!(
            "{} timestamps for {} observations",
            times.len(),
            obs.len()
        )));
    }
    // One scorer per map: the all-day map's first, then each slice's (or the all-day's).
    let day = Scorer::new(set.all_day(), params)?;
    let slices: Vec<Option<Scorer<'_>>> = set
        .slices()
        .iter()
        .map(|m| m.as_deref().map(|m| Scorer::new(m, params)).transpose())
        .collect::<Result<_, _>>()?;
    let lls: Vec<Option<f64>> = obs
        .par_iter()
        .zip(times)
        .filter(|(o, _)| o.rho > 0.0)
        .map(|(o, &t)| {
            let scorer = set
                .slice_index(t)
                .and_then(|k| slices[k].as_ref())
                .unwrap_or(&day);
            scorer.log_likelihood(o)
        })
        .collect();
    Ok(summarise(obs.len(), lls, params))
}

/// The report from the log-likelihoods of the moving observations (`None`: unmatched)
/// out of `all` observations.
fn summarise(all: usize, lls: Vec<Option<f64>>, params: &ScoreParams) -> ScoreReport {
    let moving = lls.len();
    let mut matched: Vec<f64> = lls.iter().flatten().copied().collect();
    let unmatched = moving - matched.len();
    let n = matched.len();
    let mean = matched.iter().sum::<f64>() / n as f64;
    let bad = matched.iter().filter(|&&l| l < params.bad_below).count();
    matched.sort_by(|a, b| a.total_cmp(b));
    let median = if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        matched[n / 2]
    } else {
        0.5 * (matched[n / 2 - 1] + matched[n / 2])
    };
    ScoreReport {
        observations: moving,
        standing: all - moving,
        unmatched,
        mean_log_likelihood: mean,
        median_log_likelihood: median,
        share_below: if n == 0 {
            f64::NAN
        } else {
            bad as f64 / n as f64
        },
        bad_below: params.bad_below,
        radius: params.radius,
    }
}
