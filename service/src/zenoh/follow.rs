//! Following another daemon's map (`cliffd --follow NAME=ENDPOINT`): a thread per
//! followed map asks the site's daemon over zenoh for the version it serves
//! ([`cliff_client::map_wire`]), checks what comes (size bound before reading,
//! checksum, the snapshot's own checks, the same shape as the map served), builds its
//! tables, writes it to the snapshot directory and leaves it in a slot that the serving
//! loop swaps into the registry between requests ([`Following::housekeeping`]), as it
//! swaps learned versions: no request waits for a version, and requests in flight keep
//! the one they started on. The versions keep the site's numbers.
//!
//! When the site is away the daemon serves the last version it took; at start it serves
//! the newest good snapshot in the directory; its thread keeps asking (every
//! [`FollowSettings::every`]) and catches up once the site answers again.

use std::path::PathBuf;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use cliff::map::MapSet;
use cliff_client::map_wire::{self, MapStatus};
use tracing::{info, warn};
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::query::ConsolidationMode;

use crate::learn::{Saved, newest_snapshot, same_shape, write_snapshot};
use crate::registry::{Registry, TablePolicy};
use crate::settings::StartError;

/// The largest map snapshot a follower takes by default (bytes).
pub const DEFAULT_MAX_MAP_BYTES: usize = 256 << 20;

/// One followed map: `NAME=ENDPOINT[,ENDPOINT...]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FollowSpec {
    /// The map's name, here and at the site.
    pub name: String,
    /// The site daemon's zenoh endpoints (`tcp/10.0.0.1:7447`); empty: those of the
    /// configuration file.
    pub endpoints: Vec<String>,
}

impl FromStr for FollowSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (name, endpoints) = s.split_once('=').unwrap_or((s, ""));
        if name.is_empty() {
            return Err(format!(
                "--follow '{s}': expected NAME=ENDPOINT (e.g. atc=tcp/10.0.0.1:7447)"
            ));
        }
        Ok(FollowSpec {
            name: name.to_string(),
            endpoints: endpoints
                .split(',')
                .filter(|e| !e.is_empty())
                .map(str::to_string)
                .collect(),
        })
    }
}

/// What a daemon follows and how.
#[derive(Debug, Clone, PartialEq)]
pub struct FollowSettings {
    /// The followed maps.
    pub maps: Vec<FollowSpec>,
    /// The site daemon's service name (its zenoh keys derive from it).
    pub service: String,
    /// A zenoh configuration file for the link to the site (TLS, access control).
    pub config_file: Option<PathBuf>,
    /// Where the versions taken are written (and found at start); `None`: memory only.
    pub dir: Option<PathBuf>,
    /// How often the site is asked.
    pub every: Duration,
    /// How long one question waits for the site's answer.
    pub timeout: Duration,
    /// The largest snapshot taken (bytes).
    pub max_bytes: usize,
    /// Versions kept before the one served, for requests that name one (`NAME@VERSION`).
    pub keep_versions: usize,
}

impl Default for FollowSettings {
    fn default() -> Self {
        FollowSettings {
            maps: Vec::new(),
            service: cliff_client::DEFAULT_SERVICE.to_string(),
            config_file: None,
            dir: None,
            every: Duration::from_millis(500),
            timeout: Duration::from_secs(10),
            max_bytes: DEFAULT_MAX_MAP_BYTES,
            keep_versions: 4,
        }
    }
}

/// What following counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FollowStats {
    /// Versions taken from the site.
    pub taken: u64,
    /// Answers refused (damaged, too large, another shape).
    pub refused: u64,
    /// Questions the site did not answer.
    pub unanswered: u64,
}

#[derive(Debug, Default)]
struct Counters {
    taken: AtomicU64,
    refused: AtomicU64,
    unanswered: AtomicU64,
}

/// A version taken, waiting for the serving loop.
type Slot = Mutex<Option<(u32, MapSet)>>;

/// The daemon's side of following: a thread and a slot per followed map.
pub struct Following {
    /// The registry entry of each followed map.
    entries: Vec<usize>,
    slots: Arc<Vec<Slot>>,
    stop: Arc<AtomicBool>,
    counters: Arc<Counters>,
    threads: Vec<JoinHandle<()>>,
    keep: usize,
}

impl std::fmt::Debug for Following {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Following")
            .field("entries", &self.entries)
            .finish_non_exhaustive()
    }
}

impl Following {
    /// Start following: each map serves the newest good snapshot in `settings.dir`
    /// (swapped into `registry` now), and a thread per map starts asking the site.
    pub(crate) fn start(
        settings: &FollowSettings,
        registry: &mut Registry,
        policy: TablePolicy,
        learned: &[String],
    ) -> Result<Following, StartError> {
        let bad = |m: String| StartError::Settings(m);
        if settings.max_bytes == 0 || settings.every.is_zero() || settings.timeout.is_zero() {
            return Err(bad(
                "--follow: the size bound, the period and the timeout must be positive".into(),
            ));
        }
        let mut entries = Vec::new();
        let mut plans = Vec::new();
        for spec in &settings.maps {
            let name = &spec.name;
            let Some(i) = registry.entries().iter().position(|e| &e.name == name) else {
                return Err(bad(format!(
                    "--follow {name}: no map of that name is served (--map {name}=PATH: the map served until the site's first version comes)"
                )));
            };
            if learned.contains(name) {
                return Err(bad(format!(
                    "--follow {name}: the map is also learned here (--learn {name}); a followed map takes the site's versions"
                )));
            }
            if entries.contains(&i) {
                return Err(bad(format!("--follow {name}: followed twice")));
            }
            if spec.endpoints.is_empty() && settings.config_file.is_none() {
                return Err(bad(format!(
                    "--follow {name}: no endpoint (NAME=ENDPOINT, or --follow-config FILE)"
                )));
            }
            if settings.dir.is_some() && !crate::learn::usable_name(name) {
                return Err(bad(format!(
                    "--follow {name}: a followed map's name may hold letters, digits, '-', '_' and '.' only"
                )));
            }
            let base = registry.entries()[i].set.clone();
            let mut held = None;
            if let Some(dir) = &settings.dir {
                let mut skipped = Vec::new();
                let found = newest_snapshot(dir, name, |s| same_shape(&base, s), &mut skipped);
                for s in skipped {
                    warn!(map = %name, "followed snapshot skipped: {s}");
                }
                if let Some((set, saved)) = found {
                    policy.prepare(name, &set);
                    info!(map = %name, version = saved.version, "serving the newest followed snapshot");
                    registry.swap_learned(i, set, saved.version, settings.keep_versions);
                    held = Some(saved.version);
                }
            }
            let mut config = cliff_client::zenoh::client_config(
                &spec.endpoints,
                settings.config_file.as_deref(),
            )
            .map_err(|e| bad(format!("--follow {name}: {e}")))?;
            if super::uses_tls_link(&config) {
                warn!("{}", super::tls_link_warning(&format!("--follow {name}")));
            }
            // a reply holds the snapshot: room for the bound and the header
            let rx_max = settings
                .max_bytes
                .saturating_add(map_wire::MAP_HEADER_BYTES + 4096);
            config
                .insert_json5("transport/link/rx/max_message_size", &rx_max.to_string())
                .map_err(|e| bad(format!("--follow {name}: zenoh config: {e}")))?;
            let key =
                zenoh::key_expr::KeyExpr::try_from(map_wire::map_key_for(&settings.service, name))
                    .map_err(|e| bad(format!("--follow {name}: zenoh key: {e}")))?;
            entries.push(i);
            plans.push(Thread {
                name: name.clone(),
                index: plans.len(),
                config,
                key,
                base,
                held,
                policy: policy.clone(),
                settings: settings.clone(),
            });
        }
        let slots: Arc<Vec<Slot>> = Arc::new(entries.iter().map(|_| Mutex::new(None)).collect());
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(Counters::default());
        let mut threads = Vec::new();
        for plan in plans {
            let (slots, stop, counters) = (slots.clone(), stop.clone(), counters.clone());
            let t = std::thread::Builder::new()
                .name(format!("cliffd-follow-{}", plan.index))
                .spawn(move || plan.run(&slots, &stop, &counters))
                .map_err(|e| bad(format!("cannot start a follow thread: {e}")))?;
            threads.push(t);
        }
        Ok(Following {
            entries,
            slots,
            stop,
            counters,
            threads,
            keep: settings.keep_versions,
        })
    }

    /// Between requests: swap in the versions taken.
    pub(crate) fn housekeeping(&mut self, registry: &mut Registry) {
        for (slot, &entry) in self.slots.iter().zip(&self.entries) {
            let Ok(mut slot) = slot.try_lock() else {
                continue; // the thread is handing one over: next time
            };
            if let Some((version, set)) = slot.take() {
                registry.swap_learned(entry, set, version, self.keep);
            }
        }
    }

    /// Whether the map `name` is followed.
    pub(crate) fn follows(&self, registry: &Registry, name: &str) -> bool {
        self.entries
            .iter()
            .any(|&i| registry.entries()[i].name == name)
    }

    /// What following counted so far.
    pub fn stats(&self) -> FollowStats {
        FollowStats {
            taken: self.counters.taken.load(Ordering::Relaxed),
            refused: self.counters.refused.load(Ordering::Relaxed),
            unanswered: self.counters.unanswered.load(Ordering::Relaxed),
        }
    }
}

impl Drop for Following {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// One followed map's thread.
struct Thread {
    name: String,
    index: usize,
    config: zenoh::Config,
    key: zenoh::key_expr::KeyExpr<'static>,
    base: MapSet,
    held: Option<u32>,
    policy: TablePolicy,
    settings: FollowSettings,
}

/// What one question to the site gave.
enum Asked {
    /// A version to serve.
    Taken(u32, MapSet),
    /// The site serves the version held.
    Current,
    /// No answer (the site is away, or access control keeps this daemon out).
    Unanswered,
    /// An answer that was not taken, with why.
    Refused(String),
}

impl Thread {
    fn run(mut self, slots: &[Slot], stop: &AtomicBool, counters: &Counters) {
        let mut session: Option<zenoh::Session> = None;
        let mut away = false;
        while !stop.load(Ordering::Relaxed) {
            if session.is_none() {
                match zenoh::open(self.config.clone()).wait() {
                    Ok(s) => session = Some(s),
                    Err(e) => {
                        if !away {
                            warn!(map = %self.name, "the site is away ({e}); serving version {:?} until it answers", self.held);
                            away = true;
                        }
                        counters.unanswered.fetch_add(1, Ordering::Relaxed);
                        pause(self.settings.every, stop);
                        continue;
                    }
                }
            }
            let s = session.as_ref().expect("opened above");
            match self.ask(s) {
                Asked::Taken(version, set) => {
                    away = false;
                    self.take(version, set, &slots[self.index]);
                    counters.taken.fetch_add(1, Ordering::Relaxed);
                }
                Asked::Current => {
                    if away {
                        info!(map = %self.name, "the site answers again");
                        away = false;
                    }
                }
                Asked::Unanswered => {
                    if !away {
                        warn!(map = %self.name, "the site does not answer; serving version {:?} until it does", self.held);
                        away = true;
                    }
                    counters.unanswered.fetch_add(1, Ordering::Relaxed);
                }
                Asked::Refused(why) => {
                    warn!(map = %self.name, "map version from the site refused: {why}");
                    counters.refused.fetch_add(1, Ordering::Relaxed);
                }
            }
            pause(self.settings.every, stop);
        }
    }

    /// Ask the site for the version it serves, and check what comes.
    fn ask(&self, session: &zenoh::Session) -> Asked {
        let replies = match session
            .get(&self.key)
            .payload(ZBytes::from(map_wire::encode_map_query(self.held)))
            .consolidation(ConsolidationMode::None)
            .timeout(self.settings.timeout)
            .wait()
        {
            Ok(r) => r,
            Err(e) => return Asked::Refused(format!("cannot send the query: {e}")),
        };
        let Ok(reply) = replies.recv() else {
            return Asked::Unanswered;
        };
        let sample = match reply.into_result() {
            Ok(s) => s,
            Err(e) => {
                let text = e.payload().to_bytes();
                return match String::from_utf8_lossy(&text) {
                    t if t.eq_ignore_ascii_case("timeout") => Asked::Unanswered,
                    t => Asked::Refused(format!("error reply: {t}")),
                };
            }
        };
        // the size is bounded by the link's largest message before anything is read
        let bytes = sample.payload().to_bytes();
        let (h, snapshot) = match map_wire::decode_map_reply(&bytes, self.settings.max_bytes) {
            Ok(r) => r,
            Err(e) => return Asked::Refused(e.to_string()),
        };
        match h.status {
            MapStatus::Current => Asked::Current,
            MapStatus::UnknownMap => {
                Asked::Refused(format!("the site serves no map '{}'", self.name))
            }
            MapStatus::Newer => {
                let source = format!("{} version {} from the site", self.name, h.version);
                match MapSet::from_snapshot_bytes(snapshot, &source)
                    .map_err(|e| e.to_string())
                    .and_then(|set| same_shape(&self.base, &set).map(|()| set))
                {
                    Ok(set) => Asked::Taken(h.version, set),
                    Err(e) => Asked::Refused(e),
                }
            }
        }
    }

    /// Prepare a version taken, write it to the directory, and hand it to the serving
    /// loop.
    fn take(&mut self, version: u32, set: MapSet, slot: &Slot) {
        let started = Instant::now();
        self.policy.prepare(&self.name, &set);
        if let Some(dir) = &self.settings.dir {
            let saved = Saved {
                version,
                rows: 0,
                count_scales: Vec::new(),
            };
            if let Err(e) = write_snapshot(dir, &self.name, &set, &saved) {
                warn!(map = %self.name, version, "followed snapshot not written: {e}");
            }
        }
        *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some((version, set));
        self.held = Some(version);
        info!(
            map = %self.name,
            version,
            prepared_ms = started.elapsed().as_secs_f64() * 1e3,
            "took the site's version"
        );
    }
}

/// Sleep `d`, waking early when `stop` is set.
fn pause(d: Duration, stop: &AtomicBool) {
    let end = Instant::now() + d;
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now >= end {
            return;
        }
        std::thread::sleep((end - now).min(Duration::from_millis(50)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follow_specs_name_a_map_and_its_endpoints() {
        let s: FollowSpec = "atc=tcp/10.0.0.1:7447,tls/site:7447".parse().unwrap();
        assert_eq!(s.name, "atc");
        assert_eq!(s.endpoints, ["tcp/10.0.0.1:7447", "tls/site:7447"]);
        let s: FollowSpec = "atc".parse().unwrap();
        assert!(s.endpoints.is_empty());
        assert!("=tcp/x:1".parse::<FollowSpec>().is_err());
    }
}
