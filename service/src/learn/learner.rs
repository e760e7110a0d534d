//! The learner: a background thread that folds segments of tracks into each learned map
//! with the online update, publishes every new version for the serving loop to swap in,
//! and writes snapshots ([`Learner`]).

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cliff::map::build::Observation as MapObservation;
use cliff::map::update::{OnlineMap, UpdateParams};
use cliff::map::{CliffMap, MapSet, SetParts};
use tracing::{info, warn};

use super::guard;
use super::intake::{ClientKey, Segment};
use super::snapshots::{self, Saved};
use crate::registry::TablePolicy;
use crate::settings::LearnSettings;

/// A version of a learned map, ready to be served.
pub(crate) struct Published {
    pub version: u32,
    pub set: MapSet,
}

/// What the learner counted (read by the serving loop's log and by tests).
#[derive(Debug, Default)]
pub(crate) struct LearnerCounters {
    /// Rows folded into maps.
    pub learned_rows: AtomicU64,
    /// Versions published.
    pub versions: AtomicU64,
    /// Candidate versions refused by the held-out check.
    pub refused: AtomicU64,
    /// Snapshots written.
    pub snapshots: AtomicU64,
    /// Snapshot writes that failed.
    pub snapshot_failures: AtomicU64,
}

/// What the learner thread shares with the serving loop.
pub(crate) struct Shared {
    /// Per learned map, the newest version not yet swapped in.
    pub slots: Vec<Mutex<Option<Published>>>,
    pub stop: AtomicBool,
    pub counters: LearnerCounters,
}

/// One part of a learned map that learns by itself: the map of a set without slices, or
/// one slice of a time-of-day set (the all-day map of a set does not learn).
struct Part {
    /// `None` until the first update when the count scale comes from the first batch.
    online: Option<OnlineMap>,
    /// The part's map served now (what `online` last produced, or the start map).
    current: Arc<CliffMap>,
    /// Rows waiting for the next update, by client and track (for the guards' caps).
    waiting: HashMap<(ClientKey, u32), Vec<MapObservation>>,
    waiting_rows: usize,
    oldest: Option<Instant>,
    held: guard::HeldSample,
    /// When the part last moved (a version published), or the learner started.
    moved: Instant,
}

/// One learned map on the learner thread.
struct Learned {
    name: String,
    /// The set served now (the newest version).
    set: MapSet,
    /// The parts that learn: one (index 0) for a set without slices, one per slice for a
    /// time-of-day set, each made when its first row arrives.
    parts: Vec<Option<Part>>,
    /// The count scale each part starts with (from the snapshot resumed, else the
    /// setting; `None`: from its first batch).
    start_scales: Vec<Option<f64>>,
    version: u32,
    /// Rows learned since the start map.
    rows: u64,
    saved_version: u32,
}

impl Learned {
    /// The part a row at `time` (the client's clock) belongs to: the slice of its time of
    /// day for a time-of-day set, else the one part.
    fn part_of(&self, time: f64) -> Option<usize> {
        if self.set.is_sliced() {
            self.set.slice_index(time)
        } else {
            Some(0)
        }
    }

    /// Part `p`, made on first use from the map it stands for now (a slice without a map
    /// of its own starts from a copy of the all-day map).
    fn part(&mut self, p: usize, settings: &LearnSettings) -> Result<&mut Part, String> {
        if self.parts[p].is_none() {
            let current = if self.set.is_sliced() {
                Arc::clone(self.set.slice_map(p).ok_or("no such slice")?)
            } else {
                Arc::clone(self.set.all_day())
            };
            let online = match self.start_scales[p] {
                Some(c) => Some(
                    OnlineMap::from_map(&current, c, update_params(settings))
                        .map_err(|e| format!("map '{}': cannot learn it: {e}", self.name))?,
                ),
                None => None,
            };
            self.parts[p] = Some(Part {
                online,
                current,
                waiting: HashMap::new(),
                waiting_rows: 0,
                oldest: None,
                held: guard::HeldSample::new(settings.guards.held_rows, settings.guards.held_every),
                moved: Instant::now(),
            });
        }
        Ok(self.parts[p].as_mut().expect("made above"))
    }

    /// Give part `p` a segment of its rows: held out, or waiting for the next update.
    fn offer(&mut self, p: usize, s: Segment, settings: &LearnSettings) {
        let part = match self.part(p, settings) {
            Ok(part) => part,
            Err(e) => {
                // (the error names the map)
                warn!(slice = p, "rows not learned: {e}");
                return;
            }
        };
        // some segments are held out to judge new versions, never learned
        if let Some(s) = part.held.offer(s) {
            part.waiting_rows += s.observations.len();
            part.waiting
                .entry((s.client, s.track))
                .or_default()
                .extend(s.observations);
            part.oldest.get_or_insert_with(Instant::now);
        }
    }

    /// The count scale of every part (`None` where unknown yet), as saved.
    fn scales(&self) -> Vec<Option<f64>> {
        self.parts
            .iter()
            .zip(&self.start_scales)
            .map(|(p, s)| {
                p.as_ref()
                    .and_then(|p| p.online.as_ref().map(|o| o.count_scale()))
                    .or(*s)
            })
            .collect()
    }
}

/// `set` with part `p` replaced by `map`: the map of a set without slices, or slice `p`.
fn with_part(set: &MapSet, p: usize, map: Arc<CliffMap>) -> Result<MapSet, String> {
    let parts = if set.is_sliced() {
        let mut slices = set.slices().to_vec();
        slices[p] = Some(map);
        SetParts {
            all_day: Arc::clone(set.all_day()),
            slices,
            slice_length: set.slice_length(),
            clock_offset: set.clock_offset(),
            smoothing: set.smoothing(),
            observations: set.observations().to_vec(),
        }
    } else {
        SetParts {
            all_day: map,
            slices: Vec::new(),
            slice_length: set.slice_length(),
            clock_offset: set.clock_offset(),
            smoothing: set.smoothing(),
            observations: Vec::new(),
        }
    };
    MapSet::from_parts(parts).map_err(|e| e.to_string())
}

/// The learner thread's state.
pub(crate) struct Learner {
    settings: LearnSettings,
    policy: TablePolicy,
    maps: Vec<Learned>,
    shared: Arc<Shared>,
    pool: rayon::ThreadPool,
    next_snapshot: Instant,
}

/// The online update's options from the daemon's settings (the damping bound is set per
/// update: [`move_bound`]).
fn update_params(settings: &LearnSettings) -> UpdateParams {
    UpdateParams {
        decay: settings.decay,
        ..UpdateParams::default()
    }
}

/// The damping bound of an update `since` the previous one: the move per minute times
/// the minutes, counted up to the learning interval (an idle map does not save moves
/// up); `None` when it reaches 1, which bounds nothing.
fn move_bound(settings: &LearnSettings, since: Duration) -> Option<f64> {
    let minutes = since.min(settings.every).as_secs_f64() / 60.0;
    let bound = settings.guards.max_move_per_min * minutes;
    (bound < 1.0).then_some(bound.max(1e-9))
}

/// Where a learned map starts: the set and its version, the rows learned so far and the
/// count scale of each part (when known: empty for none).
pub(crate) struct Start {
    pub name: String,
    pub set: MapSet,
    pub version: u32,
    pub rows: u64,
    pub count_scales: Vec<Option<f64>>,
}

impl Learner {
    pub fn new(
        settings: LearnSettings,
        policy: TablePolicy,
        starts: Vec<Start>,
        shared: Arc<Shared>,
    ) -> Result<Self, String> {
        // one thread: the update's parallel parts must not take the serving cores
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .thread_name(|_| "cliffd-learn".into())
            .build()
            .map_err(|e| format!("cannot start the learner's thread pool: {e}"))?;
        let mut maps = Vec::new();
        for s in starts {
            let n = if s.set.is_sliced() {
                s.set.slices().len()
            } else {
                1
            };
            let start_scales = (0..n)
                .map(|p| {
                    s.count_scales
                        .get(p)
                        .copied()
                        .flatten()
                        .or(settings.count_scale)
                })
                .collect();
            let mut m = Learned {
                name: s.name,
                set: s.set,
                parts: (0..n).map(|_| None).collect(),
                start_scales,
                version: s.version,
                rows: s.rows,
                saved_version: s.version,
            };
            // a set without slices learns from the start: its settings are checked now
            if n == 1 {
                m.part(0, &settings)?;
            }
            maps.push(m);
        }
        Ok(Learner {
            next_snapshot: Instant::now() + settings.snapshot_every,
            settings,
            policy,
            maps,
            shared,
            pool,
        })
    }

    /// Run until the stop flag is set and the channel is drained; then learn what waits
    /// and write the last snapshots.
    pub fn run(mut self, segments: Receiver<Segment>) {
        loop {
            match segments.recv_timeout(Duration::from_millis(100)) {
                Ok(s) => self.add(s),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if self.shared.stop.load(Ordering::Relaxed) {
                while let Ok(s) = segments.try_recv() {
                    self.add(s);
                }
                break;
            }
            let now = Instant::now();
            for i in 0..self.maps.len() {
                for p in 0..self.maps[i].parts.len() {
                    let due = self.maps[i].parts[p].as_ref().is_some_and(|part| {
                        part.waiting_rows >= self.settings.every_rows
                            || part
                                .oldest
                                .is_some_and(|t| now.duration_since(t) >= self.settings.every)
                    });
                    if due {
                        self.learn(i, p);
                    }
                }
            }
            if now >= self.next_snapshot {
                self.snapshot_all();
                self.next_snapshot = now + self.settings.snapshot_every;
            }
        }
        for i in 0..self.maps.len() {
            for p in 0..self.maps[i].parts.len() {
                if self.maps[i].parts[p]
                    .as_ref()
                    .is_some_and(|part| part.waiting_rows > 0)
                {
                    self.learn(i, p);
                }
            }
        }
        self.snapshot_all();
    }

    /// Take a segment: its rows go to the part of their time (a time-of-day set's rows
    /// to the slice of each row's time of day), where they wait for the next update or
    /// are held out to judge new versions.
    fn add(&mut self, s: Segment) {
        let Some(m) = self.maps.get_mut(s.map) else {
            return;
        };
        if !m.set.is_sliced() {
            m.offer(0, s, &self.settings);
            return;
        }
        // consecutive rows of one slice stay one segment (a track rarely crosses a slice)
        let mut rows = s.observations.into_iter().zip(s.times).peekable();
        while let Some((o, t)) = rows.next() {
            let Some(p) = m.part_of(t) else { continue };
            let mut piece = Segment {
                map: s.map,
                client: s.client,
                track: s.track,
                observations: vec![o],
                times: vec![t],
            };
            while let Some((o, t)) = rows.next_if(|&(_, t)| m.part_of(t) == Some(p)) {
                piece.observations.push(o);
                piece.times.push(t);
            }
            m.offer(p, piece, &self.settings);
        }
    }

    /// Fold the waiting rows of part `p` of map `i` into it, check the candidate on the
    /// part's held sample, and publish the set with it.
    fn learn(&mut self, i: usize, p: usize) {
        let guards = self.settings.guards;
        let params = update_params(&self.settings);
        let fixed_scale = self.settings.count_scale;
        let m = &mut self.maps[i];
        let sliced = m.set.is_sliced();
        let Some(part) = m.parts[p].as_mut() else {
            return;
        };
        let mut by_client: HashMap<ClientKey, Vec<MapObservation>> = HashMap::new();
        for ((client, _), rows) in std::mem::take(&mut part.waiting) {
            by_client
                .entry(client)
                .or_default()
                .extend(guard::thin(&rows, guards.track_rows));
        }
        let batch = guard::share_capped(by_client, guards.client_share, self.settings.every_rows);
        let bound = move_bound(&self.settings, part.moved.elapsed());
        part.waiting_rows = 0;
        part.oldest = None;
        if batch.is_empty() {
            return;
        }
        let name = &m.name;
        let slice = sliced.then_some(p);
        let result = self.pool.install(|| -> Result<Option<CliffMap>, String> {
            if part.online.is_none() {
                let mut online =
                    OnlineMap::from_map(&part.current, fixed_scale.unwrap_or(1.0), params)
                        .map_err(|e| e.to_string())?;
                let scale = online.busiest_node(&batch).map_err(|e| e.to_string())?;
                online
                    .set_count_scale(scale.max(1) as f64)
                    .map_err(|e| e.to_string())?;
                part.online = Some(online);
            }
            let online = part.online.as_mut().expect("set above");
            online.set_max_move(bound).map_err(|e| e.to_string())?;
            let before = online.clone();
            let report = online.update(&batch).map_err(|e| e.to_string())?;
            if report.damped > 0 {
                info!(
                    map = %name, ?slice, locations = report.damped, bound = bound.unwrap_or(1.0),
                    "update damped (--learn-move-per-min)"
                );
            }
            let candidate = online.to_map().map_err(|e| e.to_string())?;
            if let Some(why) = part
                .held
                .refuses(&part.current, &candidate, guards.max_score_drop)
            {
                warn!(map = %name, ?slice, "learned version refused: {why}");
                *online = before;
                return Ok(None);
            }
            Ok(Some(candidate))
        });
        let candidate = match result {
            Ok(Some(c)) => Arc::new(c),
            Ok(None) => {
                self.shared.counters.refused.fetch_add(1, Ordering::Relaxed);
                return;
            }
            Err(e) => {
                warn!(map = %m.name, ?slice, rows = batch.len(), "learning failed: {e}");
                return;
            }
        };
        let set = match with_part(&m.set, p, Arc::clone(&candidate)) {
            Ok(set) => set,
            Err(e) => {
                warn!(map = %m.name, ?slice, "learned version not made: {e}");
                return;
            }
        };
        // the new map gets its tables here; the others have theirs
        self.policy.prepare(&m.name, &set);
        part.current = Arc::clone(&candidate);
        part.moved = Instant::now();
        m.set = set.clone();
        m.version += 1;
        m.rows += batch.len() as u64;
        let c = &self.shared.counters;
        c.learned_rows
            .fetch_add(batch.len() as u64, Ordering::Relaxed);
        c.versions.fetch_add(1, Ordering::Relaxed);
        info!(
            map = %m.name,
            ?slice,
            version = m.version,
            rows = batch.len(),
            locations = candidate.locations().len(),
            "learned a new version"
        );
        let mut slot = self.shared.slots[i]
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        *slot = Some(Published {
            version: m.version,
            set,
        });
    }

    fn snapshot_all(&mut self) {
        let Some(dir) = self.settings.dir.clone() else {
            return;
        };
        for m in &mut self.maps {
            if m.version == m.saved_version {
                continue;
            }
            let saved = Saved {
                version: m.version,
                rows: m.rows,
                count_scales: m.scales(),
            };
            match snapshots::write(&dir, &m.name, &m.set, &saved) {
                Ok(path) => {
                    m.saved_version = m.version;
                    self.shared
                        .counters
                        .snapshots
                        .fetch_add(1, Ordering::Relaxed);
                    info!(map = %m.name, version = m.version, file = %path.display(), "snapshot written");
                }
                Err(e) => {
                    self.shared
                        .counters
                        .snapshot_failures
                        .fetch_add(1, Ordering::Relaxed);
                    warn!(map = %m.name, "snapshot not written: {e}");
                }
            }
        }
    }
}
