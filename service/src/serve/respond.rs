//! Responses out: the response header, rejections and the responses of finished
//! predictions (shared memory or zenoh), and waking the clients that wait for them.

use std::time::Duration;

use cliff_client::protocol::{
    FLAG_SCORES, Field, PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader, Status,
};
use iceoryx2::prelude::*;
use tracing::debug;

use crate::scheduler::Finished;

use super::daemon::Daemon;
use super::output::Out;
use super::ports::Active;
use super::stats::Stats;

impl Daemon {
    pub(super) fn reject(&mut self, req: &Active, h: &RequestHeader, rej: Rejection) {
        debug!(request_id = h.request_id, "rejected: {rej}");
        self.stats.rejected += 1;
        let mut rh = response_header(h, self.settings.idle_spin);
        rej.write_to(&mut rh);
        let sent = send_empty(req, rh);
        self.after_send(h, sent);
    }

    /// Send the responses of finished requests.
    pub(super) fn send_finished(&mut self) {
        if !self.scheduler.has_finished() {
            return; // (the loop polls this on every pass)
        }
        // Other clients that compete for the cores: when the clients connected (and the
        // daemon) outnumber the cores, a spinning client takes a core the daemon needs.
        let clients = self.service.dynamic_config().number_of_clients();
        let crowd = if clients > 1 && clients >= self.cores {
            clients - 1
        } else {
            0
        };
        let Self {
            scheduler,
            stats,
            wakeups,
            settings,
            #[cfg(feature = "zenoh")]
            remote,
            ..
        } = self;
        scheduler.take_finished(|f: Finished<'_, Out>| {
            let h = f.header;
            let mut rh = response_header(h, settings.idle_spin);
            if f.ok {
                rh.agents = f.agents as u32;
                rh.k = f.params.k as u32;
                rh.steps = f.params.steps() as u32;
                rh.flags = if f.scores { FLAG_SCORES } else { 0 };
                // ResponseHeader::busy
                rh.limit = (f.others + crowd).min(u32::MAX as usize) as u32;
                stats.served += 1;
            } else {
                stats.rejected += 1;
                internal().write_to(&mut rh);
            }
            match f.output {
                Out::Ipc {
                    request,
                    mut response,
                } => {
                    let sent = if f.ok {
                        // (written when the request was accepted)
                        rh.map_version = response.user_header().map_version;
                        *response.user_header_mut() = rh;
                        response.send().map_err(|e| format!("{e:?}"))
                    } else {
                        drop(response);
                        send_empty(&request, rh)
                    };
                    count_failure(stats, h, sent);
                    wakeups.notify(h);
                    // dropping the active request ends it
                }
                #[cfg(feature = "zenoh")]
                Out::Remote {
                    reply,
                    words,
                    map_version,
                } => {
                    // remote clients do not see the daemon's wake state
                    rh.awake_us = 0;
                    if f.ok {
                        rh.map_version = map_version;
                    }
                    let payload: &[u32] = if f.ok { &words } else { &[] };
                    if !reply.reply(&rh, payload) {
                        stats.failed += 1;
                    }
                    if let Some(r) = remote.as_mut() {
                        r.buffers.push(words);
                    }
                }
            }
        });
    }

    pub(super) fn after_send(&mut self, h: &RequestHeader, sent: Result<(), String>) {
        count_failure(&mut self.stats, h, sent);
        self.wakeups.notify(h);
    }
}

/// Count (and log) a response that could not be sent.
fn count_failure(stats: &mut Stats, h: &RequestHeader, sent: Result<(), String>) {
    if let Err(e) = sent {
        stats.failed += 1;
        debug!(
            request_id = h.request_id,
            "response not sent (client gone?): {e}"
        );
    }
}

/// A response header for request `h`; `awake` is how long the daemon keeps polling
/// after answering (see [`ResponseHeader::awake_us`]).
pub(super) fn response_header(h: &RequestHeader, awake: Duration) -> ResponseHeader {
    ResponseHeader {
        version: PROTOCOL_VERSION,
        request_id: h.request_id,
        awake_us: awake.as_micros().min(u32::MAX as u128) as u32,
        ..ResponseHeader::default()
    }
}

/// A rejection with status `internal` and no field: the base that others fill in.
pub(super) fn internal() -> Rejection {
    Rejection {
        status: Status::Internal,
        agent: None,
        row: None,
        field: Field::None,
        limit: 0,
    }
}

/// Send the empty response `rh` (a rejection, a reload answer) to `req`.
pub(super) fn send_empty(req: &Active, rh: ResponseHeader) -> Result<(), String> {
    let resp = req.loan_slice_uninit(0).map_err(|e| format!("{e:?}"))?;
    let mut resp = resp.write_from_fn(|_| 0u32);
    *resp.user_header_mut() = rh;
    resp.send().map_err(|e| format!("{e:?}"))
}
