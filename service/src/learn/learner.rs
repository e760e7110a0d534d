//! The learner: a background thread that folds segments of tracks into each learned map
//! with the online update, publishes every new version for the serving loop to swap in,
//! and writes snapshots ([`Learner`]).

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::map::build::Observation as MapObservation;
use cliff::map::update::{OnlineMap, UpdateParams};
use tracing::{info, warn};

use super::guard;
use super::intake::{ClientKey, Segment};
use super::settings::LearnSettings;
use super::snapshots::{self, Saved};
use crate::registry::TablePolicy;

/// A version of a learned map, ready to be served.
pub(crate) struct Published {
    pub version: u32,
    pub map: Arc<CliffMap>,
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

/// One learned map on the learner thread.
struct Learned {
    name: String,
    /// `None` until the first update when the count scale comes from the first batch.
    online: Option<OnlineMap>,
    /// The map served now (what `online` last produced, or the start map).
    current: Arc<CliffMap>,
    version: u32,
    /// Rows waiting for the next update, by client and track (for the guards' caps).
    waiting: HashMap<(ClientKey, u32), Vec<MapObservation>>,
    waiting_rows: usize,
    oldest: Option<Instant>,
    held: guard::HeldSample,
    /// Rows learned since the start map.
    rows: u64,
    /// When the map last moved (a version published), or the learner started.
    moved: Instant,
    saved_version: u32,
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

/// Where a learned map starts: the map and its version, the rows learned so far and the
/// count scale (when known).
pub(crate) struct Start {
    pub name: String,
    pub map: Arc<CliffMap>,
    pub version: u32,
    pub rows: u64,
    pub count_scale: Option<f64>,
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
        let params = update_params(&settings);
        let mut maps = Vec::new();
        for s in starts {
            let scale = s.count_scale.or(settings.count_scale);
            let online = match scale {
                Some(c) => Some(
                    OnlineMap::from_map(&s.map, c, params)
                        .map_err(|e| format!("map '{}': cannot learn it: {e}", s.name))?,
                ),
                None => None,
            };
            maps.push(Learned {
                name: s.name,
                online,
                current: s.map,
                version: s.version,
                waiting: HashMap::new(),
                waiting_rows: 0,
                oldest: None,
                held: guard::HeldSample::new(settings.guards.held_rows, settings.guards.held_every),
                rows: s.rows,
                moved: Instant::now(),
                saved_version: s.version,
            });
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
                let m = &self.maps[i];
                let due = m.waiting_rows >= self.settings.every_rows
                    || m.oldest
                        .is_some_and(|t| now.duration_since(t) >= self.settings.every);
                if due {
                    self.learn(i);
                }
            }
            if now >= self.next_snapshot {
                self.snapshot_all();
                self.next_snapshot = now + self.settings.snapshot_every;
            }
        }
        for i in 0..self.maps.len() {
            if self.maps[i].waiting_rows > 0 {
                self.learn(i);
            }
        }
        self.snapshot_all();
    }

    fn add(&mut self, s: Segment) {
        let Some(m) = self.maps.get_mut(s.map) else {
            return;
        };
        // some segments are held out to judge new versions, never learned
        if let Some(s) = m.held.offer(s) {
            m.waiting_rows += s.observations.len();
            m.waiting
                .entry((s.client, s.track))
                .or_default()
                .extend(s.observations);
            m.oldest.get_or_insert_with(Instant::now);
        }
    }

    /// Fold map `i`'s waiting rows into it, check the candidate on the held sample, and
    /// publish it.
    fn learn(&mut self, i: usize) {
        let guards = self.settings.guards;
        let params = update_params(&self.settings);
        let fixed_scale = self.settings.count_scale;
        let m = &mut self.maps[i];
        let mut by_client: HashMap<ClientKey, Vec<MapObservation>> = HashMap::new();
        for ((client, _), rows) in std::mem::take(&mut m.waiting) {
            by_client
                .entry(client)
                .or_default()
                .extend(guard::thin(&rows, guards.track_rows));
        }
        let batch = guard::share_capped(by_client, guards.client_share, self.settings.every_rows);
        let bound = move_bound(&self.settings, m.moved.elapsed());
        m.waiting_rows = 0;
        m.oldest = None;
        if batch.is_empty() {
            return;
        }
        let result = self.pool.install(|| -> Result<Option<CliffMap>, String> {
            if m.online.is_none() {
                let mut online =
                    OnlineMap::from_map(&m.current, fixed_scale.unwrap_or(1.0), params)
                        .map_err(|e| e.to_string())?;
                let scale = online.busiest_node(&batch).map_err(|e| e.to_string())?;
                online
                    .set_count_scale(scale.max(1) as f64)
                    .map_err(|e| e.to_string())?;
                m.online = Some(online);
            }
            let online = m.online.as_mut().expect("set above");
            online.set_max_move(bound).map_err(|e| e.to_string())?;
            let before = online.clone();
            let report = online.update(&batch).map_err(|e| e.to_string())?;
            if report.damped > 0 {
                info!(
                    map = %m.name, locations = report.damped, bound = bound.unwrap_or(1.0),
                    "update damped (--learn-move-per-min)"
                );
            }
            let candidate = online.to_map().map_err(|e| e.to_string())?;
            if let Some(why) = m
                .held
                .refuses(&m.current, &candidate, guards.max_score_drop)
            {
                warn!(map = %m.name, "learned version refused: {why}");
                *online = before;
                return Ok(None);
            }
            Ok(Some(candidate))
        });
        let candidate = match result {
            Ok(Some(c)) => c,
            Ok(None) => {
                self.shared.counters.refused.fetch_add(1, Ordering::Relaxed);
                return;
            }
            Err(e) => {
                warn!(map = %m.name, rows = batch.len(), "learning failed: {e}");
                return;
            }
        };
        let map = Arc::new(candidate);
        self.policy
            .prepare(&m.name, &cliff::map::MapSet::single_arc(Arc::clone(&map)));
        m.version += 1;
        m.moved = Instant::now();
        m.rows += batch.len() as u64;
        m.current = Arc::clone(&map);
        let c = &self.shared.counters;
        c.learned_rows
            .fetch_add(batch.len() as u64, Ordering::Relaxed);
        c.versions.fetch_add(1, Ordering::Relaxed);
        info!(
            map = %m.name,
            version = m.version,
            rows = batch.len(),
            locations = map.locations().len(),
            "learned a new version"
        );
        let mut slot = self.shared.slots[i]
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        *slot = Some(Published {
            version: m.version,
            map,
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
                count_scale: m.online.as_ref().map(|o| o.count_scale()),
            };
            match snapshots::write(&dir, &m.name, &m.current, &saved) {
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
