//! The versions of the maps served, for daemons that follow them ([`MapServer`]): a
//! queryable on `SERVICE/maps/*` answered by a thread of its own
//! (`cliffd-zenoh-maps`) with the map's newest version as snapshot bytes
//! ([`cliff_client::map_wire`]).
//!
//! The serving loop only hands each new version over ([`MapServer::publish`]: a short
//! lock, the set's `Arc`s cloned); the thread encodes the snapshot once per version, off
//! the serving loop, and answers one query at a time. Queries beyond the few that may
//! wait ([`WAITING`]) get no reply (a follower asks again).

use std::sync::mpsc::{Receiver, sync_channel};
use std::sync::{Arc, Mutex, MutexGuard};

use cliff::map::MapSet;
use cliff_client::map_wire::{self, MapStatus};
use tracing::{debug, warn};
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::query::{Query, Queryable};

use crate::settings::StartError;

/// Map queries that may wait for the map thread; more get no reply.
pub const WAITING: usize = 8;

/// One map as published.
struct Published {
    name: String,
    version: u32,
    set: MapSet,
    /// The snapshot bytes of `version`, once a query asked for them.
    bytes: Option<Arc<Vec<u8>>>,
}

/// Serves the newest version of every map to followers (see the module docs).
pub struct MapServer {
    maps: Arc<Mutex<Vec<Published>>>,
    _queryable: Queryable<()>,
}

impl std::fmt::Debug for MapServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MapServer").finish_non_exhaustive()
    }
}

fn lock(m: &Mutex<Vec<Published>>) -> MutexGuard<'_, Vec<Published>> {
    // every change is one assignment: a poisoned lock holds a consistent list
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl MapServer {
    /// Answer map queries on `service`'s map keys ([`map_wire::map_key_for`]) in
    /// `session`, starting with `maps` (name, version, set).
    pub fn start(
        session: &zenoh::Session,
        service: &str,
        maps: Vec<(String, u32, MapSet)>,
    ) -> Result<MapServer, StartError> {
        let prefix = map_wire::map_key_for(service, "");
        let maps = Arc::new(Mutex::new(
            maps.into_iter()
                .map(|(name, version, set)| Published {
                    name,
                    version,
                    set,
                    bytes: None,
                })
                .collect::<Vec<_>>(),
        ));
        let (tx, rx) = sync_channel::<Query>(WAITING);
        let shared = Arc::clone(&maps);
        let answered_prefix = prefix.clone();
        std::thread::Builder::new()
            .name("cliffd-zenoh-maps".into())
            .spawn(move || answer(rx, &shared, &answered_prefix))
            .map_err(|e| StartError::Zenoh(format!("cannot start a thread: {e}")))?;
        let queryable = session
            .declare_queryable(format!("{prefix}*"))
            .callback(move |query: Query| {
                // never block zenoh's thread: a query without room gets no reply
                let _ = tx.try_send(query);
            })
            .wait()
            .map_err(|e| StartError::Zenoh(format!("cannot declare the map queryable: {e}")))?;
        Ok(MapServer {
            maps,
            _queryable: queryable,
        })
    }

    /// Serve `set` as version `version` of the map `name` (nothing changes when that
    /// version is published already).
    pub fn publish(&self, name: &str, version: u32, set: &MapSet) {
        let mut maps = lock(&self.maps);
        match maps.iter_mut().find(|m| m.name == name) {
            Some(m) if m.version == version => {}
            Some(m) => {
                m.version = version;
                m.set = set.clone();
                m.bytes = None;
            }
            None => maps.push(Published {
                name: name.to_string(),
                version,
                set: set.clone(),
                bytes: None,
            }),
        }
    }
}

/// The map thread: answer each query with the version its map serves.
fn answer(rx: Receiver<Query>, maps: &Mutex<Vec<Published>>, prefix: &str) {
    let mut out = Vec::new();
    while let Ok(query) = rx.recv() {
        let name = query
            .key_expr()
            .as_str()
            .strip_prefix(prefix)
            .unwrap_or("")
            .to_string();
        let held = query
            .payload()
            .and_then(|p| map_wire::decode_map_query(&p.to_bytes()));
        let found = {
            let maps = lock(maps);
            maps.iter()
                .find(|m| m.name == name)
                .map(|m| (m.version, m.set.clone(), m.bytes.clone()))
        };
        match found {
            None => map_wire::encode_map_reply(MapStatus::UnknownMap, 0, &[], &mut out),
            Some((version, _, _)) if held == Some(version) => {
                map_wire::encode_map_reply(MapStatus::Current, version, &[], &mut out)
            }
            Some((version, set, bytes)) => {
                let bytes = bytes.unwrap_or_else(|| {
                    // encoded here, once per version, off the serving loop
                    let b = Arc::new(set.to_snapshot_bytes());
                    let mut maps = lock(maps);
                    if let Some(m) = maps
                        .iter_mut()
                        .find(|m| m.name == name && m.version == version)
                    {
                        m.bytes = Some(Arc::clone(&b));
                    }
                    b
                });
                debug!(map = %name, version, bytes = bytes.len(), "map version sent");
                map_wire::encode_map_reply(MapStatus::Newer, version, &bytes, &mut out);
            }
        }
        // zenoh takes the buffer over
        let reply = ZBytes::from(std::mem::take(&mut out));
        if let Err(e) = query.reply(query.key_expr().clone(), reply).wait() {
            warn!(map = %name, "map reply failed: {e}");
        }
    }
}
