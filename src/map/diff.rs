//! What changed between two maps of one place (a base map and a learned snapshot, two
//! versions of an online map): locations added and removed, and for each location in
//! both how far its mixture moved ([`total_variation`]), its components before and
//! after, its main component and its observation ratio ([`diff`], `cliff map diff`).
//!
//! Locations are matched by position: a location of the new map is the old one's when it
//! lies within a thousandth of the grid step of it (online updates keep the grid, so a
//! learned map's locations sit where the base map's did).
//!
//! ```
//! use cliff::map::{CliffMap, diff::diff};
//! let map = CliffMap::demo();
//! let d = diff(&map, &map);
//! assert_eq!((d.added.len(), d.removed.len(), d.common.len()), (0, 0, map.locations().len()));
//! assert!(d.common.iter().all(|c| c.moved < 1e-12));
//! ```

use glam::DVec2;
use serde::Serialize;

use super::movement::total_variation;
use super::{CliffMap, Location};

/// One location found in both maps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocationChange {
    /// Position (m), as in the new map.
    pub position: DVec2,
    /// Index in the old map's locations.
    pub old: usize,
    /// Index in the new map's locations.
    pub new: usize,
    /// How far the mixture moved: the total-variation distance, in `[0, 1]`.
    pub moved: f64,
    /// Components before and after.
    pub components: (usize, usize),
    /// Mean direction (rad) of the heaviest component, before and after.
    pub main_direction: (f64, f64),
    /// Weight of the heaviest component (renormalised), before and after.
    pub main_weight: (f64, f64),
    /// Observation ratio before and after.
    pub observation_ratio: (f64, f64),
}

/// What changed from one map to another ([`diff`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapDiff {
    /// Indices (in the new map) of locations the old map does not have.
    pub added: Vec<usize>,
    /// Indices (in the old map) of locations the new map does not have.
    pub removed: Vec<usize>,
    /// Locations in both, in the new map's order.
    pub common: Vec<LocationChange>,
}

impl MapDiff {
    /// Locations in both that moved more than `tv`.
    pub fn moved_more_than(&self, tv: f64) -> usize {
        self.common.iter().filter(|c| c.moved > tv).count()
    }

    /// The mean move of the locations in both (0 when there are none).
    pub fn mean_move(&self) -> f64 {
        if self.common.is_empty() {
            return 0.0;
        }
        self.common.iter().map(|c| c.moved).sum::<f64>() / self.common.len() as f64
    }

    /// The largest move of a location in both (0 when there are none).
    pub fn largest_move(&self) -> f64 {
        self.common.iter().map(|c| c.moved).fold(0.0, f64::max)
    }

    /// Components of the locations in both, before and after.
    pub fn components(&self) -> (usize, usize) {
        self.common
            .iter()
            .fold((0, 0), |(a, b), c| (a + c.components.0, b + c.components.1))
    }

    /// The locations in both, the furthest moved first (at most `n`).
    pub fn largest(&self, n: usize) -> Vec<LocationChange> {
        let mut v = self.common.clone();
        v.sort_by(|a, b| b.moved.total_cmp(&a.moved));
        v.truncate(n);
        v
    }
}

/// The heaviest component's direction and renormalised weight (0, 0 for none).
fn main_component(l: &Location) -> (f64, f64) {
    let total: f64 = l.components.iter().map(|c| c.weight).sum();
    l.components
        .iter()
        .max_by(|a, b| a.weight.total_cmp(&b.weight))
        .map(|c| (c.theta, if total > 0.0 { c.weight / total } else { 0.0 }))
        .unwrap_or((0.0, 0.0))
}

/// What changed from `old` to `new` (see the [module documentation](self)).
pub fn diff(old: &CliffMap, new: &CliffMap) -> MapDiff {
    let tol = 1e-3 * old.grid().step().min(new.grid().step());
    let mut matched = vec![false; old.locations().len()];
    let mut added = Vec::new();
    let mut common = Vec::new();
    for (j, l) in new.locations().iter().enumerate() {
        let Some(i) = old.nearest(l.position, tol) else {
            added.push(j);
            continue;
        };
        matched[i] = true;
        let o = &old.locations()[i];
        let (d0, w0) = main_component(o);
        let (d1, w1) = main_component(l);
        common.push(LocationChange {
            position: l.position,
            old: i,
            new: j,
            moved: total_variation(&o.components, &l.components),
            components: (o.components.len(), l.components.len()),
            main_direction: (d0, d1),
            main_weight: (w0, w1),
            observation_ratio: (o.observation_ratio, l.observation_ratio),
        });
    }
    let removed = (0..matched.len()).filter(|&i| !matched[i]).collect();
    MapDiff {
        added,
        removed,
        common,
    }
}
