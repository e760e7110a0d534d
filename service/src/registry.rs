//! The maps a daemon serves: loading, radius limits, neighbour tables and reloads.
//!
//! Every cost a map adds to a request is bounded here, before any request arrives:
//!
//! * each map has a radius limit ([`Settings::max_radius`], by default
//!   [`RADIUS_LIMIT_STEPS`] grid steps), so one map lookup tests at most
//!   `(2 * 4 + 1)^2 = 81` locations through the grid scan, and a table's candidate lists
//!   are as short;
//! * the neighbour tables of the expected radii ([`Settings::table_radii`]) are built
//!   when the map loads (or reloads, on the reload thread) and pinned; tables of other
//!   radii are built by one background thread ([`TableBuilder`]), never on the serving
//!   thread, at most a quarter of one core's time, under the map's memory budget with
//!   eviction; failed builds are remembered;
//! * a reload runs on its own thread, catches panics, and keeps the old map of any file
//!   that fails;
//! * a time-of-day map set (`cliff map build --slice`) is served whole: each request
//!   runs on the map of the time of day it asks for ([`map_for_request`]); every map of
//!   the set gets the pinned tables, and the set shares the table budget.

use std::collections::VecDeque;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, SyncSender, TryRecvError, TrySendError};
use std::time::{Duration, Instant};

use cliff::map::{CliffMap, MapSet};
use cliff_client::protocol::{self, MAP_NAME_BYTES, MapTime};
use tracing::{debug, error, info, warn};

use crate::settings::{MapSpec, RADIUS_LIMIT_STEPS, Settings, StartError};

/// One served map.
pub(crate) struct MapEntry {
    pub name: String,
    pub wire: [u8; MAP_NAME_BYTES],
    pub path: Option<PathBuf>,
    /// The all-day map (the map itself for a file of one map).
    pub map: Arc<CliffMap>,
    /// The time-of-day set the map belongs to (a set of one map for a file of one).
    pub set: MapSet,
    /// Largest radius a request may use (m).
    pub max_radius: f64,
    /// The version served: 0 for the map as loaded, then one more for every learned
    /// version swapped in ([`Registry::swap_learned`]).
    pub version: u32,
    /// The set as loaded from the file (or the built-in scene), which a request may pin
    /// ([`FLAG_BASE_MAP`](cliff_client::protocol::FLAG_BASE_MAP), or the name `NAME@0`);
    /// `set` is this set until a learned version replaces it.
    pub base: MapSet,
    /// The learned versions served before `version`, newest first, that a request may
    /// still ask for by name (`NAME@VERSION`): at most the `keep` of
    /// [`Registry::swap_learned`].
    pub kept: VecDeque<(u32, MapSet)>,
}

/// Which version of a map a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Pick {
    /// The version served now (the map name alone).
    Served,
    /// A version by number (`NAME@VERSION`; 0 and the base-map flag: the map as loaded).
    Version(u32),
}

impl MapEntry {
    /// The radius limit in whole millimetres, as a rejection reports it.
    pub fn max_radius_mm(&self) -> u32 {
        (self.max_radius * 1000.0)
            .floor()
            .clamp(1.0, u32::MAX as f64) as u32
    }
}

/// The set of version `pick` of `entry` and its number; `None` for a version the entry
/// does not hold (not learned yet, or older than the versions kept).
pub(crate) fn set_for(entry: &MapEntry, pick: Pick) -> Option<(&MapSet, u32)> {
    match pick {
        Pick::Served => Some((&entry.set, entry.version)),
        Pick::Version(v) if v == entry.version => Some((&entry.set, v)),
        Pick::Version(0) => Some((&entry.base, 0)),
        Pick::Version(v) => entry
            .kept
            .iter()
            .find(|(k, _)| *k == v)
            .map(|(_, set)| (set, v)),
    }
}

/// The map a request on `entry` runs on, and its version's number: in the set of
/// version `pick` (the version served now, the map as loaded, or a learned version kept;
/// `None` for a version the entry does not hold, [`set_for`]), the map of the time of day
/// the request asks for (`when`: [`RequestHeader::time_mode`] and
/// [`RequestHeader::time`], validated): the slice that holds `t` for
/// [`MapTime::At`]`(t)`, the one that holds the daemon's wall clock (unix time, read as
/// the request is accepted) for [`MapTime::Now`], and the all-day map for
/// [`MapTime::AllDay`]. A file of one map gives that map whatever `when` says. The one
/// place where the daemon picks a request's map; the neighbour table asked for
/// ([`Registry::want_table`]) then belongs to the map picked.
///
/// [`RequestHeader::time_mode`]: cliff_client::RequestHeader::time_mode
/// [`RequestHeader::time`]: cliff_client::RequestHeader::time
pub(crate) fn map_for_request(
    entry: &MapEntry,
    when: MapTime,
    pick: Pick,
) -> Option<(&Arc<CliffMap>, u32)> {
    let (set, version) = set_for(entry, pick)?;
    Some((map_in(set, when), version))
}

/// [`map_for_request`] on the version served now (which an entry always holds).
pub(crate) fn served_map(entry: &MapEntry, when: MapTime) -> (&Arc<CliffMap>, u32) {
    (map_in(&entry.set, when), entry.version)
}

fn map_in(set: &MapSet, when: MapTime) -> &Arc<CliffMap> {
    if set.is_sliced() {
        // the rule in-process callers use too
        when.map_in(set)
    } else {
        set.all_day()
    }
}

/// How maps are prepared: the radius limit, the table budget and the pinned radii.
#[derive(Debug, Clone)]
pub(crate) struct TablePolicy {
    max_radius: Option<f64>,
    radii: Vec<f64>,
    budget: usize,
}

impl TablePolicy {
    pub fn from_settings(s: &Settings) -> Self {
        Self {
            max_radius: s.max_radius,
            radii: s.table_radii.clone(),
            budget: s.table_budget,
        }
    }

    /// The radius limit of `map`.
    pub fn max_radius(&self, map: &CliffMap) -> f64 {
        self.max_radius
            .unwrap_or(RADIUS_LIMIT_STEPS * map.grid().step())
    }

    /// Set the map's table budget and build (pinned) the tables of the expected radii
    /// within its limit; a table that does not fit is logged and left to the grid scan.
    pub fn prepare(&self, name: &str, set: &MapSet) {
        // the maps of a set share the budget
        let maps: Vec<&Arc<CliffMap>> = set.maps().collect();
        let budget = self.budget / maps.len().max(1);
        for map in maps {
            map.set_table_budget(budget);
            let limit = self.max_radius(map);
            for &r in self.radii.iter().filter(|&&r| r <= limit) {
                if let Err(e) = map.build_table(r, true) {
                    warn!(map = name, radius = r, "no neighbour table: {e}");
                }
            }
        }
    }
}

/// A map file's load (one map or a time-of-day set), with panics turned into errors.
fn load_file(name: &str, path: &PathBuf) -> Result<MapSet, String> {
    match catch_unwind(|| MapSet::load(path)) {
        Ok(Ok(map)) => Ok(map),
        Ok(Err(e)) => Err(format!("map '{name}': {e}")),
        Err(panic) => Err(format!(
            "map '{name}': loading {} panicked: {}",
            path.display(),
            panic_message(&panic)
        )),
    }
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

/// The maps, their table builder and reloads.
pub(crate) struct Registry {
    entries: Vec<MapEntry>,
    policy: TablePolicy,
    builder: TableBuilder,
    reloads: Reloads,
}

impl Registry {
    /// Load every map (the built-in demo scene when none is given) and build the tables
    /// of the expected radii.
    pub fn load(specs: &[MapSpec], policy: TablePolicy) -> Result<Self, StartError> {
        let demo = [MapSpec {
            name: "demo".into(),
            path: None,
        }];
        let specs = if specs.is_empty() { &demo[..] } else { specs };
        let mut entries: Vec<MapEntry> = Vec::with_capacity(specs.len());
        for s in specs {
            if entries.iter().any(|m| m.name == s.name) {
                return Err(StartError::Settings(format!(
                    "map name '{}' is given twice",
                    s.name
                )));
            }
            let wire = protocol::encode_map_name(&s.name).map_err(StartError::Settings)?;
            let set = match &s.path {
                Some(p) => match catch_unwind(|| MapSet::load(p)) {
                    Ok(r) => r.map_err(|source| StartError::Map {
                        name: s.name.clone(),
                        source,
                    })?,
                    Err(panic) => {
                        return Err(StartError::Settings(format!(
                            "map '{}': loading {} panicked: {}",
                            s.name,
                            p.display(),
                            panic_message(&panic)
                        )));
                    }
                },
                None => MapSet::single(CliffMap::demo()),
            };
            policy.prepare(&s.name, &set);
            let map = Arc::clone(set.all_day());
            let max_radius = policy.max_radius(&map);
            let tables = map.table_stats();
            info!(
                map = %s.name, path = ?s.path, locations = map.locations().len(),
                max_radius, table_radii = ?tables.radii, table_kib = tables.bytes / 1024,
                slices = set.slices().len(), clock_offset = set.clock_offset(),
                "map loaded"
            );
            entries.push(MapEntry {
                name: s.name.clone(),
                wire,
                path: s.path.clone(),
                map,
                base: set.clone(),
                set,
                max_radius,
                version: 0,
                kept: VecDeque::new(),
            });
        }
        Ok(Self {
            entries,
            policy,
            builder: TableBuilder::start(),
            reloads: Reloads::default(),
        })
    }

    /// The maps.
    pub fn entries(&self) -> &[MapEntry] {
        &self.entries
    }

    /// The index of the map with this wire name.
    #[inline]
    pub fn find(&self, wire: &[u8; MAP_NAME_BYTES]) -> Option<usize> {
        self.entries.iter().position(|m| &m.wire == wire)
    }

    /// The map a request's wire name names and the version it asks for: `NAME` (the
    /// version served now) or `NAME@VERSION` (`VERSION` in decimal digits); `None` when no
    /// served map has that name. (Served names never hold `@`.)
    #[inline]
    pub fn find_pick(&self, wire: &[u8; MAP_NAME_BYTES]) -> Option<(usize, Pick)> {
        if let Some(i) = self.find(wire) {
            return Some((i, Pick::Served));
        }
        let len = wire.iter().position(|&b| b == 0).unwrap_or(MAP_NAME_BYTES);
        let name = &wire[..len];
        let at = name.iter().rposition(|&b| b == b'@')?;
        let digits = &name[at + 1..];
        if digits.is_empty() || digits.len() > 10 || !digits.iter().all(u8::is_ascii_digit) {
            return None;
        }
        let version = digits.iter().try_fold(0u32, |v, &d| {
            v.checked_mul(10)?.checked_add((d - b'0') as u32)
        })?;
        let i = self
            .entries
            .iter()
            .position(|m| m.name.as_bytes() == &name[..at])?;
        Some((i, Pick::Version(version)))
    }

    /// Ask the background thread for the table of `radius` (already within the map's
    /// limit) if the map has neither a table nor a failed build for it.
    pub fn want_table(&mut self, map: &Arc<CliffMap>, radius: f64) {
        if !map.table_settled(radius) {
            self.builder.request(map, radius);
        }
    }

    /// Start a reload (or note that another must follow the one running) and return
    /// the generation whose completion answers a request that arrived now.
    pub fn request_reload(&mut self) -> u64 {
        self.reloads.request(&self.entries, &self.policy)
    }

    /// Apply a finished reload, if any: its generation and the first failure.
    pub fn poll_reload(&mut self) -> Option<(u64, Option<String>)> {
        let (generation, results) = self.reloads.poll()?;
        let mut first_error = None;
        for (i, r) in results {
            match r {
                Ok(set) => {
                    let e = &mut self.entries[i];
                    e.base = set.clone();
                    if e.version > 0 {
                        // a learned version stays served; the file is its new base
                        info!(map = %e.name, version = e.version, "base map reloaded, the learned version stays");
                        continue;
                    }
                    let map = Arc::clone(set.all_day());
                    e.max_radius = self.policy.max_radius(&map);
                    info!(map = %e.name, locations = map.locations().len(), max_radius = e.max_radius, slices = set.slices().len(), "map reloaded");
                    e.map = map;
                    e.set = set;
                }
                Err(e) => {
                    error!("reload failed, keeping the old map: {e}");
                    first_error.get_or_insert(e);
                }
            }
        }
        if self.reloads.again {
            self.reloads.again = false;
            self.reloads.start(&self.entries, &self.policy);
        }
        Some((generation, first_error))
    }

    /// Serve `set` as version `version` of entry `i` (a learned version: one map, or a
    /// time-of-day set whose slices learned), and keep the `keep` learned versions before
    /// it for requests that ask for them by number. Requests in flight keep the version
    /// they started on (they hold its maps' `Arc`s).
    pub fn swap_learned(&mut self, i: usize, set: MapSet, version: u32, keep: usize) {
        let e = &mut self.entries[i];
        let old = std::mem::replace(&mut e.set, set);
        if e.version > 0 && keep > 0 {
            e.kept.push_front((e.version, old));
        }
        e.kept.truncate(keep);
        e.map = Arc::clone(e.set.all_day());
        e.version = version;
    }

    /// Completed reloads.
    pub fn reloads_done(&self) -> u64 {
        self.reloads.finished
    }
}

type ReloadResult = Vec<(usize, Result<MapSet, String>)>;

/// Reloads: one at a time, numbered; a request that arrives while one runs is answered
/// by the next.
#[derive(Default)]
struct Reloads {
    running: Option<Receiver<ReloadResult>>,
    /// Generations started and finished.
    started: u64,
    finished: u64,
    /// Another reload must start when the running one ends.
    again: bool,
}

impl Reloads {
    fn request(&mut self, entries: &[MapEntry], policy: &TablePolicy) -> u64 {
        if self.running.is_some() {
            self.again = true;
            self.started + 1
        } else {
            self.start(entries, policy);
            self.started
        }
    }

    fn start(&mut self, entries: &[MapEntry], policy: &TablePolicy) {
        self.started += 1;
        let jobs: Vec<(usize, String, PathBuf)> = entries
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.path.clone().map(|p| (i, m.name.clone(), p)))
            .collect();
        let policy = policy.clone();
        let (tx, rx) = mpsc::channel();
        let spawned = std::thread::Builder::new()
            .name("cliffd-reload".into())
            .spawn(move || {
                let results: ReloadResult = jobs
                    .into_iter()
                    .map(|(i, name, path)| {
                        let r = load_file(&name, &path).and_then(|map| {
                            // tables are built here, not on the serving thread
                            catch_unwind(AssertUnwindSafe(|| policy.prepare(&name, &map)))
                                .map(|_| map)
                                .map_err(|p| {
                                    format!(
                                        "map '{name}': building its tables panicked: {}",
                                        panic_message(&p)
                                    )
                                })
                        });
                        (i, r)
                    })
                    .collect();
                let _ = tx.send(results);
            });
        match spawned {
            Ok(_) => self.running = Some(rx),
            Err(e) => {
                error!("cannot start the reload thread: {e}");
                // an already-disconnected channel: poll reports the failure
                let (_, rx) = mpsc::channel();
                self.running = Some(rx);
            }
        }
    }

    /// A finished reload's generation and results (a thread that died reports every map
    /// as failed).
    fn poll(&mut self) -> Option<(u64, ReloadResult)> {
        let rx = self.running.as_ref()?;
        let results = match rx.try_recv() {
            Ok(r) => r,
            Err(TryRecvError::Empty) => return None,
            // (an error names no map, so no map is replaced)
            Err(TryRecvError::Disconnected) => vec![(
                usize::MAX,
                Err("the reload thread died before it finished".to_string()),
            )],
        };
        self.running = None;
        self.finished = self.started;
        Some((self.finished, results))
    }
}

/// Queued table builds (bounded: a full queue drops the request, asked again later).
const BUILD_QUEUE: usize = 8;

/// How much longer than a build the builder rests after it: 3 (a quarter of a core).
const BUILD_REST_FACTOR: u32 = 3;

/// Builds neighbour tables of radii asked for by requests, on its own thread.
pub(crate) struct TableBuilder {
    tx: Option<SyncSender<(Arc<CliffMap>, f64)>>,
    /// Recently queued (map, radius bits), so a stream of requests queues a radius once.
    recent: [(usize, u64); BUILD_QUEUE],
    next: usize,
}

impl TableBuilder {
    fn start() -> Self {
        let (tx, rx) = mpsc::sync_channel::<(Arc<CliffMap>, f64)>(BUILD_QUEUE);
        let spawned = std::thread::Builder::new()
            .name("cliffd-tables".into())
            .spawn(move || {
                while let Ok((map, radius)) = rx.recv() {
                    if map.table_settled(radius) {
                        continue;
                    }
                    let t0 = Instant::now();
                    let r = catch_unwind(AssertUnwindSafe(|| map.build_table(radius, false)));
                    let took = t0.elapsed();
                    match r {
                        Ok(Ok(t)) => debug!(
                            radius,
                            kib = t.memory_bytes() / 1024,
                            ms = took.as_secs_f64() * 1e3,
                            "neighbour table built"
                        ),
                        Ok(Err(e)) => info!(radius, "no neighbour table: {e}"),
                        Err(p) => error!(
                            radius,
                            "building a neighbour table panicked: {}",
                            panic_message(&p)
                        ),
                    }
                    drop(map);
                    std::thread::sleep((took * BUILD_REST_FACTOR).min(Duration::from_secs(10)));
                }
            });
        let tx = match spawned {
            Ok(_) => Some(tx),
            Err(e) => {
                error!("cannot start the table builder: {e}; other radii use the grid scan");
                None
            }
        };
        Self {
            tx,
            recent: [(0, 0); BUILD_QUEUE],
            next: 0,
        }
    }

    fn request(&mut self, map: &Arc<CliffMap>, radius: f64) {
        let key = (Arc::as_ptr(map) as usize, radius.to_bits());
        if self.recent.contains(&key) {
            return;
        }
        let Some(tx) = &self.tx else { return };
        match tx.try_send((map.clone(), radius)) {
            Ok(()) => {
                self.recent[self.next] = key;
                self.next = (self.next + 1) % BUILD_QUEUE;
            }
            Err(TrySendError::Full(_)) => {} // asked again by a later request
            Err(TrySendError::Disconnected(_)) => self.tx = None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(max_radius: Option<f64>, radii: &[f64]) -> TablePolicy {
        TablePolicy {
            max_radius,
            radii: radii.to_vec(),
            budget: 64 << 20,
        }
    }

    #[test]
    fn maps_load_with_their_limits_and_pinned_tables() {
        let r = Registry::load(&[], policy(None, &[0.5, 0.75, 100.0])).unwrap();
        let demo = &r.entries()[0];
        assert_eq!(demo.name, "demo");
        let step = demo.map.grid().step();
        assert_eq!(demo.max_radius, 4.0 * step);
        // radii within the limit get a table at load; 100 m is over it
        let stats = demo.map.table_stats();
        assert_eq!(stats.radii, vec![0.5, 0.75]);
        assert_eq!(demo.max_radius_mm(), (4000.0 * step) as u32);
        let r = Registry::load(&[], policy(Some(0.6), &[0.5, 0.75])).unwrap();
        assert_eq!(r.entries()[0].map.table_stats().radii, vec![0.5]);
    }

    #[test]
    fn other_radii_are_built_in_the_background() {
        let mut r = Registry::load(&[], policy(None, &[])).unwrap();
        let map = r.entries()[0].map.clone();
        assert!(map.table_stats().radii.is_empty());
        r.want_table(&map, 0.9);
        r.want_table(&map, 0.9); // queued once
        let t0 = Instant::now();
        while !map.table_settled(0.9) {
            assert!(t0.elapsed() < Duration::from_secs(10), "never built");
            std::thread::sleep(Duration::from_millis(5));
        }
        assert_eq!(map.table_stats().radii, vec![0.9]);
    }

    #[test]
    fn a_reload_answers_requests_that_arrived_before_it_started() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hall.csv");
        cliff::map::write_csv(&CliffMap::demo(), &path).unwrap();
        let spec = MapSpec {
            name: "hall".into(),
            path: Some(path.clone()),
        };
        let mut r = Registry::load(std::slice::from_ref(&spec), policy(None, &[])).unwrap();
        let first = r.request_reload();
        // asked while the first runs: answered only by the second
        let second = r.request_reload();
        assert_eq!((first, second), (1, 2));
        assert_eq!(r.request_reload(), 2, "one more reload covers both");
        let wait = |r: &mut Registry| {
            let t0 = Instant::now();
            loop {
                if let Some(done) = r.poll_reload() {
                    return done;
                }
                assert!(t0.elapsed() < Duration::from_secs(10));
                std::thread::sleep(Duration::from_millis(2));
            }
        };
        assert_eq!(wait(&mut r), (1, None));
        // the second started by itself; break the file before it reads it? it may have
        // read it already, so only check it completes
        assert_eq!(wait(&mut r).0, 2);
        // a broken file fails the reload and keeps the old map
        std::fs::write(&path, "1,2,oops\n").unwrap();
        let before = Arc::as_ptr(&r.entries()[0].map);
        let g = r.request_reload();
        let (done, err) = wait(&mut r);
        assert_eq!(done, g);
        let err = err.expect("failed");
        assert!(err.contains("hall") && err.contains("oops"), "{err}");
        assert_eq!(Arc::as_ptr(&r.entries()[0].map), before);
        assert_eq!(r.reloads_done(), 3);
    }
}
