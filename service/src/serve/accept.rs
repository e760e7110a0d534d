//! Requests in: validation against the loaded maps and limits, rejections, and handing
//! accepted requests (local and remote) to the scheduler.

use std::sync::Arc;

use cliff::map::CliffMap;
use cliff_client::protocol::{
    self, Decoded, Field, KIND_RELOAD, Limits, Observation, PROTOCOL_VERSION, Rejection,
    RequestHeader, Status,
};
#[cfg(feature = "zenoh")]
use tracing::debug;
use tracing::{info, warn};

use crate::registry::{self, Pick, Registry};

use super::daemon::Daemon;
use super::output::Out;
use super::ports::Active;
use super::respond::internal;

impl Daemon {
    /// Take the remote requests waiting now (as many as there are free slots): reject
    /// or hand them to the scheduler with a reused buffer; true when there was one.
    #[cfg(feature = "zenoh")]
    pub(super) fn accept_remote(&mut self) -> bool {
        let Some(remote) = self.remote.as_mut() else {
            return false;
        };
        let mut any = false;
        while let Some(slot) = self.scheduler.free_slot() {
            let Some(req) = remote.frontend.try_next() else {
                break;
            };
            any = true;
            let h = *req.header();
            let observing = h.version == PROTOCOL_VERSION && h.kind == protocol::KIND_OBSERVE;
            if observing != req.on_observe_key() && h.version == PROTOCOL_VERSION {
                // observations only on the observe key (which access control may close),
                // and nothing else there
                let status = if observing {
                    Status::NotAllowed
                } else {
                    Status::UnknownKind
                };
                debug!(
                    request_id = h.request_id,
                    "remote request on the wrong key: {status}"
                );
                self.stats.rejected += 1;
                let rej = Rejection {
                    status,
                    ..internal()
                };
                if !req.reject(&rej) {
                    self.stats.failed += 1;
                }
                continue;
            }
            if observing {
                let client = super::observe::remote_client(req.session());
                let answer = super::observe::observe(
                    &mut self.learning,
                    &self.registry,
                    client,
                    &h,
                    req.rows(),
                );
                let sent = match answer {
                    Ok(reply) => {
                        self.stats.served += 1;
                        let mut rh = super::respond::response_header(&h, Default::default());
                        reply.write_to(&mut rh);
                        req.reply(&rh, &[])
                    }
                    Err(rej) => {
                        self.stats.rejected += 1;
                        req.reject(&rej)
                    }
                };
                if !sent {
                    self.stats.failed += 1;
                }
                continue;
            }
            slot.header = h;
            let decoded = decode(
                &self.registry,
                &self.settings.limits,
                &h,
                req.rows(),
                &mut slot.scratch,
            );
            let (map, decoded) = match decoded {
                Ok(d) => d,
                Err(rej) => {
                    debug!(request_id = h.request_id, "remote request rejected: {rej}");
                    self.stats.rejected += 1;
                    if !req.reject(&rej) {
                        self.stats.failed += 1;
                    }
                    continue;
                }
            };
            let agents = slot.scratch.states().len();
            let mut words = remote.buffers.pop().unwrap_or_default();
            words.clear();
            words.resize(decoded.payload_words(agents), 0);
            let (map, map_version) = map_for(&mut self.registry, map, &decoded);
            let reply = req.into_pending();
            self.scheduler.admit(
                map,
                &decoded,
                Out::Remote {
                    reply,
                    words,
                    map_version,
                },
            );
        }
        any
    }

    /// Validate a request and either answer it (rejection, reload) or hand it to the
    /// scheduler with its loaned response.
    pub(super) fn accept(&mut self, req: Active) {
        let h = *req.user_header();
        if h.version == PROTOCOL_VERSION && h.kind == protocol::KIND_OBSERVE {
            return self.accept_observe(req);
        }
        if h.version == PROTOCOL_VERSION && h.kind == KIND_RELOAD {
            info!(request_id = h.request_id, "reload request");
            let generation = self.registry.request_reload();
            self.reload_waiters.push((generation, req));
            return;
        }
        let Some(slot) = self.scheduler.free_slot() else {
            return; // the caller checked; dropping the request would end it unanswered
        };
        slot.header = h;
        let decoded = decode(
            &self.registry,
            &self.settings.limits,
            &h,
            req.payload(),
            &mut slot.scratch,
        );
        let (map, decoded) = match decoded {
            Ok(d) => d,
            Err(rej) => return self.reject(&req, &h, rej),
        };
        let agents = slot.scratch.states().len();
        let words = decoded.payload_words(agents);
        let mut response = match req.loan_slice_uninit(words) {
            Ok(r) => r.write_from_fn(|_| 0u32),
            Err(e) => {
                warn!(
                    request_id = h.request_id,
                    words, "cannot loan a response: {e:?}"
                );
                return self.reject(&req, &h, internal());
            }
        };
        let (map, version) = map_for(&mut self.registry, map, &decoded);
        response.user_header_mut().map_version = version;
        self.scheduler.admit(
            map,
            &decoded,
            Out::Ipc {
                request: req,
                response,
            },
        );
    }
}

/// The map an accepted request on map entry `entry` runs on
/// ([`registry::map_for_request`]: the version served now, the base map when the
/// request pins it, or the version it names) and its version, its neighbour table asked
/// for.
fn map_for(
    registry: &mut Registry,
    (entry, pick): (usize, Pick),
    decoded: &Decoded,
) -> (Arc<CliffMap>, u32) {
    let e = &registry.entries()[entry];
    // (decode checked that the entry holds the version)
    let (map, version) = registry::map_for_request(e, decoded.map_time, pick)
        .unwrap_or_else(|| registry::served_map(e, decoded.map_time));
    let map = Arc::clone(map);
    if uses_map(decoded) {
        registry.want_table(&map, decoded.params.radius);
    }
    (map, version)
}

/// Whether a request looks up the map at its radius: every method but constant
/// velocity, and constant velocity when it scores its samples.
fn uses_map(d: &Decoded) -> bool {
    d.params.method.samples_map() || d.options.scores
}

/// Validate a request against the loaded maps, the versions they hold, their radius
/// limits and the limits; the map entry's index, the version asked for and the decoded
/// request.
fn decode(
    registry: &Registry,
    limits: &Limits,
    h: &RequestHeader,
    rows: &[Observation],
    scratch: &mut protocol::DecodeScratch,
) -> Result<((usize, Pick), Decoded), Rejection> {
    // the version and the kind are checked before anything else is read (a reload
    // request, which names no map, that reaches this point over zenoh is `unknown-kind`)
    if h.version != PROTOCOL_VERSION || h.kind != protocol::KIND_PREDICT {
        return protocol::decode_request(h, rows, limits, scratch).map(|d| ((0, Pick::Served), d));
    }
    let Some((map, pick)) = registry.find_pick(&h.map) else {
        return Err(Rejection {
            status: Status::UnknownMap,
            field: Field::Map,
            ..internal()
        });
    };
    let entry = &registry.entries()[map];
    // the base-map flag pins the map as loaded, whatever the name asks for
    let pick = if h.flags & protocol::FLAG_BASE_MAP != 0 {
        Pick::Version(0)
    } else {
        pick
    };
    if registry::set_for(entry, pick).is_none() {
        return Err(Rejection {
            status: Status::UnknownVersion,
            field: Field::Map,
            limit: entry.version,
            ..internal()
        });
    }
    let decoded = protocol::decode_request(h, rows, limits, scratch)?;
    if uses_map(&decoded) && decoded.params.radius > entry.max_radius {
        return Err(Rejection {
            status: Status::RadiusTooLarge,
            field: Field::Radius,
            limit: entry.max_radius_mm(),
            ..internal()
        });
    }
    Ok(((map, pick), decoded))
}
