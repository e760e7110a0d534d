//! Answering clients of protocol version 1 with `bad-version`.

use cliff_client::legacy;
use cliff_client::protocol::RequestHeader;
use tracing::{debug, warn};

use super::daemon::Daemon;

impl Daemon {
    /// Answer every request waiting on protocol version 1's service with
    /// `bad-version` (the daemon's version in `limit`); true when there was one. The run
    /// loop calls this every 2 ms while it polls, and after every wake-up from sleep.
    pub fn answer_old_clients(&mut self) -> bool {
        let mut any = false;
        loop {
            let req = match self.legacy_server.receive() {
                Ok(Some(req)) => req,
                Ok(None) => return any,
                Err(e) => {
                    warn!("receiving requests of protocol version 1 failed: {e:?}");
                    return any;
                }
            };
            any = true;
            let h = *req.user_header();
            debug!(
                request_id = h.request_id,
                version = h.version,
                "request of an old client: answered bad-version"
            );
            self.stats.rejected += 1;
            self.stats.old_clients += 1;
            let sent = req
                .loan_slice_uninit(0)
                .map_err(|e| format!("{e:?}"))
                .and_then(|r| {
                    let mut r = r.write_from_fn(|_| 0u32);
                    *r.user_header_mut() = legacy::bad_version_response(h.request_id);
                    r.send().map_err(|e| format!("{e:?}"))
                });
            if let Err(e) = sent {
                self.stats.failed += 1;
                debug!(request_id = h.request_id, "response not sent: {e}");
            }
            // a version 1 client waiting on the response event: the listener id sits where
            // it always did
            let woken = RequestHeader {
                listener_id: h.listener_id,
                ..RequestHeader::default()
            };
            self.wakeups.notify(&woken);
        }
    }
}
