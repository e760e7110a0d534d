//! Finding the location a prediction samples from: [`Lookup`] for one sampling radius
//! (a neighbour table or the grid scan), and the map's radius queries.

use std::sync::Arc;

use glam::DVec2;

use super::cliff_map::CliffMap;
use super::neighbours::NeighbourTable;
use super::neighbours::TableError;
use super::tables::TableStats;

/// Finds the location CLiFF-LHMP samples from, for one sampling radius (see
/// [`CliffMap::lookup`]).
#[derive(Debug, Clone)]
pub enum Lookup<'a> {
    /// Through a precomputed neighbour table.
    Table(Arc<NeighbourTable>),
    /// Through the grid scan.
    Grid(&'a CliffMap, f64),
}

impl Lookup<'_> {
    /// Same as [`CliffMap::best_near`] for this lookup's radius.
    #[inline]
    pub fn best_near(&self, p: DVec2) -> Option<usize> {
        match self {
            Lookup::Table(t) => t.best_near(p),
            Lookup::Grid(m, r) => m.best_near(p, *r),
        }
    }

    /// The most locations one query can test for distance: a bound on the work of
    /// [`best_near`](Self::best_near), whatever the point. Through a table, the longest
    /// candidate list of a cell; through the grid scan, the cells within the radius
    /// (each holds at most one location).
    pub fn max_tests(&self) -> usize {
        match self {
            Lookup::Table(t) => t.max_scan().max(1),
            Lookup::Grid(m, r) => m.grid.max_candidates(*r),
        }
    }
}

impl CliffMap {
    /// Call `f` with the index of every location strictly within `radius` of `p`.
    /// Touches only the grid cells that can hold such a location.
    #[inline]
    pub fn for_each_near(&self, p: DVec2, radius: f64, mut f: impl FnMut(usize)) {
        let r2 = radius * radius;
        self.grid.for_each_candidate(p, radius, |i| {
            if self.positions[i].distance_squared(p) < r2 {
                f(i);
            }
        });
    }

    /// The location CLiFF-LHMP samples from at `p`: of the locations strictly within
    /// `radius`, the one with the largest observation ratio (ties: the first in order).
    #[inline]
    pub fn best_near(&self, p: DVec2, radius: f64) -> Option<usize> {
        let r2 = radius * radius;
        let mut best: Option<usize> = None;
        let mut best_ratio = f64::NEG_INFINITY;
        self.grid.for_each_candidate(p, radius, |i| {
            if self.positions[i].distance_squared(p) < r2 {
                let r = self.ratios[i];
                if r > best_ratio || (r == best_ratio && best.is_some_and(|b| i < b)) {
                    best_ratio = r;
                    best = Some(i);
                }
            }
        });
        best
    }

    /// A [`Lookup`] for `radius`: through the neighbour table, built on first use of the
    /// radius and kept under the map's table budget ([`set_table_budget`](Self::set_table_budget)),
    /// else (a table too large, or a radius whose build failed before) through the grid
    /// scan. Both give the same answers as [`best_near`](Self::best_near).
    ///
    /// Building a table takes milliseconds for the usual radii, but grows with the
    /// radius squared: a caller that must not stall uses [`cached_lookup`](Self::cached_lookup)
    /// and builds elsewhere with [`build_table`](Self::build_table).
    pub fn lookup(&self, radius: f64) -> Lookup<'_> {
        match self.build_table(radius, false) {
            Ok(t) => Lookup::Table(t),
            Err(_) => Lookup::Grid(self, radius),
        }
    }

    /// A [`Lookup`] for `radius` that never builds: the table when it is built, else
    /// the grid scan (same answers, slower for large radii).
    #[inline]
    pub fn cached_lookup(&self, radius: f64) -> Lookup<'_> {
        match self.tables.get(radius) {
            Some(t) => Lookup::Table(t),
            None => Lookup::Grid(self, radius),
        }
    }

    /// Build (or find) the neighbour table of `radius` and keep it, evicting the least
    /// recently used unpinned tables to stay within the budget; `pin` keeps it from
    /// eviction. A failed build (a table larger than the budget left by pinned tables)
    /// is remembered and returned again without building.
    pub fn build_table(&self, radius: f64, pin: bool) -> Result<Arc<NeighbourTable>, TableError> {
        self.tables.get_or_build(radius, pin, |max_bytes| {
            NeighbourTable::build(&self.grid, &self.positions, &self.ratios, radius, max_bytes)
        })
    }

    /// True when `radius` has a table or a remembered failed build (so
    /// [`build_table`](Self::build_table) would return at once).
    pub fn table_settled(&self, radius: f64) -> bool {
        self.tables.settled(radius)
    }

    /// Set the memory all neighbour tables of this map may take together (bytes;
    /// [`DEFAULT_TABLE_BUDGET`] unless set). Unpinned tables are evicted to fit.
    pub fn set_table_budget(&self, bytes: usize) {
        self.tables.set_budget(bytes);
    }

    /// The radii with a table, their size and the failed builds.
    pub fn table_stats(&self) -> TableStats {
        self.tables.stats()
    }

    /// The nearest location within `radius` of `p` (ties: the first in order).
    pub fn nearest(&self, p: DVec2, radius: f64) -> Option<usize> {
        let mut best: Option<(f64, usize)> = None;
        self.for_each_near(p, radius, |i| {
            let d = self.positions[i].distance_squared(p);
            if best.is_none_or(|(bd, bi)| d < bd || (d == bd && i < bi)) {
                best = Some((d, i));
            }
        });
        best.map(|(_, i)| i)
    }
}
