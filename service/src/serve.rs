//! The serving loop: iceoryx2 ports, requests in, responses out, housekeeping.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff_client::protocol::{
    self, Decoded, FLAG_SCORES, Field, KIND_RELOAD, Limits, Observation, PROTOCOL_VERSION,
    Rejection, RequestHeader, ResponseHeader, Status,
};
use cliff_client::{PredictService, legacy, request_event_name, response_event_name};
use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::{ListenerKey, Notifier};
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;
use tracing::{debug, info, warn};

use crate::registry::{self, Registry, TablePolicy};
use crate::scheduler::{Finished, Output, Scheduler};
use crate::settings::{Settings, StartError};

/// After this long without requests, the busy-polling loop yields its core between polls.
const POLITE_AFTER: Duration = Duration::from_micros(50);

/// How often the daemon logs its traffic (when there was any).
const STATS_INTERVAL: Duration = Duration::from_secs(10);

/// How often the serving loop looks for requests of protocol version 1 (answered
/// `bad-version`): often enough for an old client's deadline, rarely enough to cost the
/// polling loop nothing.
const LEGACY_POLL: Duration = Duration::from_millis(2);

type Port = Server<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
type LegacyPort = Server<
    ipc::Service,
    [legacy::Observation],
    legacy::RequestHeader,
    [u32],
    legacy::ResponseHeader,
>;
type LegacyService = iceoryx2::service::port_factory::request_response::PortFactory<
    ipc::Service,
    [legacy::Observation],
    legacy::RequestHeader,
    [u32],
    legacy::ResponseHeader,
>;
type Active = ActiveRequest<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
type Response = iceoryx2::response_mut::ResponseMut<ipc::Service, [u32], ResponseHeader>;

/// Where a request's prediction goes: straight into its loaned shared-memory response,
/// or (a remote request over zenoh) into a buffer encoded into the reply.
enum Out {
    Ipc {
        request: Active,
        response: Response,
    },
    #[cfg(feature = "zenoh")]
    Remote {
        reply: crate::zenoh::PendingReply,
        words: Vec<u32>,
    },
}

impl Output for Out {
    #[inline]
    fn words(&mut self) -> &mut [u32] {
        match self {
            Out::Ipc { response, .. } => response.payload_mut(),
            #[cfg(feature = "zenoh")]
            Out::Remote { words, .. } => words,
        }
    }
}

/// The zenoh frontend and the payload buffers of remote requests (reused).
#[cfg(feature = "zenoh")]
struct Remote {
    frontend: crate::zenoh::ZenohFrontend,
    buffers: Vec<Vec<u32>>,
}

/// Counters of a running daemon.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Requests answered with a batch.
    pub served: u64,
    /// Requests answered with a rejection.
    pub rejected: u64,
    /// Responses that could not be sent (client gone, memory exhausted).
    pub failed: u64,
    /// Requests of protocol version 1 (answered `bad-version`; counted in `rejected`).
    pub old_clients: u64,
    /// Completed map reloads.
    pub reloads: u64,
    /// Chunks predicted in parallel with others (with more than one worker).
    pub parallel: u64,
}

/// Wakes the client that sent a request (clients may sleep on their own event).
struct Wakeups {
    notifier: Notifier<ipc::Service>,
    keys: Vec<(u128, ListenerKey)>,
}

impl Wakeups {
    fn notify(&mut self, h: &RequestHeader) {
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

/// The prediction daemon: maps, iceoryx2 ports and the scheduler.
pub struct Daemon {
    settings: Settings,
    registry: Registry,
    scheduler: Scheduler<Out>,
    // ports before services before node (drop order)
    server: Port,
    /// Protocol version 1's service, where every request gets `bad-version`.
    legacy_server: LegacyPort,
    wake: Listener<ipc::Service>,
    wakeups: Wakeups,
    service: PredictService,
    _legacy_service: LegacyService,
    _wake_service: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    _response_events: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    node: Node<ipc::Service>,
    /// Reload requests and the reload generation that answers each.
    reload_waiters: Vec<(u64, Active)>,
    stats: Stats,
    /// Cores of this host (for the busy hint of responses).
    cores: usize,
    /// Remote clients over zenoh, once [`Daemon::serve_zenoh`] started them.
    #[cfg(feature = "zenoh")]
    remote: Option<Remote>,
}

fn ipc(what: &str, e: impl std::fmt::Debug) -> StartError {
    StartError::Ipc(format!("{what}: {e:?}"))
}

impl Daemon {
    /// Load the maps and create the iceoryx2 service and ports.
    pub fn new(settings: Settings) -> Result<Daemon, StartError> {
        settings.check()?;
        let l = settings.limits;
        let words = l.max_payload_words();
        let registry = Registry::load(&settings.maps, TablePolicy::from_settings(&settings))?;

        let config = cliff_client::iceoryx_config(settings.prefix.as_deref())
            .map_err(StartError::Settings)?;
        let node = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| ipc("cannot create node", e))?;
        let name = |s: &str| {
            ServiceName::new(s)
                .map_err(|e| StartError::Settings(format!("service name '{s}': {e:?}")))
        };
        let clients = settings.max_clients;
        let nodes = clients + 4;
        let service = node
            .service_builder(&name(&protocol::ipc_service_name(&settings.service))?)
            .request_response::<[Observation], [u32]>()
            .request_user_header::<RequestHeader>()
            .response_user_header::<ResponseHeader>()
            .max_clients(clients)
            .max_servers(2)
            .max_nodes(nodes)
            .max_active_requests_per_client(settings.max_active_requests)
            .max_loaned_requests(1)
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the service", e))?;
        if service.dynamic_config().number_of_servers() > 0 {
            return Err(StartError::AlreadyServed(settings.service.clone()));
        }
        // protocol version 1's name and types, only to tell old clients the version
        let legacy_service = node
            .service_builder(&name(&legacy::ipc_service_name(&settings.service))?)
            .request_response::<[legacy::Observation], [u32]>()
            .request_user_header::<legacy::RequestHeader>()
            .response_user_header::<legacy::ResponseHeader>()
            .max_clients(clients)
            .max_servers(2)
            .max_nodes(nodes)
            .max_active_requests_per_client(settings.max_active_requests)
            .max_loaned_requests(1)
            .max_response_buffer_size(1)
            .max_borrowed_responses_per_pending_response(1)
            .open_or_create()
            .map_err(|e| {
                ipc(
                    &format!(
                        "cannot open or create '{}' for clients of protocol version 1 \
                         (does a daemon of version 1 serve it?)",
                        settings.service
                    ),
                    e,
                )
            })?;
        if legacy_service.dynamic_config().number_of_servers() > 0 {
            return Err(StartError::AlreadyServed(settings.service.clone()));
        }
        let wake_service = node
            .service_builder(&name(&request_event_name(&settings.service))?)
            .event()
            .max_notifiers(clients + 2)
            .max_listeners(2)
            .max_nodes(nodes)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the request event service", e))?;
        let response_events = node
            .service_builder(&name(&response_event_name(&settings.service))?)
            .event()
            .max_notifiers(2)
            .max_listeners(clients + 2)
            .max_nodes(nodes)
            .open_or_create()
            .map_err(|e| ipc("cannot open or create the response event service", e))?;
        let server = service
            .server_builder()
            .initial_max_slice_len(words)
            .max_loaned_responses_per_request(1)
            .create()
            .map_err(|e| ipc("cannot create the server port", e))?;
        let legacy_server = legacy_service
            .server_builder()
            .initial_max_slice_len(1)
            .max_loaned_responses_per_request(1)
            .create()
            .map_err(|e| ipc("cannot create the server port of protocol version 1", e))?;
        let wake = wake_service
            .listener_builder()
            .create()
            .map_err(|e| ipc("cannot create the request listener", e))?;
        let notifier = response_events
            .notifier_builder()
            .create()
            .map_err(|e| ipc("cannot create the response notifier", e))?;
        info!(
            service = %settings.service,
            prefix = %config.global.prefix,
            max_clients = clients,
            max_active_requests = settings.max_active_requests,
            max_agents = l.max_agents,
            max_k = l.max_k,
            max_steps = l.max_steps,
            max_history = l.max_history,
            workers = settings.workers,
            chunk_positions = settings.chunk_positions,
            response_kib = words * 4 / 1024,
            "iceoryx2 service ready"
        );
        // requests in progress at once: everything the clients can have in flight,
        // within reason
        let capacity = (clients * settings.max_active_requests).clamp(1, 64);
        let scheduler = Scheduler::new(capacity, &l, settings.workers, settings.chunk_positions)
            .map_err(StartError::Settings)?;
        Ok(Daemon {
            registry,
            scheduler,
            server,
            legacy_server,
            wake,
            wakeups: Wakeups {
                notifier,
                keys: Vec::with_capacity(clients * 2),
            },
            service,
            _legacy_service: legacy_service,
            _wake_service: wake_service,
            _response_events: response_events,
            node,
            reload_waiters: Vec::new(),
            stats: Stats::default(),
            cores: crate::settings::available_cores(),
            #[cfg(feature = "zenoh")]
            remote: None,
            settings,
        })
    }

    /// Also serve remote clients over zenoh: the same validation, limits and scheduler
    /// as local clients (their requests take turns in the same rounds). zenoh runs on
    /// its own threads and wakes the serving loop through the iceoryx2 request event;
    /// returns what it serves on, for the ready line.
    #[cfg(feature = "zenoh")]
    pub fn serve_zenoh(
        &mut self,
        settings: &crate::zenoh::ZenohSettings,
    ) -> Result<String, StartError> {
        let waker = crate::zenoh::RequestWaker::open(
            &self.settings.service,
            self.settings.prefix.as_deref(),
        )?;
        let frontend =
            crate::zenoh::ZenohFrontend::start(settings, &self.settings.limits, move || {
                waker.wake()
            })?;
        let description = frontend.description().to_string();
        info!(zid = %frontend.zid(), "serving remote clients on {description}");
        self.remote = Some(Remote {
            frontend,
            buffers: Vec::new(),
        });
        Ok(description)
    }

    /// The line printed once the daemon serves (contains `ready`).
    pub fn ready_line(&self) -> String {
        let maps: Vec<String> = self
            .registry
            .entries()
            .iter()
            .map(|m| format!("{} ({} locations)", m.name, m.map.locations().len()))
            .collect();
        format!(
            "cliffd ready: serving {} on service '{}' (iceoryx2 prefix '{}'), protocol v{}",
            maps.join(", "),
            self.settings.service,
            self.node.config().global.prefix,
            PROTOCOL_VERSION
        )
    }

    /// Counters so far.
    pub fn stats(&self) -> Stats {
        Stats {
            reloads: self.registry.reloads_done(),
            parallel: self.scheduler.parallel_chunks,
            ..self.stats
        }
    }

    /// Names of the loaded maps.
    pub fn map_names(&self) -> Vec<String> {
        self.registry
            .entries()
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// The largest sampling radius requests may use on each map (m), by name.
    pub fn radius_limits(&self) -> Vec<(String, f64)> {
        self.registry
            .entries()
            .iter()
            .map(|m| (m.name.clone(), m.max_radius))
            .collect()
    }

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

    /// Take the remote requests waiting now (as many as there are free slots): reject
    /// or hand them to the scheduler with a reused buffer; true when there was one.
    #[cfg(feature = "zenoh")]
    fn accept_remote(&mut self) -> bool {
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
            let map = map_for(&mut self.registry, map, &decoded);
            let reply = req.into_pending();
            self.scheduler
                .admit(map, &decoded, Out::Remote { reply, words });
        }
        any
    }

    /// Validate a request and either answer it (rejection, reload) or hand it to the
    /// scheduler with its loaned response.
    fn accept(&mut self, req: Active) {
        let h = *req.user_header();
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
        let response = match req.loan_slice_uninit(words) {
            Ok(r) => r.write_from_fn(|_| 0u32),
            Err(e) => {
                warn!(
                    request_id = h.request_id,
                    words, "cannot loan a response: {e:?}"
                );
                return self.reject(&req, &h, internal());
            }
        };
        let map = map_for(&mut self.registry, map, &decoded);
        self.scheduler.admit(
            map,
            &decoded,
            Out::Ipc {
                request: req,
                response,
            },
        );
    }

    fn reject(&mut self, req: &Active, h: &RequestHeader, rej: Rejection) {
        debug!(request_id = h.request_id, "rejected: {rej}");
        self.stats.rejected += 1;
        let mut rh = response_header(h, self.settings.idle_spin);
        rej.write_to(&mut rh);
        let sent = send_empty(req, rh);
        self.after_send(h, sent);
    }

    /// Send the responses of finished requests.
    fn send_finished(&mut self) {
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
                Out::Remote { reply, words } => {
                    // remote clients do not see the daemon's wake state
                    rh.awake_us = 0;
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

    fn after_send(&mut self, h: &RequestHeader, sent: Result<(), String>) {
        count_failure(&mut self.stats, h, sent);
        self.wakeups.notify(h);
    }

    fn cleanup_dead_nodes(&mut self) {
        let state = self.node.try_cleanup_dead_nodes();
        if state.cleanups > 0 || state.failed_cleanups > 0 {
            info!(
                cleaned = state.cleanups,
                failed = state.failed_cleanups,
                "removed resources of dead processes"
            );
            self.wakeups.keys.clear();
        }
    }

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

fn count_failure(stats: &mut Stats, h: &RequestHeader, sent: Result<(), String>) {
    if let Err(e) = sent {
        stats.failed += 1;
        debug!(
            request_id = h.request_id,
            "response not sent (client gone?): {e}"
        );
    }
}

/// The map an accepted request on map entry `entry` runs on
/// ([`registry::map_for_time`]), its neighbour table asked for.
fn map_for(registry: &mut Registry, entry: usize, decoded: &Decoded) -> Arc<CliffMap> {
    let map = Arc::clone(registry::map_for_time(
        &registry.entries()[entry],
        decoded.map_time,
    ));
    if uses_map(decoded) {
        registry.want_table(&map, decoded.params.radius);
    }
    map
}

/// Whether a request looks up the map at its radius: every method but constant
/// velocity, and constant velocity when it scores its samples.
fn uses_map(d: &Decoded) -> bool {
    d.params.method.samples_map() || d.options.scores
}

/// Validate a request against the loaded maps, their radius limits and the limits; the
/// map entry's index and the decoded request.
fn decode(
    registry: &Registry,
    limits: &Limits,
    h: &RequestHeader,
    rows: &[Observation],
    scratch: &mut protocol::DecodeScratch,
) -> Result<(usize, Decoded), Rejection> {
    // the version and the kind are checked before anything else is read (a reload
    // request, which names no map, that reaches this point over zenoh is `unknown-kind`)
    if h.version != PROTOCOL_VERSION || h.kind != protocol::KIND_PREDICT {
        return protocol::decode_request(h, rows, limits, scratch).map(|d| (0, d));
    }
    let Some(map) = registry.find(&h.map) else {
        return Err(Rejection {
            status: Status::UnknownMap,
            field: Field::Map,
            ..internal()
        });
    };
    let decoded = protocol::decode_request(h, rows, limits, scratch)?;
    let entry = &registry.entries()[map];
    if uses_map(&decoded) && decoded.params.radius > entry.max_radius {
        return Err(Rejection {
            status: Status::RadiusTooLarge,
            field: Field::Radius,
            limit: entry.max_radius_mm(),
            ..internal()
        });
    }
    Ok((map, decoded))
}

/// A response header for request `h`; `awake` is how long the daemon keeps polling
/// after answering (see [`ResponseHeader::awake_us`]).
fn response_header(h: &RequestHeader, awake: Duration) -> ResponseHeader {
    ResponseHeader {
        version: PROTOCOL_VERSION,
        request_id: h.request_id,
        awake_us: awake.as_micros().min(u32::MAX as u128) as u32,
        ..ResponseHeader::default()
    }
}

fn internal() -> Rejection {
    Rejection {
        status: Status::Internal,
        agent: None,
        row: None,
        field: Field::None,
        limit: 0,
    }
}

fn send_empty(req: &Active, rh: ResponseHeader) -> Result<(), String> {
    let resp = req.loan_slice_uninit(0).map_err(|e| format!("{e:?}"))?;
    let mut resp = resp.write_from_fn(|_| 0u32);
    *resp.user_header_mut() = rh;
    resp.send().map_err(|e| format!("{e:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::MapSpec;

    #[test]
    fn bad_settings_and_maps_are_refused_before_serving() {
        let bad = |f: &dyn Fn(&mut Settings)| {
            let mut s = Settings {
                prefix: Some("cliff_unit_settings_".into()),
                ..Settings::default()
            };
            f(&mut s);
            Daemon::new(s).err().expect("refused").to_string()
        };
        assert!(bad(&|s| s.limits.max_k = 0).contains("at least 1"));
        let e = bad(&|s| {
            s.maps = vec![MapSpec {
                name: "x".into(),
                path: Some("/nonexistent/map.csv".into()),
            }]
        });
        assert!(
            e.contains("map 'x'") && e.contains("/nonexistent/map.csv"),
            "{e}"
        );
        let e = bad(&|s| {
            let m = MapSpec {
                name: "x".into(),
                path: None,
            };
            s.maps = vec![m.clone(), m];
        });
        assert!(e.contains("twice"), "{e}");
    }
}
