//! Waking a client that sleeps on the response event ([`Wakeups`]).

use cliff_client::protocol::RequestHeader;
use iceoryx2::port::notifier::{ListenerKey, Notifier};
use iceoryx2::prelude::*;

/// Wakes the client that sent a request (clients may sleep on their own event).
pub(super) struct Wakeups {
    pub(super) notifier: Notifier<ipc::Service>,
    pub(super) keys: Vec<(u128, ListenerKey)>,
}

impl Wakeups {
    pub(super) fn notify(&mut self, h: &RequestHeader) {
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
