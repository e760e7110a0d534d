//! # cliff-service: the `cliffd` prediction daemon
//!
//! [`Daemon`] holds named CLiFF-maps in memory and answers prediction requests over one
//! iceoryx2 request-response service (protocol: [`cliff_client::protocol`]). Each
//! request is validated ([`cliff_client::protocol::decode_request`]) and answered with
//! one slice response that [`cliff::predict::predict_into`] writes in place: no copy and
//! no allocation per request.
//!
//! The serving loop busy-polls for [`Settings::idle_spin`] after the last request, then
//! sleeps on an iceoryx2 event that clients signal with every request. Maps reload in a
//! background thread (SIGHUP or a reload request); a map that fails to load keeps its old
//! version. Dead clients' resources are cleaned up once a second.
#![warn(missing_docs)]

#[cfg(feature = "zenoh")]
pub mod zenoh;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::predict::{BatchMut, Params, predict_into};
use cliff_client::protocol::{
    self, DecodeScratch, Field, KIND_RELOAD, Limits, MAP_NAME_BYTES, Observation, PROTOCOL_VERSION,
    Rejection, RequestHeader, ResponseHeader, Status,
};
use cliff_client::{PredictService, request_event_name, response_event_name};
use iceoryx2::active_request::ActiveRequest;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::{ListenerKey, Notifier};
use iceoryx2::port::server::Server;
use iceoryx2::prelude::*;
use rayon::prelude::*;
use tracing::{debug, error, info, warn};

/// After this long without requests, the busy-polling loop yields its core between polls.
const POLITE_AFTER: Duration = Duration::from_micros(50);

/// How often the daemon logs its traffic (when there was any).
const STATS_INTERVAL: Duration = Duration::from_secs(10);

/// A map to serve: a name and the file it comes from (`None`: the built-in demo scene).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapSpec {
    /// Name clients ask for.
    pub name: String,
    /// CSV or snapshot file; `None` for the built-in scene.
    pub path: Option<PathBuf>,
}

impl std::str::FromStr for MapSpec {
    type Err = String;
    /// `NAME=PATH`.
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, path) = s
            .split_once('=')
            .ok_or_else(|| format!("'{s}' is not NAME=PATH (for example hall=maps/hall.csv)"))?;
        protocol::encode_map_name(name)?;
        if path.is_empty() {
            return Err(format!("map '{name}' has an empty path"));
        }
        Ok(MapSpec {
            name: name.to_string(),
            path: Some(PathBuf::from(path)),
        })
    }
}

/// Daemon settings. The iceoryx2 service limits are derived from them.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// iceoryx2 service name.
    pub service: String,
    /// iceoryx2 prefix (namespace); `None`: iceoryx2's default.
    pub prefix: Option<String>,
    /// Maps; empty: the built-in demo scene under the name `demo`.
    pub maps: Vec<MapSpec>,
    /// Per-request limits.
    pub limits: Limits,
    /// Client processes served at once.
    pub max_clients: usize,
    /// Requests one client may have in flight.
    pub max_active_requests: usize,
    /// How long the loop busy-polls after the last request before it sleeps.
    pub idle_spin: Duration,
    /// Threads predicting requests that arrive together (1: the serving thread alone).
    pub workers: usize,
    /// How often resources of dead processes (clients killed with SIGKILL) are removed.
    pub cleanup_interval: Duration,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            service: cliff_client::DEFAULT_SERVICE.to_string(),
            prefix: None,
            maps: Vec::new(),
            limits: Limits::default(),
            max_clients: 16,
            max_active_requests: 2,
            idle_spin: Duration::from_millis(1),
            cleanup_interval: Duration::from_secs(1),
            workers: 1,
        }
    }
}

/// Errors that stop the daemon from starting.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// A map file could not be loaded.
    #[error("map '{name}': {source}")]
    Map {
        /// Map name.
        name: String,
        /// Why.
        source: cliff::map::MapError,
    },
    /// Settings are unusable.
    #[error("{0}")]
    Settings(String),
    /// iceoryx2 refused (permissions, a service of another version, ...).
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// Another daemon already serves the service.
    #[error("another cliffd already serves '{0}' (stop it, or use another --service or --prefix)")]
    AlreadyServed(String),
    /// zenoh refused (endpoint in use, bad configuration).
    #[error("zenoh: {0}")]
    Zenoh(String),
}

struct LoadedMap {
    name: String,
    wire: [u8; MAP_NAME_BYTES],
    path: Option<PathBuf>,
    map: CliffMap,
}

type ReloadResult = Vec<(usize, Result<CliffMap, String>)>;

type Port = Server<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
type Active = ActiveRequest<ipc::Service, [Observation], RequestHeader, [u32], ResponseHeader>;
type Response = iceoryx2::response_mut::ResponseMut<ipc::Service, [u32], ResponseHeader>;

/// Counters of a running daemon.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Requests answered with a batch.
    pub served: u64,
    /// Requests answered with a rejection.
    pub rejected: u64,
    /// Responses that could not be sent (client gone, memory exhausted).
    pub failed: u64,
    /// Completed map reloads.
    pub reloads: u64,
    /// Requests predicted in parallel with others (with more than one worker).
    pub parallel: u64,
}

/// The prediction daemon: maps, iceoryx2 ports and reusable buffers.
pub struct Daemon {
    settings: Settings,
    maps: Vec<LoadedMap>,
    batch: Vec<Active>,
    slots: Vec<Slot>,
    jobs: Vec<Job<'static>>,
    pool: Option<rayon::ThreadPool>,
    // ports before services before node (drop order)
    server: Port,
    wake: Listener<ipc::Service>,
    notifier: Notifier<ipc::Service>,
    listener_keys: Vec<(u128, ListenerKey)>,
    service: PredictService,
    _wake_service: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    _response_events: iceoryx2::service::port_factory::event::PortFactory<ipc::Service>,
    node: Node<ipc::Service>,
    reload_rx: Option<mpsc::Receiver<ReloadResult>>,
    reload_waiters: Vec<Active>,
    reload_again: bool,
    stats: Stats,
    /// Remote clients over zenoh, once [`Daemon::serve_zenoh`] started them.
    #[cfg(feature = "zenoh")]
    remote: Option<Remote>,
}

/// The zenoh frontend and the buffers its requests are decoded and predicted into.
#[cfg(feature = "zenoh")]
struct Remote {
    frontend: zenoh::ZenohFrontend,
    scratch: DecodeScratch,
    payload: Vec<u32>,
}

/// Remote requests answered per sweep at most, so that local ones arriving meanwhile
/// are served between them.
#[cfg(feature = "zenoh")]
const REMOTE_PER_SWEEP: usize = 4;

fn ipc(what: &str, e: impl std::fmt::Debug) -> StartError {
    StartError::Ipc(format!("{what}: {e:?}"))
}

impl Daemon {
    /// Load the maps and create the iceoryx2 service and ports.
    pub fn new(settings: Settings) -> Result<Daemon, StartError> {
        let l = settings.limits;
        if l.max_agents == 0 || l.max_k == 0 || l.max_steps == 0 || l.max_history == 0 {
            return Err(StartError::Settings(
                "limits on agents, k, steps and history must be at least 1".into(),
            ));
        }
        if l.max_history > protocol::MAX_HISTORY {
            return Err(StartError::Settings(format!(
                "max history {} is above the protocol's {}",
                l.max_history,
                protocol::MAX_HISTORY
            )));
        }
        if settings.workers == 0 || settings.workers > 256 {
            return Err(StartError::Settings(
                "workers must be between 1 and 256".into(),
            ));
        }
        if settings.max_clients == 0 || settings.max_active_requests == 0 {
            return Err(StartError::Settings(
                "max clients and max active requests must be at least 1".into(),
            ));
        }
        let words = l.max_payload_words();
        if words > (1 << 28) {
            return Err(StartError::Settings(format!(
                "agents x k x steps = {} x {} x {} makes responses of {} MB; lower a limit",
                l.max_agents,
                l.max_k,
                l.max_steps,
                (words * 4) >> 20
            )));
        }
        let maps = load_maps(&settings.maps)?;

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
            .service_builder(&name(&settings.service)?)
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
            response_kib = words * 4 / 1024,
            "iceoryx2 service ready"
        );
        // requests taken in one sweep: everything that can be in flight, within reason
        let batch = (clients * settings.max_active_requests).clamp(1, 64);
        let pool = if settings.workers > 1 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(settings.workers)
                .use_current_thread()
                .thread_name(|i| format!("cliffd-worker-{i}"))
                .build()
                .map_err(|e| StartError::Settings(format!("cannot start the workers: {e}")))?;
            Some(pool)
        } else {
            None
        };
        let slots = (0..batch)
            .map(|_| Slot {
                header: RequestHeader::default(),
                scratch: DecodeScratch::new(&l),
                map: 0,
                params: Params::default(),
                response: None,
                ok: false,
            })
            .collect();
        Ok(Daemon {
            batch: Vec::with_capacity(batch),
            slots,
            jobs: Vec::with_capacity(batch),
            pool,
            maps,
            server,
            wake,
            notifier,
            listener_keys: Vec::with_capacity(clients * 2),
            service,
            _wake_service: wake_service,
            _response_events: response_events,
            node,
            reload_rx: None,
            reload_waiters: Vec::new(),
            reload_again: false,
            stats: Stats::default(),
            #[cfg(feature = "zenoh")]
            remote: None,
            settings,
        })
    }

    /// The line printed once the daemon serves (contains `ready`).
    pub fn ready_line(&self) -> String {
        let maps: Vec<String> = self
            .maps
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
        self.stats
    }

    /// Also serve remote clients over zenoh (same validation, limits and predictions);
    /// returns what it serves on, for the ready line. zenoh runs on its own threads and
    /// wakes the serving loop through the iceoryx2 request event.
    #[cfg(feature = "zenoh")]
    pub fn serve_zenoh(&mut self, settings: &zenoh::ZenohSettings) -> Result<String, StartError> {
        let waker =
            zenoh::RequestWaker::open(&self.settings.service, self.settings.prefix.as_deref())?;
        let limits = self.settings.limits;
        let frontend = zenoh::ZenohFrontend::start(settings, &limits, move || waker.wake())?;
        let description = frontend.description().to_string();
        info!(zid = %frontend.zid(), "serving remote clients on {description}");
        self.remote = Some(Remote {
            frontend,
            scratch: DecodeScratch::new(&limits),
            payload: Vec::with_capacity(limits.max_payload_words()),
        });
        Ok(description)
    }

    /// Answer up to [`REMOTE_PER_SWEEP`] remote requests: decode, predict into the
    /// reused buffer, reply (the reply thread sends it); true when there was one.
    #[cfg(feature = "zenoh")]
    fn serve_remote(&mut self) -> bool {
        let Some(remote) = self.remote.as_mut() else {
            return false;
        };
        let mut any = false;
        for _ in 0..REMOTE_PER_SWEEP {
            let Some(req) = remote.frontend.try_next() else {
                break;
            };
            any = true;
            let h = *req.header();
            let decoded = decode(
                &self.maps,
                &self.settings.limits,
                &h,
                req.rows(),
                &mut remote.scratch,
            );
            let sent = match decoded {
                Ok((map, params)) => {
                    let states = remote.scratch.states();
                    let words = protocol::payload_words(states.len(), params.k, params.steps());
                    remote.payload.clear();
                    remote.payload.resize(words, 0);
                    let mut ok = false;
                    Job {
                        map: &self.maps[map].map,
                        states,
                        params,
                        out: &mut remote.payload,
                        ok: &mut ok,
                    }
                    .run();
                    if ok {
                        self.stats.served += 1;
                        let rh = ResponseHeader {
                            agents: states.len() as u32,
                            k: params.k as u32,
                            steps: params.steps() as u32,
                            ..response_header(&h, Duration::ZERO)
                        };
                        req.reply(&rh, &remote.payload)
                    } else {
                        self.stats.rejected += 1;
                        req.reject(&internal())
                    }
                }
                Err(rej) => {
                    debug!(request_id = h.request_id, "remote request rejected: {rej}");
                    self.stats.rejected += 1;
                    req.reject(&rej)
                }
            };
            if !sent {
                self.stats.failed += 1;
            }
        }
        any
    }

    /// Names of the loaded maps.
    pub fn map_names(&self) -> Vec<String> {
        self.maps.iter().map(|m| m.name.clone()).collect()
    }

    /// Serve until `stop` is set. `reload` set (by SIGHUP) starts a map reload and is
    /// cleared.
    pub fn run(&mut self, stop: &AtomicBool, reload: &AtomicBool) {
        let mut last_activity = Instant::now();
        let mut next_housekeeping = last_activity;
        let mut next_cleanup = last_activity + self.settings.cleanup_interval;
        let mut next_report = last_activity + STATS_INTERVAL;
        let mut reported = self.stats;
        while !stop.load(Ordering::Relaxed) {
            let served = self.serve_pending();
            let now = Instant::now();
            if served {
                last_activity = now;
            }
            if now >= next_housekeeping {
                if reload.swap(false, Ordering::Relaxed) {
                    info!("SIGHUP: reloading maps");
                    self.start_reload();
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
                } else if now.duration_since(last_activity) >= POLITE_AFTER {
                    // let a client on this core run (oversubscribed hosts)
                    std::thread::yield_now();
                } else {
                    std::hint::spin_loop();
                }
            }
        }
        info!(
            served = self.stats.served,
            rejected = self.stats.rejected,
            failed = self.stats.failed,
            parallel = self.stats.parallel,
            "shutting down"
        );
    }

    /// Answer the requests waiting now (up to one batch: everything the clients can
    /// have in flight, at most 64); true when there was at least one. With more than
    /// one worker, requests that arrived together are predicted in parallel.
    pub fn serve_pending(&mut self) -> bool {
        while self.batch.len() < self.batch.capacity() {
            match self.server.receive() {
                Ok(Some(req)) => {
                    let h = req.user_header();
                    if h.version == PROTOCOL_VERSION && h.kind == KIND_RELOAD {
                        info!(request_id = h.request_id, "reload request");
                        self.start_reload();
                        self.reload_waiters.push(req);
                    } else {
                        self.batch.push(req);
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    warn!("receiving requests failed: {e:?}");
                    break;
                }
            }
        }
        #[cfg(feature = "zenoh")]
        let remote = self.serve_remote();
        #[cfg(not(feature = "zenoh"))]
        let remote = false;
        if self.batch.is_empty() {
            return remote;
        }
        self.serve_batch();
        true
    }

    /// Decode, loan, predict (in parallel when there is a pool and more than one
    /// request), send, notify; empties `self.batch`.
    fn serve_batch(&mut self) {
        let reqs = std::mem::take(&mut self.batch);
        let n = reqs.len();
        // 1. validate and loan a response for each (rejections are answered here)
        for (i, req) in reqs.iter().enumerate() {
            let h = *req.user_header();
            let slot = &mut self.slots[i];
            slot.header = h;
            slot.response = None;
            let decoded = decode(
                &self.maps,
                &self.settings.limits,
                &h,
                req.payload(),
                &mut slot.scratch,
            );
            let rejection = match decoded {
                Err(rej) => Some(rej),
                Ok((map, params)) => {
                    slot.map = map;
                    slot.params = params;
                    let words = protocol::payload_words(
                        slot.scratch.states().len(),
                        params.k,
                        params.steps(),
                    );
                    match req.loan_slice_uninit(words) {
                        Ok(resp) => {
                            slot.response = Some(resp.write_from_fn(|_| 0u32));
                            None
                        }
                        Err(e) => {
                            warn!(
                                request_id = h.request_id,
                                words, "cannot loan a response: {e:?}"
                            );
                            Some(internal())
                        }
                    }
                }
            };
            if let Some(rej) = rejection {
                debug!(request_id = h.request_id, "rejected: {rej}");
                self.stats.rejected += 1;
                let mut rh = response_header(&h, self.settings.idle_spin);
                rej.write_to(&mut rh);
                let sent = send_empty(req, rh);
                self.after_send(&h, sent);
            }
        }
        // 2. predict straight into the loaned responses
        let slots = &mut self.slots[..n];
        let maps = &self.maps;
        match &self.pool {
            Some(pool) if worth_parallel(slots) => {
                let mut jobs = recycle(std::mem::take(&mut self.jobs));
                for s in slots.iter_mut() {
                    if let Some(resp) = s.response.as_mut() {
                        jobs.push(Job {
                            map: &maps[s.map].map,
                            states: s.scratch.states(),
                            params: s.params,
                            out: resp.payload_mut(),
                            ok: &mut s.ok,
                        });
                    }
                }
                self.stats.parallel += jobs.len() as u64;
                pool.install(|| jobs.par_iter_mut().for_each(|j| j.run()));
                self.jobs = recycle(jobs);
            }
            _ => {
                for s in slots.iter_mut() {
                    if let Some(resp) = s.response.as_mut() {
                        Job {
                            map: &maps[s.map].map,
                            states: s.scratch.states(),
                            params: s.params,
                            out: resp.payload_mut(),
                            ok: &mut s.ok,
                        }
                        .run();
                    }
                }
            }
        }
        // 3. send
        for (i, req) in reqs.iter().enumerate() {
            let slot = &mut self.slots[i];
            let Some(mut resp) = slot.response.take() else {
                continue; // answered in step 1
            };
            let h = slot.header;
            let mut rh = response_header(&h, self.settings.idle_spin);
            let sent = if slot.ok {
                rh.agents = slot.scratch.states().len() as u32;
                rh.k = slot.params.k as u32;
                rh.steps = slot.params.steps() as u32;
                *resp.user_header_mut() = rh;
                self.stats.served += 1;
                resp.send().map_err(|e| format!("{e:?}"))
            } else {
                drop(resp);
                self.stats.rejected += 1;
                internal().write_to(&mut rh);
                send_empty(req, rh)
            };
            self.after_send(&h, sent);
        }
        // dropping the active requests ends them; keep the vector's memory
        let mut reqs = reqs;
        reqs.clear();
        self.batch = reqs;
    }

    fn after_send(&mut self, h: &RequestHeader, sent: Result<(), String>) {
        if let Err(e) = sent {
            self.stats.failed += 1;
            debug!(
                request_id = h.request_id,
                "response not sent (client gone?): {e}"
            );
        }
        let lid = (h.listener_id[0] as u128) | ((h.listener_id[1] as u128) << 64);
        if lid != 0 {
            self.notify_client(lid);
        }
    }

    fn notify_client(&mut self, id: u128) {
        if let Some(i) = self.listener_keys.iter().position(|(l, _)| *l == id) {
            if self
                .notifier
                .notify_single_listener(&self.listener_keys[i].1)
                .is_ok()
            {
                return;
            }
            self.listener_keys.swap_remove(i);
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
            if self.listener_keys.len() == self.listener_keys.capacity() {
                self.listener_keys.clear(); // forget clients that left
            }
            self.listener_keys.push((id, key));
        }
    }

    fn cleanup_dead_nodes(&mut self) {
        let state = self.node.try_cleanup_dead_nodes();
        if state.cleanups > 0 || state.failed_cleanups > 0 {
            info!(
                cleaned = state.cleanups,
                failed = state.failed_cleanups,
                "removed resources of dead processes"
            );
            self.listener_keys.clear();
        }
    }

    /// Start reloading every map from its file in a background thread (no-op for the
    /// built-in scene). A reload already running is followed by another one.
    pub fn start_reload(&mut self) {
        if self.reload_rx.is_some() {
            self.reload_again = true;
            return;
        }
        let jobs: Vec<(usize, String, PathBuf)> = self
            .maps
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.path.clone().map(|p| (i, m.name.clone(), p)))
            .collect();
        let (tx, rx) = mpsc::channel();
        let spawned = std::thread::Builder::new()
            .name("cliffd-reload".into())
            .spawn(move || {
                let results: ReloadResult = jobs
                    .into_iter()
                    .map(|(i, name, path)| {
                        let r = CliffMap::load(&path).map_err(|e| format!("map '{name}': {e}"));
                        (i, r)
                    })
                    .collect();
                let _ = tx.send(results);
            });
        match spawned {
            Ok(_) => self.reload_rx = Some(rx),
            Err(e) => {
                error!("cannot start the reload thread: {e}");
                self.finish_reload(Some("cannot start the reload thread".into()));
            }
        }
    }

    /// Apply a finished reload, if any; true when one was applied.
    pub fn poll_reload(&mut self) -> bool {
        let Some(rx) = &self.reload_rx else {
            return false;
        };
        let results = match rx.try_recv() {
            Ok(r) => r,
            Err(mpsc::TryRecvError::Empty) => return false,
            Err(mpsc::TryRecvError::Disconnected) => {
                vec![] // the thread died; nothing to apply
            }
        };
        self.reload_rx = None;
        let mut first_error = None;
        for (i, r) in results {
            match r {
                Ok(map) => {
                    info!(map = %self.maps[i].name, locations = map.locations().len(), "map reloaded");
                    self.maps[i].map = map;
                }
                Err(e) => {
                    error!("reload failed, keeping the old map: {e}");
                    first_error.get_or_insert(e);
                }
            }
        }
        self.stats.reloads += 1;
        self.finish_reload(first_error);
        if std::mem::take(&mut self.reload_again) {
            self.start_reload();
        }
        true
    }

    fn finish_reload(&mut self, error: Option<String>) {
        for req in std::mem::take(&mut self.reload_waiters) {
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
            let lid = (h.listener_id[0] as u128) | ((h.listener_id[1] as u128) << 64);
            if lid != 0 {
                self.notify_client(lid);
            }
        }
    }
}

/// Validate a request against the loaded maps and the limits.
fn decode(
    maps: &[LoadedMap],
    limits: &Limits,
    h: &RequestHeader,
    rows: &[Observation],
    scratch: &mut DecodeScratch,
) -> Result<(usize, Params), Rejection> {
    // the version is checked before anything else is read
    if h.version == PROTOCOL_VERSION {
        let Some(map) = maps.iter().position(|m| m.wire == h.map) else {
            return Err(Rejection {
                status: Status::UnknownMap,
                field: Field::Map,
                ..internal()
            });
        };
        let params = protocol::decode_request(h, rows, limits, scratch)?;
        return Ok((map, params));
    }
    protocol::decode_request(h, rows, limits, scratch).map(|p| (0, p))
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

/// One request's prediction: the loaned response's payload and what goes into it.
struct Job<'a> {
    map: &'a CliffMap,
    states: &'a [cliff::motion::State],
    params: Params,
    out: &'a mut [u32],
    ok: &'a mut bool,
}

impl Job<'_> {
    fn run(&mut self) {
        let points = self.states.len() * self.params.k * self.params.steps();
        let (pos, lens) = self.out.split_at_mut(points * 2);
        let out = BatchMut {
            positions: bytemuck::cast_slice_mut(pos),
            lens,
        };
        *self.ok = match predict_into(self.map, self.states, &self.params, out) {
            Ok(()) => true,
            Err(e) => {
                // decode_request checks everything predict_into does
                error!("prediction failed: {e}");
                false
            }
        };
    }
}

/// Positions a batch must predict before it is split over the workers: waking a
/// sleeping worker costs tens of microseconds, about a thousand positions' work.
const PARALLEL_MIN_POINTS: usize = 4000;

/// True when at least two requests are to be predicted and together they are large
/// enough to pay for waking the workers.
fn worth_parallel(slots: &[Slot]) -> bool {
    let mut jobs = 0;
    let mut points = 0;
    for s in slots.iter().filter(|s| s.response.is_some()) {
        jobs += 1;
        points += s.scratch.states().len() * s.params.k * s.params.steps();
    }
    jobs > 1 && points >= PARALLEL_MIN_POINTS
}

/// Reuse a vector's memory for elements of another lifetime (it is empty in between),
/// so that the parallel path builds its job list without allocating.
fn recycle<'b>(mut v: Vec<Job<'_>>) -> Vec<Job<'b>> {
    v.clear();
    // collecting an emptied vector's iterator in place keeps the allocation (same layout)
    v.into_iter().map(|_| unreachable!()).collect()
}

/// Per-request state of a batch slot, reused between batches.
struct Slot {
    header: RequestHeader,
    scratch: DecodeScratch,
    map: usize,
    params: Params,
    response: Option<Response>,
    ok: bool,
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

fn load_maps(specs: &[MapSpec]) -> Result<Vec<LoadedMap>, StartError> {
    if specs.is_empty() {
        return Ok(vec![LoadedMap {
            name: "demo".into(),
            wire: protocol::encode_map_name("demo").expect("valid name"),
            path: None,
            map: CliffMap::demo(),
        }]);
    }
    let mut out: Vec<LoadedMap> = Vec::with_capacity(specs.len());
    for s in specs {
        if out.iter().any(|m| m.name == s.name) {
            return Err(StartError::Settings(format!(
                "map name '{}' is given twice",
                s.name
            )));
        }
        let wire = protocol::encode_map_name(&s.name).map_err(StartError::Settings)?;
        let map = match &s.path {
            Some(p) => CliffMap::load(p).map_err(|source| StartError::Map {
                name: s.name.clone(),
                source,
            })?,
            None => CliffMap::demo(),
        };
        info!(map = %s.name, path = ?s.path, locations = map.locations().len(), "map loaded");
        out.push(LoadedMap {
            name: s.name.clone(),
            wire,
            path: s.path.clone(),
            map,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recycled_job_vectors_keep_their_memory() {
        let v: Vec<Job<'static>> = Vec::with_capacity(16);
        let ptr = v.as_ptr() as usize;
        let w: Vec<Job<'_>> = recycle(v);
        assert_eq!((w.capacity(), w.as_ptr() as usize), (16, ptr));
        let back: Vec<Job<'static>> = recycle(w);
        assert_eq!((back.capacity(), back.as_ptr() as usize), (16, ptr));
    }

    #[test]
    fn map_specs_parse_and_refuse_bad_ones() {
        let m: MapSpec = "hall=maps/hall.csv".parse().unwrap();
        assert_eq!(m.name, "hall");
        assert_eq!(m.path, Some(PathBuf::from("maps/hall.csv")));
        assert!("hall".parse::<MapSpec>().unwrap_err().contains("NAME=PATH"));
        assert!("=x.csv".parse::<MapSpec>().unwrap_err().contains("empty"));
        assert!(
            "hall="
                .parse::<MapSpec>()
                .unwrap_err()
                .contains("empty path")
        );
        let long = format!("{}=x.csv", "n".repeat(64));
        assert!(long.parse::<MapSpec>().is_err());
    }

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
        assert!(bad(&|s| s.limits.max_history = 65).contains("max history"));
        assert!(bad(&|s| s.workers = 0).contains("workers"));
        assert!(bad(&|s| s.max_clients = 0).contains("at least 1"));
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
