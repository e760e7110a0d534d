//! Map reloads: starting one, and answering the reload requests once it is done.

use cliff_client::protocol::{Rejection, Status};

use super::daemon::Daemon;
use super::respond::{internal, response_header, send_empty};

impl Daemon {
    /// Start reloading every map from its file in a background thread (no-op for the
    /// built-in scene). A reload already running is followed by another one.
    pub fn start_reload(&mut self) {
        self.registry.request_reload();
    }

    /// Apply a finished reload, if any, and answer the reload requests that arrived
    /// before it started; true when one was applied.
    pub fn poll_reload(&mut self) -> bool {
        let Some((generation, error)) = self.registry.poll_reload() else {
            return false;
        };
        let mut i = 0;
        while i < self.reload_waiters.len() {
            if self.reload_waiters[i].0 > generation {
                i += 1;
                continue;
            }
            let (_, req) = self.reload_waiters.swap_remove(i);
            let h = *req.user_header();
            let mut rh = response_header(&h, self.settings.idle_spin);
            if error.is_some() {
                Rejection {
                    status: Status::ReloadFailed,
                    ..internal()
                }
                .write_to(&mut rh);
            }
            let _ = send_empty(&req, rh);
            self.wakeups.notify(&h);
        }
        true
    }
}
