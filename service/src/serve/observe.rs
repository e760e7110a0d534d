//! Observe requests ([`KIND_OBSERVE`](cliff_client::protocol::KIND_OBSERVE)): checked,
//! handed to the learning intake (bounded work on the serving thread, never a wait for
//! the learner) and answered at once with the counts.

use cliff_client::protocol::{
    self, Field, Observation, ObserveReply, Rejection, RequestHeader, Status,
};
use tracing::debug;

use crate::learn::{ClientKey, Learning};
use crate::registry::Registry;

use super::daemon::Daemon;
use super::ports::Active;
use super::respond::{internal, response_header, send_empty};

impl Daemon {
    /// Answer an observe request from a local client.
    pub(super) fn accept_observe(&mut self, req: Active) {
        let h = *req.user_header();
        let client: ClientKey = req.origin().value();
        match observe(
            &mut self.learning,
            &self.registry,
            client,
            &h,
            req.payload(),
        ) {
            Ok(reply) => {
                self.stats.served += 1;
                let mut rh = response_header(&h, self.settings.idle_spin);
                reply.write_to(&mut rh);
                let sent = send_empty(&req, rh);
                self.after_send(&h, sent);
            }
            Err(rej) => self.reject(&req, &h, rej),
        }
    }
}

/// Check an observe request from `client` and take its rows: the counts, or why not.
pub(super) fn observe(
    learning: &mut Option<Learning>,
    registry: &Registry,
    client: ClientKey,
    h: &RequestHeader,
    rows: &[Observation],
) -> Result<ObserveReply, Rejection> {
    let Some(learning) = learning.as_mut() else {
        // a daemon that learns nothing: the map decides the status
        return Err(match registry.find(&h.map) {
            Some(_) => Rejection {
                status: Status::NotLearning,
                field: Field::Map,
                ..internal()
            },
            None => Rejection {
                status: Status::UnknownMap,
                field: Field::Map,
                ..internal()
            },
        });
    };
    protocol::validate_observe(h, rows, learning.max_observe_rows())?;
    let Some(entry) = registry.find(&h.map) else {
        return Err(Rejection {
            status: Status::UnknownMap,
            field: Field::Map,
            ..internal()
        });
    };
    let r = learning.observe(client, h.request_id, entry, rows);
    if let Err(rej) = &r {
        debug!(request_id = h.request_id, "observation refused: {rej}");
    }
    r
}

/// The client key of a remote observe request: its zenoh session (the querier's id, as
/// the session's requests in flight are counted), in keys of their own (the top bit set),
/// apart from local clients' port ids. Budgets, duplicates and the guards' shares hold
/// per session, as per local client.
#[cfg(feature = "zenoh")]
pub(super) fn remote_client(session: u128) -> ClientKey {
    (1u128 << 127) | session
}
