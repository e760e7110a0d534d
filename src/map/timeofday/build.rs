//! Learning a [`MapSet`] from timestamped observations (the rule is in [`Smoothing`]).

use std::collections::{BTreeSet, HashMap};
use std::sync::Arc;

use super::clock::{DAY_SECONDS, check_clock_offset, slice_count, slice_label};
use super::set::{MapSet, SetParts};
use super::smoothing::Smoothing;
use crate::map::build::{
    BuildError, BuildParams, Built, Observation, build_map_with_progress, check_observations,
};
use crate::map::mixture::{cap_components, merge_near_duplicates};
use crate::map::{CliffMap, Component, Location};
use crate::math::wrap_2pi;

/// Options of [`build_map_set`] beyond those of every map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceParams {
    /// Slice length (s); must divide the day (3600: one map per hour).
    pub slice_length: f64,
    /// Seconds added to the timestamps to get the local time (ATC: 32400).
    pub clock_offset: f64,
    /// How slices borrow from their neighbours and from the all-day map.
    pub smoothing: Smoothing,
}

impl Default for SliceParams {
    fn default() -> Self {
        Self {
            slice_length: 3600.0,
            clock_offset: 0.0,
            smoothing: Smoothing::default(),
        }
    }
}

impl SliceParams {
    /// Check the options, naming the first bad one.
    pub fn check(&self) -> Result<(), BuildError> {
        let as_param = |e: crate::map::MapError| BuildError::InvalidParam(e.to_string());
        slice_count(self.slice_length).map_err(as_param)?;
        check_clock_offset(self.clock_offset).map_err(as_param)?;
        self.smoothing.check().map_err(as_param)
    }
}

/// Figures of one slice of a built set.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SliceSummary {
    /// Local times the slice covers (`HH:MM-HH:MM`).
    pub label: String,
    /// Observations (rows) of the slice's own data.
    pub observations: usize,
    /// Locations of the map fitted to the slice's own data alone (0: too few data).
    pub own_locations: usize,
    /// Locations and components of the slice's smoothed map (0 when the slice has no
    /// map and the all-day map stands in).
    pub locations: usize,
    /// Components of the smoothed map.
    pub components: usize,
}

/// A built set with its figures.
#[derive(Debug, Clone)]
pub struct BuiltSet {
    /// The set.
    pub set: MapSet,
    /// The all-day map with its counts (as [`build_map`](crate::map::build_map) gives it).
    pub all_day: Built,
    /// One entry per slice.
    pub slices: Vec<SliceSummary>,
}

/// Grid node -> index of its location in a map.
type NodeIndex = HashMap<(i64, i64), usize>;

/// A slice's map fitted to its own data, with its kernel weight for the slice being
/// smoothed.
struct Source<'a> {
    weight: f64,
    built: &'a Built,
    index: &'a NodeIndex,
}

/// Kernel weights below this leave a neighbouring slice out.
const KERNEL_CUTOFF: f64 = 1e-3;
/// Components lighter than this share of a location's weight are dropped.
const MIN_WEIGHT: f64 = 1e-3;

/// Learn a time-of-day set: the all-day map from every observation, then a map per
/// slice smoothed as [`Smoothing`] describes. `times[i]` is the timestamp of `obs[i]`
/// (s, the data's clock; [`SliceParams::clock_offset`] turns it into local time).
///
/// ```
/// use cliff::map::build::{BuildParams, Observation};
/// use cliff::map::{SliceParams, build_map_set};
/// use cliff::math::wrap_2pi;
/// use glam::DVec2;
/// // People walk east through (0, 0) from 08:00 to 12:00 and west from 12:00 to 16:00.
/// let (mut obs, mut times) = (Vec::new(), Vec::new());
/// for i in 0..4000 {
///     let t = 8.0 * 3600.0 + i as f64 * 7.2;
///     let east = t < 12.0 * 3600.0;
///     obs.push(Observation {
///         position: DVec2::new(-0.9 + 0.0045 * (i % 400) as f64, 0.0),
///         theta: wrap_2pi(if east { 0.0 } else { 3.1416 } + 0.02 * ((i % 5) as f64 - 2.0)),
///         rho: 1.0 + 0.01 * (i % 7) as f64,
///     });
///     times.push(t);
/// }
/// let built = build_map_set(&obs, &times, &BuildParams::default(), &SliceParams::default()).unwrap();
/// let at = |hour: f64| {
///     let m = built.set.at(hour * 3600.0);
///     let loc = &m.locations()[m.nearest(DVec2::ZERO, 0.5).unwrap()];
///     // the heaviest component's direction
///     loc.components.iter().max_by(|a, b| a.weight.total_cmp(&b.weight)).unwrap().theta
/// };
/// assert!(at(10.0) < 0.5 || at(10.0) > 5.8); // east
/// assert!((at(14.0) - std::f64::consts::PI).abs() < 0.5); // west
/// ```
pub fn build_map_set(
    obs: &[Observation],
    times: &[f64],
    build: &BuildParams,
    slicing: &SliceParams,
) -> Result<BuiltSet, BuildError> {
    build_map_set_with_progress(obs, times, build, slicing, &|_, _| {})
}

/// [`build_map_set`], calling `progress(part, total)` once per fitted node of each map
/// built (the all-day map, then each slice's own data), with the part's name (`all
/// day`, `HH:MM-HH:MM`) and its number of nodes to fit.
pub fn build_map_set_with_progress(
    obs: &[Observation],
    times: &[f64],
    build: &BuildParams,
    slicing: &SliceParams,
    progress: &(dyn Fn(&str, usize) + Sync),
) -> Result<BuiltSet, BuildError> {
    build.check()?;
    slicing.check()?;
    if times.len() != obs.len() {
        return Err(BuildError::InvalidParam(format!(
            "{} timestamps for {} observations",
            times.len(),
            obs.len()
        )));
    }
    check_observations(obs)?;
    let n =
        slice_count(slicing.slice_length).map_err(|e| BuildError::InvalidParam(e.to_string()))?;
    let mut per_slice: Vec<Vec<Observation>> = vec![Vec::new(); n];
    for (index, (o, &t)) in obs.iter().zip(times).enumerate() {
        let local = t + slicing.clock_offset;
        if !local.is_finite() {
            return Err(BuildError::BadObservation {
                index,
                message: format!("time {t} is not finite"),
            });
        }
        let tod = local.rem_euclid(DAY_SECONDS);
        let i = ((tod / slicing.slice_length) as usize).min(n - 1);
        per_slice[i].push(*o);
    }
    let all_day = build_map_with_progress(obs, build, &|total| progress("all day", total))?;
    let mut fits: Vec<Option<Built>> = Vec::with_capacity(n);
    for (i, slice_obs) in per_slice.iter().enumerate() {
        if slice_obs.is_empty() {
            fits.push(None);
            continue;
        }
        let label = slice_label(i, slicing.slice_length);
        match build_map_with_progress(slice_obs, build, &|total| progress(&label, total)) {
            Ok(b) => fits.push(Some(b)),
            Err(BuildError::NoLocations { .. }) => fits.push(None),
            Err(e) => return Err(e),
        }
    }
    let key = |l: &Location| {
        (
            (l.position.x / build.grid).round() as i64,
            (l.position.y / build.grid).round() as i64,
        )
    };
    let index_of = |m: &CliffMap| -> NodeIndex {
        m.locations()
            .iter()
            .enumerate()
            .map(|(i, l)| (key(l), i))
            .collect()
    };
    let day_index = index_of(&all_day.map);
    let fit_index: Vec<Option<NodeIndex>> = fits
        .iter()
        .map(|f| f.as_ref().map(|b| index_of(&b.map)))
        .collect();
    let s = slicing.smoothing;
    let mut slices = Vec::with_capacity(n);
    let mut summaries = Vec::with_capacity(n);
    for h in 0..n {
        let sources: Vec<Source<'_>> = (0..n)
            .filter_map(|k| {
                let weight = kernel(h, k, n, slicing.slice_length, s.kernel_width);
                match (&fits[k], &fit_index[k]) {
                    (Some(built), Some(index)) if weight >= KERNEL_CUTOFF => Some(Source {
                        weight,
                        built,
                        index,
                    }),
                    _ => None,
                }
            })
            .collect();
        let map = if sources.is_empty() {
            None
        } else {
            Some(Arc::new(smoothed_slice(
                &all_day, &day_index, &sources, &s, build.grid, &key,
            )?))
        };
        summaries.push(SliceSummary {
            label: slice_label(h, slicing.slice_length),
            observations: per_slice[h].len(),
            own_locations: fits[h].as_ref().map_or(0, |b| b.map.locations().len()),
            locations: map.as_ref().map_or(0, |m| m.locations().len()),
            components: map.as_ref().map_or(0, |m| m.info().components),
        });
        slices.push(map);
    }
    let set = MapSet::from_parts(SetParts {
        all_day: Arc::new(all_day.map.clone()),
        slices,
        slice_length: slicing.slice_length,
        clock_offset: slicing.clock_offset,
        smoothing: Some(s),
        observations: per_slice.iter().map(|v| v.len() as u64).collect(),
    })?;
    Ok(BuiltSet {
        set,
        all_day,
        slices: summaries,
    })
}

/// The time kernel between slices `h` and `k` of `n` (1 for the same slice).
fn kernel(h: usize, k: usize, n: usize, slice_length: f64, width: f64) -> f64 {
    if h == k {
        return 1.0;
    }
    if width == 0.0 {
        return 0.0;
    }
    let steps = h.abs_diff(k).min(n - h.abs_diff(k)) as f64;
    let d = steps * slice_length;
    (-(d * d) / (2.0 * width * width)).exp()
}

/// One slice's map from its sources (kernel weight, fit, index) and the all-day prior.
fn smoothed_slice(
    all_day: &Built,
    day_index: &NodeIndex,
    sources: &[Source<'_>],
    s: &Smoothing,
    grid: f64,
    key: &dyn Fn(&Location) -> (i64, i64),
) -> Result<CliffMap, BuildError> {
    // The all-day locations in their order, then the nodes only slices have (in
    // lattice order): the order breaks ties between equally busy locations.
    let mut keys: Vec<(i64, i64)> = all_day.map.locations().iter().map(key).collect();
    let extra: BTreeSet<(i64, i64)> = sources
        .iter()
        .flat_map(|src| src.built.map.locations().iter().map(key))
        .filter(|k| !day_index.contains_key(k))
        .collect();
    keys.extend(extra);
    let mut locations = Vec::with_capacity(keys.len());
    let mut busy = Vec::with_capacity(keys.len());
    let mut day_ratio = Vec::with_capacity(keys.len());
    let mut comps: Vec<Component> = Vec::new();
    for k in &keys {
        comps.clear();
        let mut data = 0.0;
        let mut first: Option<&Location> = None;
        for src in sources {
            if let Some(&j) = src.index.get(k) {
                let loc = &src.built.map.locations()[j];
                let weight = src.weight * src.built.counts[j] as f64;
                data += weight;
                add_scaled(&mut comps, &loc.components, weight);
                first.get_or_insert(loc);
            }
        }
        let day = day_index.get(k).map(|&j| &all_day.map.locations()[j]);
        let prior_ratio = day.map_or(0.0, |l| l.observation_ratio);
        let loc = match (first, day) {
            (Some(f), day) if data > 0.0 => {
                if let Some(d) = day {
                    add_scaled(&mut comps, &d.components, s.prior_weight);
                    // the slice's mixture gets 1 - share, the all-day mixture the share
                    let total = data + s.prior_weight;
                    for c in comps.iter_mut() {
                        c.weight *= (1.0 - s.all_day_share) / total;
                    }
                    add_scaled(&mut comps, &d.components, s.all_day_share);
                }
                tidy(&mut comps, s.merge_distance, s.max_components);
                Location {
                    position: f.position,
                    components: comps.clone(),
                    motion_ratio: day.unwrap_or(f).motion_ratio,
                    observation_ratio: 0.0,
                }
            }
            (_, Some(d)) => d.clone(),
            // (every key comes from the all-day map or a source with data)
            (_, None) => continue,
        };
        busy.push(data + s.prior_weight * prior_ratio);
        day_ratio.push(prior_ratio);
        locations.push(loc);
    }
    // The slice's traffic (busiest 1) mixed with the all-day ratios as the mixtures are.
    let top = busy.iter().copied().fold(0.0, f64::max);
    let lam = s.all_day_share;
    let mixed: Vec<f64> = busy
        .iter()
        .zip(&day_ratio)
        .map(|(b, r)| (1.0 - lam) * if top > 0.0 { b / top } else { 0.0 } + lam * r)
        .collect();
    let top = mixed.iter().copied().fold(0.0, f64::max);
    if top > 0.0 {
        for (l, m) in locations.iter_mut().zip(&mixed) {
            l.observation_ratio = (m / top).min(1.0);
        }
    }
    Ok(CliffMap::with_grid_step(locations, Some(grid))?)
}

/// Append `from`'s components with their weights scaled to sum to `total`.
fn add_scaled(to: &mut Vec<Component>, from: &[Component], total: f64) {
    let sum: f64 = from.iter().map(|c| c.weight).sum();
    if !(sum > 0.0 && total > 0.0) {
        return;
    }
    to.extend(from.iter().map(|c| Component {
        weight: c.weight * total / sum,
        ..*c
    }));
}

/// Merge near-duplicates (closest pair first), cap the count (the lightest merged into
/// its closest), drop components below [`MIN_WEIGHT`] of the total (never the
/// heaviest) and normalise the weights.
fn tidy(comps: &mut Vec<Component>, merge_distance: f64, max_components: usize) {
    merge_near_duplicates(comps, merge_distance);
    cap_components(comps, max_components);
    let total: f64 = comps.iter().map(|c| c.weight).sum();
    let heaviest = comps.iter().map(|c| c.weight).fold(0.0, f64::max);
    comps.retain(|c| c.weight >= MIN_WEIGHT * total || c.weight == heaviest);
    let total: f64 = comps.iter().map(|c| c.weight).sum();
    for c in comps.iter_mut() {
        c.weight /= total;
        c.theta = wrap_2pi(c.theta);
    }
}
