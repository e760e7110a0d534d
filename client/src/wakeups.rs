//! Waking a client that sleeps on the response event ([`Wakeups`]): what a server
//! (cliffd, or cliff-bench's transport floor) does after it answers a request.

use iceoryx2::port::notifier::{ListenerKey, Notifier};
use iceoryx2::prelude::*;

use crate::protocol::RequestHeader;

/// Wakes the client that sent a request, when it sleeps on the response event (the
/// listener it named in the request). Remembers up to `capacity` clients' listeners.
pub struct Wakeups {
    notifier: Notifier<ipc::Service>,
    keys: Vec<(u128, ListenerKey)>,
}

impl std::fmt::Debug for Wakeups {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wakeups")
            .field("known", &self.keys.len())
            .finish_non_exhaustive()
    }
}

impl Wakeups {
    /// Wake through `notifier`, remembering up to `capacity` listeners (allocated here,
    /// once).
    pub fn new(notifier: Notifier<ipc::Service>, capacity: usize) -> Wakeups {
        Wakeups {
            notifier,
            keys: Vec::with_capacity(capacity.max(1)),
        }
    }

    /// Forget every remembered listener (clients that left).
    pub fn forget(&mut self) {
        self.keys.clear();
    }

    /// Wake the client that sent `h`, if it named a listener.
    pub fn notify(&mut self, h: &RequestHeader) {
        let id = (h.listener_id[0] as u128) | ((h.listener_id[1] as u128) << 64);
        if id == 0 {
            return;
        }
        if let Some(i) = self.keys.iter().position(|(l, _)| *l == id) {
            if self
                .notifier
                .notify_single_listener(&self.keys[i].1)
                .is_ok()
            {
                return;
            }
            self.keys.swap_remove(i);
        }
        let mut found = None;
        self.notifier.for_each_listener(|m, d| {
            if d.listener_id.value() == id {
                let _ = m.notify();
                found = Some(m.listener_key());
                CallbackProgression::Stop
            } else {
                CallbackProgression::Continue
            }
        });
        if let Some(key) = found {
            if self.keys.len() == self.keys.capacity() {
                self.keys.clear(); // forget clients that left
            }
            self.keys.push((id, key));
        }
    }
}
