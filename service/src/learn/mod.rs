//! Maps that learn while they serve (`cliffd --learn NAME`): observations in, a
//! background learner, new versions swapped in, snapshots on disk. What to learn and how
//! ([`LearnSettings`], the per-client [`Budgets`] and the [`Guards`]) is part of the
//! daemon's settings (`settings/learning.rs`), re-exported here. One part per file:
//!
//! * `intake.rs`: observations in, on the serving thread: budgets, deduplication by
//!   (client, track, time), tracks cut into segments, quiet clients dropped;
//! * `guard.rs`: the guards between observations and the served map (a track's and a
//!   client's weight in an update capped, new versions checked on held-out rows);
//! * `learner.rs`: the learner thread (online update, new versions, snapshots);
//! * `snapshots.rs`: learned maps on disk, written atomically, the newest good one found
//!   at start.
//!
//! The serving thread never waits for the learner: segments go through a bounded
//! channel (a full one drops the segment and counts it), and a new version waits in a
//! slot that the serving loop looks at between requests and swaps into the registry;
//! requests already accepted keep the version they started on.

mod guard;
mod intake;
mod learner;
mod snapshots;

use std::sync::atomic::Ordering;
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use cliff_client::protocol::{Field, Observation, ObserveReply, Rejection, Status};
use tracing::{info, warn};

use crate::registry::{Registry, TablePolicy};
use crate::settings::StartError;

pub use crate::settings::{Budgets, Guards, LearnSettings};
pub(crate) use intake::ClientKey;
// for following another daemon's map (zenoh/follow.rs)
#[cfg(feature = "zenoh")]
pub(crate) use snapshots::{
    Saved, newest as newest_snapshot, usable_name, write as write_snapshot,
};

use intake::{Intake, Segment};
use learner::{Learner, Shared, Start};

/// What learning counted, for the daemon's [`Stats`](crate::Stats) and log.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LearnStats {
    /// Rows taken from observe requests.
    pub accepted_rows: u64,
    /// Rows skipped as already seen (same client, track and time).
    pub duplicate_rows: u64,
    /// Observe requests refused for a budget.
    pub over_budget: u64,
    /// Segments dropped because the learner was behind.
    pub dropped_segments: u64,
    /// Rows folded into learned maps.
    pub learned_rows: u64,
    /// Learned versions swapped in.
    pub versions: u64,
    /// Learned versions refused by the held-out check.
    pub refused_versions: u64,
    /// Snapshots written, and failed writes.
    pub snapshots: u64,
    /// Snapshot writes that failed.
    pub snapshot_failures: u64,
    /// Open tracks now.
    pub open_tracks: u64,
}

/// The daemon's side of learning: the intake, the learner thread and its slots.
pub(crate) struct Learning {
    intake: Intake,
    /// The registry entry of each learned map.
    entries: Vec<usize>,
    /// The version served of each learned map.
    versions: Vec<u32>,
    max_observe_rows: u32,
    /// Learned versions kept before the one served ([`LearnSettings::keep_versions`]).
    keep_versions: usize,
    tx: Option<SyncSender<Segment>>,
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    dropped: u64,
    swapped: u64,
}

impl Learning {
    /// Start learning the maps of `settings` (none: `None`): each starts from the newest
    /// good snapshot in the learning directory (which the registry then serves) or else
    /// from the map as loaded.
    pub fn start(
        settings: &LearnSettings,
        registry: &mut Registry,
        policy: TablePolicy,
    ) -> Result<Option<Learning>, StartError> {
        if settings.maps.is_empty() {
            return Ok(None);
        }
        settings.check().map_err(StartError::Settings)?;
        let mut entries = Vec::new();
        let mut starts = Vec::new();
        let mut versions = Vec::new();
        for name in &settings.maps {
            let Some(i) = registry.entries().iter().position(|e| &e.name == name) else {
                return Err(StartError::Settings(format!(
                    "--learn {name}: no map of that name is served (--map {name}=PATH)"
                )));
            };
            if !snapshots::usable_name(name) {
                return Err(StartError::Settings(format!(
                    "--learn {name}: a learned map's name may hold letters, digits, '-', '_' and '.' only"
                )));
            }
            let served = registry.entries()[i].set.clone();
            let mut start = Start {
                name: name.clone(),
                set: served.clone(),
                version: 0,
                rows: 0,
                count_scales: Vec::new(),
            };
            if let Some(dir) = &settings.dir {
                let stale = snapshots::remove_temporaries(dir, name);
                if stale > 0 {
                    info!(map = %name, files = stale, "removed temporary files of an interrupted snapshot");
                }
                let mut skipped = Vec::new();
                let found = snapshots::newest(dir, name, |s| same_shape(&served, s), &mut skipped);
                for s in skipped {
                    warn!(map = %name, "learned snapshot skipped: {s}");
                }
                if let Some((set, saved)) = found {
                    policy.prepare(name, &set);
                    info!(
                        map = %name, version = saved.version, rows = saved.rows,
                        locations = set.all_day().locations().len(), slices = set.slices().len(),
                        "resuming from the newest learned snapshot"
                    );
                    registry.swap_learned(i, set.clone(), saved.version, settings.keep_versions);
                    start.set = set;
                    start.version = saved.version;
                    start.rows = saved.rows;
                    start.count_scales = saved.count_scales;
                }
            }
            versions.push(start.version);
            entries.push(i);
            starts.push(start);
        }
        let shared = Arc::new(Shared {
            slots: (0..entries.len()).map(|_| Mutex::new(None)).collect(),
            stop: Default::default(),
            counters: Default::default(),
        });
        let learner = Learner::new(settings.clone(), policy, starts, Arc::clone(&shared))
            .map_err(StartError::Settings)?;
        let (tx, rx) = mpsc::sync_channel(settings.queue);
        let thread = std::thread::Builder::new()
            .name("cliffd-learner".into())
            .spawn(move || learner.run(rx))
            .map_err(|e| StartError::Settings(format!("cannot start the learner: {e}")))?;
        Ok(Some(Learning {
            intake: Intake::new(settings.budgets),
            entries,
            versions,
            max_observe_rows: settings.max_observe_rows,
            keep_versions: settings.keep_versions,
            tx: Some(tx),
            shared,
            thread: Some(thread),
            dropped: 0,
            swapped: 0,
        }))
    }

    /// Rows per observe request.
    pub fn max_observe_rows(&self) -> u32 {
        self.max_observe_rows
    }

    /// Take the rows of a validated observe request from `client` (its id `request`)
    /// for registry entry `entry`; the same request sent again is answered with the
    /// same counts ([`Intake::take_request`]).
    pub fn observe(
        &mut self,
        client: ClientKey,
        request: u64,
        entry: usize,
        rows: &[Observation],
    ) -> Result<ObserveReply, Rejection> {
        let Some(i) = self.entries.iter().position(|&e| e == entry) else {
            return Err(Rejection {
                status: Status::NotLearning,
                agent: None,
                row: None,
                field: Field::Map,
                limit: 0,
            });
        };
        let (tx, dropped) = (&self.tx, &mut self.dropped);
        let taken =
            self.intake
                .take_request(client, request, i, rows, Instant::now(), &mut |s| {
                    send(tx, dropped, s)
                })?;
        Ok(ObserveReply {
            accepted: taken.accepted,
            duplicates: taken.duplicates,
            map_version: self.versions[i],
        })
    }

    /// Between requests: finish quiet tracks, and swap in the learned versions waiting.
    pub fn housekeeping(&mut self, registry: &mut Registry) {
        let (tx, dropped) = (&self.tx, &mut self.dropped);
        self.intake
            .expire(Instant::now(), &mut |s| send(tx, dropped, s));
        for (i, slot) in self.shared.slots.iter().enumerate() {
            let Ok(mut slot) = slot.try_lock() else {
                continue; // the learner is publishing: next time
            };
            if let Some(p) = slot.take() {
                registry.swap_learned(self.entries[i], p.set, p.version, self.keep_versions);
                self.versions[i] = p.version;
                self.swapped += 1;
            }
        }
    }

    /// What learning counted so far.
    pub fn stats(&self) -> LearnStats {
        let i = self.intake.stats();
        let c = &self.shared.counters;
        LearnStats {
            accepted_rows: i.accepted,
            duplicate_rows: i.duplicates,
            over_budget: i.over_budget,
            dropped_segments: self.dropped,
            learned_rows: c.learned_rows.load(Ordering::Relaxed),
            versions: self.swapped,
            refused_versions: c.refused.load(Ordering::Relaxed),
            snapshots: c.snapshots.load(Ordering::Relaxed),
            snapshot_failures: c.snapshot_failures.load(Ordering::Relaxed),
            open_tracks: self.intake.tracks() as u64,
        }
    }

    /// At shutdown: every open track to the learner, which learns what waits, writes the
    /// last snapshots and ends.
    pub fn shutdown(&mut self) {
        let (tx, dropped) = (&self.tx, &mut self.dropped);
        self.intake.flush(&mut |s| send(tx, dropped, s));
        self.shared.stop.store(true, Ordering::Relaxed);
        self.tx = None;
        if let Some(t) = self.thread.take()
            && t.join().is_err()
        {
            warn!("the learner thread panicked");
        }
    }
}

impl Drop for Learning {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Whether a snapshot `found` can stand for the map `served` (as loaded from its file):
/// both one map, or both time-of-day sets of the same slices and clock offset.
pub(crate) fn same_shape(
    served: &cliff::map::MapSet,
    found: &cliff::map::MapSet,
) -> Result<(), String> {
    let shape = |s: &cliff::map::MapSet| {
        if s.is_sliced() {
            format!(
                "a time-of-day set of {} slices of {} s, clock offset {} s",
                s.slices().len(),
                s.slice_length(),
                s.clock_offset()
            )
        } else {
            "one map".to_string()
        }
    };
    let (a, b) = (shape(served), shape(found));
    if a == b {
        Ok(())
    } else {
        Err(format!("it holds {b}, the map served is {a}"))
    }
}

/// Hand a segment to the learner without waiting: a full queue drops it (counted).
fn send(tx: &Option<SyncSender<Segment>>, dropped: &mut u64, s: Segment) {
    let Some(tx) = tx else { return };
    match tx.try_send(s) {
        Ok(()) => {}
        Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => *dropped += 1,
    }
}
