//! Observe requests ([`KIND_OBSERVE`](cliff_client::protocol::KIND_OBSERVE)): checked,
//! handed to the learning intake (bounded work on the serving thread, never a wait for
//! the learner) and answered at once with the counts.

use cliff_client::protocol::{self, Field, Observation, ObserveReply, Rejection, RequestHeader, Status};
use tracing::debug;

use crate::learn::ClientKey;

use super::daemon::Daemon;
use super::ports::Active;
use super::respond::{internal, response_header, send_empty};

impl Daemon {
    /// Answer an observe request from a local client.
    pub(super) fn accept_observe(&mut self, req: Active) {
        let h = *req.user_header();
        let client: ClientKey = req.origin().value();
        match self.observe(client, &h, req.payload()) {
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

    /// Check an observe request and take its rows: the counts, or why not.
    pub(super) fn observe(
        &mut self,
        client: ClientKey,
        h: &RequestHeader,
        rows: &[Observation],
    ) -> Result<ObserveReply, Rejection> {
        let Some(learning) = self.learning.as_mut() else {
            // a daemon that learns nothing: the map decides the status
            return Err(match self.registry.find(&h.map) {
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
        let Some(entry) = self.registry.find(&h.map) else {
            return Err(Rejection {
                status: Status::UnknownMap,
                field: Field::Map,
                ..internal()
            });
        };
        let r = learning.observe(client, entry, rows);
        if let Err(rej) = &r {
            debug!(request_id = h.request_id, "observation refused: {rej}");
        }
        r
    }
}
