//! The neighbour tables a map keeps, one per sampling radius, under a memory budget.
//!
//! A [`NeighbourTable`] makes a CLiFF-LHMP map lookup one table load and one distance
//! test, but it costs memory (about 8 bytes per sub-cell plus the candidate lists) and
//! time to build (milliseconds for the usual radii, much more for a radius of tens of
//! metres). [`TableCache`] holds the tables of one map:
//!
//! * tables are kept while their total size stays within a budget
//!   ([`DEFAULT_TABLE_BUDGET`] unless set); a new table evicts the least recently used
//!   unpinned ones to fit, and a table that cannot fit (or would be too large on its own)
//!   is refused;
//! * a failed build is remembered, so the same radius is not tried again;
//! * [`TableCache::get`] never builds, so a caller that must not stall (a daemon's
//!   serving thread) can use the table when it is there and the grid scan otherwise,
//!   and leave building to another thread ([`CliffMap::build_table`](super::CliffMap::build_table)).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};

use super::neighbours::{NeighbourTable, TableError};

/// Memory a map's neighbour tables may take together unless set otherwise: 256 MiB.
pub const DEFAULT_TABLE_BUDGET: usize = 256 << 20;

/// Failed builds remembered per map (the oldest is forgotten beyond this).
const MAX_FAILED: usize = 64;

/// A cached table and when it was last used.
#[derive(Debug)]
struct Entry {
    table: Arc<NeighbourTable>,
    bytes: usize,
    pinned: bool,
    last_used: AtomicU64,
}

#[derive(Debug, Default)]
struct State {
    budget: usize,
    entries: Vec<Entry>,
    failed: Vec<(u64, TableError)>,
}

impl State {
    fn bytes(&self) -> usize {
        self.entries.iter().map(|e| e.bytes).sum()
    }

    /// Evict the least recently used unpinned tables until `extra` more bytes fit the
    /// budget; false when only pinned tables are left and it still does not fit.
    fn evict_for(&mut self, extra: usize) -> bool {
        while self.bytes() + extra > self.budget {
            let victim = self
                .entries
                .iter()
                .enumerate()
                .filter(|(_, e)| !e.pinned)
                .min_by_key(|(_, e)| e.last_used.load(Ordering::Relaxed))
                .map(|(i, _)| i);
            match victim {
                Some(i) => {
                    self.entries.remove(i);
                }
                None => return false,
            }
        }
        true
    }
}

/// What a map's table cache holds (see [`CliffMap::table_stats`](super::CliffMap::table_stats)).
#[derive(Debug, Clone, PartialEq)]
pub struct TableStats {
    /// Radii with a table, in the order they were built.
    pub radii: Vec<f64>,
    /// Their total size (bytes).
    pub bytes: usize,
    /// The budget (bytes).
    pub budget: usize,
    /// Radii whose build failed (remembered, not tried again).
    pub failed: Vec<f64>,
}

/// The neighbour tables of one map, by radius, under a memory budget.
#[derive(Debug)]
pub struct TableCache {
    state: RwLock<State>,
    clock: AtomicU64,
}

impl Default for TableCache {
    fn default() -> Self {
        Self::with_budget(DEFAULT_TABLE_BUDGET)
    }
}

impl Clone for TableCache {
    /// A clone shares the built tables (they are immutable) and the failures.
    fn clone(&self) -> Self {
        let s = self.read();
        let state = State {
            budget: s.budget,
            entries: s
                .entries
                .iter()
                .map(|e| Entry {
                    table: e.table.clone(),
                    bytes: e.bytes,
                    pinned: e.pinned,
                    last_used: AtomicU64::new(e.last_used.load(Ordering::Relaxed)),
                })
                .collect(),
            failed: s.failed.clone(),
        };
        Self {
            state: RwLock::new(state),
            clock: AtomicU64::new(self.clock.load(Ordering::Relaxed)),
        }
    }
}

impl TableCache {
    /// An empty cache whose tables may take `budget` bytes together.
    pub fn with_budget(budget: usize) -> Self {
        Self {
            state: RwLock::new(State {
                budget,
                ..State::default()
            }),
            clock: AtomicU64::new(0),
        }
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, State> {
        // A panic while holding the lock leaves the state consistent (every change is a
        // single push, remove or assignment), so a poisoned lock is still usable.
        self.state.read().unwrap_or_else(|e| e.into_inner())
    }

    fn write(&self) -> std::sync::RwLockWriteGuard<'_, State> {
        self.state.write().unwrap_or_else(|e| e.into_inner())
    }

    /// The table for `radius` if it is built (marks it as used). Never builds.
    #[inline]
    pub fn get(&self, radius: f64) -> Option<Arc<NeighbourTable>> {
        let s = self.read();
        let e = s.entries.iter().find(|e| e.table.radius() == radius)?;
        let now = self.clock.fetch_add(1, Ordering::Relaxed);
        e.last_used.store(now, Ordering::Relaxed);
        Some(e.table.clone())
    }

    /// The remembered failure for `radius`, if its build failed before.
    pub fn failure(&self, radius: f64) -> Option<TableError> {
        self.read()
            .failed
            .iter()
            .find(|(r, _)| *r == radius.to_bits())
            .map(|(_, e)| *e)
    }

    /// True when `radius` has a table or a remembered failure: building it again would
    /// do nothing.
    pub fn settled(&self, radius: f64) -> bool {
        let s = self.read();
        s.entries.iter().any(|e| e.table.radius() == radius)
            || s.failed.iter().any(|(r, _)| *r == radius.to_bits())
    }

    /// The table for `radius`: the cached one, else `build(max_bytes)` (outside the
    /// lock) then kept, evicting the least recently used unpinned tables to fit the
    /// budget. `pin` keeps it from eviction (and pins a table already there). A failure
    /// (from `build`, or a table that cannot fit) is remembered and returned again
    /// without building.
    pub fn get_or_build(
        &self,
        radius: f64,
        pin: bool,
        build: impl FnOnce(usize) -> Result<NeighbourTable, TableError>,
    ) -> Result<Arc<NeighbourTable>, TableError> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(TableError::BadRadius { radius });
        }
        let budget = {
            let mut s = self.write();
            if let Some(e) = s.entries.iter_mut().find(|e| e.table.radius() == radius) {
                e.pinned |= pin;
                return Ok(e.table.clone());
            }
            if let Some(e) = self.failure_in(&s, radius) {
                return Err(e);
            }
            // What the table may take: the budget less the pinned tables.
            let pinned: usize = s.entries.iter().filter(|e| e.pinned).map(|e| e.bytes).sum();
            let room = s.budget.saturating_sub(pinned);
            drop(s);
            room
        };
        let built = build(budget).and_then(|t| {
            let bytes = t.memory_bytes();
            if bytes > budget {
                Err(TableError::TooLarge {
                    radius,
                    limit: budget,
                })
            } else {
                Ok((t, bytes))
            }
        });
        let mut s = self.write();
        // Another thread may have built it meanwhile: keep the first.
        if let Some(e) = s.entries.iter_mut().find(|e| e.table.radius() == radius) {
            e.pinned |= pin;
            return Ok(e.table.clone());
        }
        match built {
            Ok((table, bytes)) => {
                if !s.evict_for(bytes) {
                    // only pinned tables left (pinned meanwhile by another call)
                    let e = TableError::TooLarge {
                        radius,
                        limit: s.budget.saturating_sub(s.bytes()),
                    };
                    Self::remember(&mut s, radius, e);
                    return Err(e);
                }
                let table = Arc::new(table);
                let now = self.clock.fetch_add(1, Ordering::Relaxed);
                s.entries.push(Entry {
                    table: table.clone(),
                    bytes,
                    pinned: pin,
                    last_used: AtomicU64::new(now),
                });
                Ok(table)
            }
            Err(e) => {
                Self::remember(&mut s, radius, e);
                Err(e)
            }
        }
    }

    fn failure_in(&self, s: &State, radius: f64) -> Option<TableError> {
        s.failed
            .iter()
            .find(|(r, _)| *r == radius.to_bits())
            .map(|(_, e)| *e)
    }

    fn remember(s: &mut State, radius: f64, e: TableError) {
        if s.failed.len() >= MAX_FAILED {
            s.failed.remove(0);
        }
        s.failed.push((radius.to_bits(), e));
    }

    /// Set the budget (bytes). Unpinned tables are evicted (least recently used first)
    /// until the rest fits; failures are forgotten, since a larger budget may let them
    /// build.
    pub fn set_budget(&self, budget: usize) {
        let mut s = self.write();
        s.budget = budget;
        s.failed.clear();
        s.evict_for(0);
    }

    /// What the cache holds.
    pub fn stats(&self) -> TableStats {
        let s = self.read();
        TableStats {
            radii: s.entries.iter().map(|e| e.table.radius()).collect(),
            bytes: s.bytes(),
            budget: s.budget,
            failed: s.failed.iter().map(|(r, _)| f64::from_bits(*r)).collect(),
        }
    }
}
