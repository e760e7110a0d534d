//! The serving loop: poll (then sleep on the request event), serve what is waiting, and
//! the housekeeping between (reloads, dead clients, traffic log).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::prelude::*;
use tracing::{info, warn};

use super::daemon::Daemon;

/// After this long without requests, the busy-polling loop yields its core between polls.
const POLITE_AFTER: Duration = Duration::from_micros(50);

/// How often the daemon logs its traffic (when there was any).
const STATS_INTERVAL: Duration = Duration::from_secs(10);

/// How often the serving loop looks for requests of protocol version 1 (answered
/// `bad-version`): often enough for an old client's deadline, rarely enough to cost the
/// polling loop nothing.
const LEGACY_POLL: Duration = Duration::from_millis(2);

impl Daemon {
    /// Serve until `stop` is set. `reload` set (by SIGHUP) starts a map reload and is
    /// cleared.
    pub fn run(&mut self, stop: &AtomicBool, reload: &AtomicBool) {
        let mut last_activity = Instant::now();
        let mut next_housekeeping = last_activity;
        let mut next_cleanup = last_activity + self.settings.cleanup_interval;
        let mut next_report = last_activity + STATS_INTERVAL;
        let mut next_legacy = last_activity;
        let mut reported = self.stats;
        while !stop.load(Ordering::Relaxed) {
            let served = self.serve_pending();
            let now = Instant::now();
            if served {
                last_activity = now;
            }
            if now >= next_legacy {
                self.answer_old_clients();
                next_legacy = now + LEGACY_POLL;
            }
            if now >= next_housekeeping {
                if reload.swap(false, Ordering::Relaxed) {
                    info!("SIGHUP: reloading maps");
                    self.registry.request_reload();
                }
                self.poll_reload();
                if let Some(l) = self.learning.as_mut() {
                    l.housekeeping(&mut self.registry);
                }
                #[cfg(feature = "zenoh")]
                self.zenoh_housekeeping();
                if now >= next_cleanup {
                    self.cleanup_dead_nodes();
                    next_cleanup = now + self.settings.cleanup_interval;
                }
                if now >= next_report {
                    if self.stats != reported {
                        let s = self.stats;
                        info!(
                            served = s.served - reported.served,
                            rejected = s.rejected - reported.rejected,
                            old_clients = s.old_clients - reported.old_clients,
                            undelivered = s.failed - reported.failed,
                            clients = self.service.dynamic_config().number_of_clients(),
                            "requests in the last {} s",
                            STATS_INTERVAL.as_secs()
                        );
                        reported = s;
                    }
                    next_report = now + STATS_INTERVAL;
                }
                next_housekeeping = now + Duration::from_millis(50);
            }
            if !served {
                if now.duration_since(last_activity) >= self.settings.idle_spin {
                    // sleep until a client signals a request (or for housekeeping)
                    match self.wake.timed_wait(|_| {}, Duration::from_millis(50)) {
                        Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                        Err(e) => {
                            warn!("waiting on the request event failed: {e:?}");
                            std::thread::sleep(Duration::from_millis(1));
                        }
                    }
                    // the signal may have come from a client of protocol version 1
                    next_legacy = Instant::now();
                } else if now.duration_since(last_activity) >= POLITE_AFTER {
                    // let a client on this core run (oversubscribed hosts)
                    std::thread::yield_now();
                } else {
                    std::hint::spin_loop();
                }
            }
        }
        if let Some(l) = self.learning.as_mut() {
            // the open tracks are learned and the last snapshots written
            l.shutdown();
        }
        let s = self.stats();
        info!(
            served = s.served,
            rejected = s.rejected,
            failed = s.failed,
            parallel = s.parallel,
            "shutting down"
        );
    }

    /// Take the requests waiting now (as many as there are free slots), run one round
    /// of chunks and send the responses that are complete; true when there was work.
    pub fn serve_pending(&mut self) -> bool {
        let mut work = false;
        while self.scheduler.free_slot().is_some() {
            match self.server.receive() {
                Ok(Some(req)) => {
                    work = true;
                    self.accept(req);
                }
                Ok(None) => break,
                Err(e) => {
                    warn!("receiving requests failed: {e:?}");
                    break;
                }
            }
        }
        #[cfg(feature = "zenoh")]
        {
            work |= self.accept_remote();
        }
        if self.scheduler.busy() {
            self.scheduler.run_round();
            work = true;
        }
        self.send_finished();
        work
    }
}
