//! Remote clients over zenoh (feature `zenoh`): a queryable that hands requests to the
//! serving loop, which answers them through the same validation, limits and prediction
//! as local iceoryx2 requests.
//!
//! The serving loop sees no zenoh type: [`ZenohFrontend::try_next`] gives a decoded
//! [`RemoteRequest`] (header and rows, see [`cliff_client::wire`]) and
//! [`RemoteRequest::reply`] / [`RemoteRequest::reject`] answer it. Parts:
//! `config.rs` (the zenoh configuration, the largest message, [`MemoryBound`]),
//! `sessions.rs` (remote sessions and their requests in flight, [`Sessions`]),
//! `priority.rs` (zenoh's threads run at a lower CPU priority than the serving loop),
//! `maps.rs` (the maps' versions for daemons that follow them, [`MapServer`]),
//! `follow.rs` (following another daemon's map, [`Following`]).
//!
//! Observations come on a key of their own, the service name followed by `/observe`
//! ([`cliff_client::map_wire::observe_key_for`]), so that zenoh's access control can
//! leave predictions open and close observations to the sessions allowed to teach the
//! map; an observe request on the prediction key is answered
//! [`Status::NotAllowed`], a prediction on the observe key [`Status::UnknownKind`].
//! Threads:
//!
//! * zenoh's own (network, rx, tx): the queryable's callback counts the query for its
//!   session ([`Sessions`]: as many requests in flight as a local client, a cap on
//!   sessions) and moves it into a channel with room for every admitted request, then
//!   wakes the serving loop; a query beyond its session's limit, or from a session
//!   beyond the cap, is refused there ([`Status::Busy`], [`Status::TooManySessions`])
//!   without being queued or decoded past its request id;
//! * the serving loop: decodes (size checks before anything is allocated, bounded by
//!   the daemon's limits), predicts, encodes the response;
//! * `cliffd-zenoh-reply`: sends the encoded responses, so that a remote link that is
//!   slow or stuck (zenoh blocks a reply when the query asked for blocking congestion
//!   control) never stalls the serving loop; a request stops counting as in flight
//!   once its reply is handed to zenoh;
//! * `cliffd-zenoh-refuse`: sends the refusals (at most [`REFUSED_QUEUE`] wait; beyond,
//!   a refused query gets no reply).
//!
//! zenoh's threads run at a lower CPU priority than the serving loop
//! ([`ZenohSettings::nice`]).
//!
//! Safe defaults (see [`zenoh_config`]): peer mode, listening only on the given
//! endpoints, multicast and gossip scouting off, received messages limited to what the
//! largest allowed request needs.

mod config;
mod follow;
mod maps;
mod priority;
mod sessions;

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, TrySendError, sync_channel};

use cliff_client::map_wire::observe_key_for;
use cliff_client::protocol::{
    Field, Limits, Observation, PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader, Status,
};
use cliff_client::wire;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;
use tracing::{debug, warn};
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::query::{Query, Queryable};

pub use config::{
    MESSAGE_SLACK, MemoryBound, REFUSED_QUERY_BYTES, REFUSED_QUEUE, TRANSPORTS_PER_SESSION,
    default_max_message_bytes, max_request_bytes, max_response_bytes, max_rows, tls_link_warning,
    uses_tls_link, zenoh_config,
};
pub use follow::{DEFAULT_MAX_MAP_BYTES, FollowSettings, FollowSpec, FollowStats, Following};
pub use maps::MapServer;
pub use priority::{MAX_NICE, nice_of};
pub use sessions::{ANONYMOUS, Admitted, Refusal, Sessions, forget_bytes, session_of};

use crate::settings::StartError;

/// Where and how the daemon serves remote clients.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ZenohSettings {
    /// Endpoints to listen on (`tcp/127.0.0.1:7447`, `quic/host:7447`); they replace the
    /// configuration file's `listen.endpoints`. Empty and no file: nothing listens (the
    /// daemon can still reach a router named in the file's `connect.endpoints`).
    pub endpoints: Vec<String>,
    /// A full zenoh configuration (JSON5): TLS, access control, scouting, connect.
    pub config_file: Option<PathBuf>,
    /// The key expression of the queryable ([`key_expr_for`] of the service name).
    pub key: String,
    /// Remote sessions with requests in flight at once ([`Daemon::serve_zenoh`] takes
    /// it from [`Settings::max_remote_sessions`]).
    ///
    /// [`Daemon::serve_zenoh`]: crate::Daemon::serve_zenoh
    /// [`Settings::max_remote_sessions`]: crate::Settings::max_remote_sessions
    pub max_sessions: usize,
    /// Requests in flight per remote session ([`Daemon::serve_zenoh`] takes it from
    /// [`Settings::max_active_requests`], the local clients' limit).
    ///
    /// [`Daemon::serve_zenoh`]: crate::Daemon::serve_zenoh
    /// [`Settings::max_active_requests`]: crate::Settings::max_active_requests
    pub max_active: usize,
    /// The largest message accepted (`transport.link.rx.max_message_size`); `None`:
    /// the largest request the limits allow plus [`MESSAGE_SLACK`], whatever the
    /// configuration file says.
    pub max_message_bytes: Option<usize>,
    /// How much lower than the daemon's own the CPU priority of zenoh's threads is: a
    /// Linux nice increment from 0 (the same) to [`MAX_NICE`], default [`DEFAULT_NICE`].
    /// The serving loop then gets the CPU before zenoh's receive threads, so a remote
    /// client flooding the daemon with large messages delays local clients less; other
    /// remote clients share zenoh's threads with it (`priority.rs`).
    pub nice: i32,
}

/// The default of [`ZenohSettings::nice`].
pub const DEFAULT_NICE: i32 = 10;

impl ZenohSettings {
    /// Settings for the iceoryx2 service `service` listening on `endpoints`.
    pub fn new(service: &str, endpoints: Vec<String>, config_file: Option<PathBuf>) -> Self {
        let d = crate::Settings::default();
        ZenohSettings {
            endpoints,
            config_file,
            key: key_expr_for(service),
            max_sessions: d.max_remote_sessions,
            max_active: d.max_active_requests,
            max_message_bytes: None,
            nice: DEFAULT_NICE,
        }
    }

    /// Requests in flight over all remote sessions at most.
    pub fn max_in_flight(&self) -> usize {
        self.max_sessions * self.max_active
    }
}

/// The zenoh key expression a daemon serving the iceoryx2 service `service` answers on:
/// the service name itself (`cliff/predict`); clients derive it the same way.
pub fn key_expr_for(service: &str) -> String {
    cliff_client::zenoh::key_expr_for(service)
}
/// Wakes the serving loop when it sleeps on the iceoryx2 request event: a notifier of
/// that event on a node of its own (thread-safe ports, so zenoh's threads can use it).
pub struct RequestWaker {
    notifier: Notifier<ipc_threadsafe::Service>,
    _events: iceoryx2::service::port_factory::event::PortFactory<ipc_threadsafe::Service>,
    _node: Node<ipc_threadsafe::Service>,
}

impl RequestWaker {
    /// Open the request event of the daemon serving `service` under `prefix`.
    pub fn open(service: &str, prefix: Option<&str>) -> Result<RequestWaker, StartError> {
        let config = cliff_client::iceoryx_config(prefix).map_err(StartError::Settings)?;
        let err = |what: &str, e: &dyn std::fmt::Debug| StartError::Ipc(format!("{what}: {e:?}"));
        let node = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc_threadsafe::Service>()
            .map_err(|e| err("cannot create the zenoh bridge's node", &e))?;
        let name = cliff_client::request_event_name(service);
        let name = ServiceName::new(&name)
            .map_err(|e| StartError::Settings(format!("service name '{name}': {e:?}")))?;
        let events = node
            .service_builder(&name)
            .event()
            .open()
            .map_err(|e| err("cannot open the request event service", &e))?;
        let notifier = events
            .notifier_builder()
            .create()
            .map_err(|e| err("cannot create the zenoh bridge's notifier", &e))?;
        Ok(RequestWaker {
            notifier,
            _events: events,
            _node: node,
        })
    }

    /// Wake the serving loop (a system call only when it sleeps).
    pub fn wake(&self) {
        let _ = self.notifier.notify();
    }
}

/// What the queryables' callbacks share (on zenoh's threads): a query is counted for its
/// session and queued for the serving loop, or refused.
struct Intake {
    sessions: Arc<Sessions>,
    tx: SyncSender<(Admitted, bool)>,
    refusals: SyncSender<(Query, Vec<u8>)>,
    counters: Arc<Counters>,
    wake: Box<dyn Fn() + Send + Sync>,
}

impl Intake {
    /// Take a query that came on the prediction key or (`observe`) the observe key.
    fn take(&self, query: Query, observe: bool) {
        match Admitted::new(query, &self.sessions) {
            Ok(admitted) => match self.tx.try_send((admitted, observe)) {
                Ok(()) => (self.wake)(),
                // (the channel has room for every admitted request: only at shutdown;
                // dropping it ends the query unanswered)
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {}
            },
            Err((query, why)) => {
                let counter = match why {
                    Refusal::Busy => &self.counters.busy,
                    Refusal::TooManySessions => &self.counters.too_many_sessions,
                };
                counter.fetch_add(1, Ordering::Relaxed);
                let refusal = refusal(query, why, &self.sessions);
                // never block zenoh's thread: without room the query is dropped (its
                // client sees no reply)
                if self.refusals.try_send(refusal).is_err() {
                    self.counters
                        .dropped_replies
                        .fetch_add(1, Ordering::Relaxed);
                }
            }
        }
    }
}

/// Counters of the frontend (shared with zenoh's threads).
#[derive(Debug, Default)]
struct Counters {
    busy: AtomicU64,
    too_many_sessions: AtomicU64,
    dropped_replies: AtomicU64,
}

/// What the frontend counted so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrontendStats {
    /// Requests answered [`Status::Busy`]: their session had its limit in flight.
    pub busy: u64,
    /// Requests answered [`Status::TooManySessions`]: the cap on sessions was reached.
    pub too_many_sessions: u64,
    /// Responses (or refusals) dropped because their thread was behind.
    pub dropped_replies: u64,
    /// Requests refused before decoding (bad size, bad version).
    pub malformed: u64,
}

/// An encoded reply and the query it answers.
type Outgoing = (Admitted, Vec<u8>);

/// The zenoh side of the daemon: a session and a queryable whose admitted requests wait
/// in a bounded channel for [`try_next`](Self::try_next).
pub struct ZenohFrontend {
    rx: Receiver<(Admitted, bool)>,
    replies: SyncSender<Outgoing>,
    // the queryables (prediction key, observe key) before the session (drop order)
    _queryables: [Queryable<()>; 2],
    session: zenoh::Session,
    sessions: Arc<Sessions>,
    max_rows: usize,
    rows: Vec<Observation>,
    counters: Arc<Counters>,
    malformed: u64,
    description: String,
    bound: MemoryBound,
}

impl std::fmt::Debug for ZenohFrontend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohFrontend")
            .field("serving", &self.description)
            .finish_non_exhaustive()
    }
}

impl ZenohFrontend {
    /// Open the zenoh session ([`zenoh_config`]) and declare the queryable on
    /// `settings.key`. `wake` is called (from a zenoh thread) after each request is
    /// queued; it must not block.
    pub fn start(
        settings: &ZenohSettings,
        limits: &Limits,
        wake: impl Fn() + Send + Sync + 'static,
    ) -> Result<ZenohFrontend, StartError> {
        let bad = |m: String| StartError::Settings(m);
        if settings.max_sessions == 0 || settings.max_active == 0 {
            return Err(bad(
                "remote sessions and requests in flight per session must be at least 1".into(),
            ));
        }
        if settings.max_message_bytes == Some(0) {
            return Err(bad(
                "the largest zenoh message must be at least 1 byte".into()
            ));
        }
        let config = zenoh_config(settings, limits).map_err(bad)?;
        if uses_tls_link(&config) {
            warn!("{}", tls_link_warning("--zenoh"));
        }
        let bound = MemoryBound::of(&config, limits, settings.max_sessions, settings.max_active)
            .map_err(bad)?;
        let key = zenoh::key_expr::KeyExpr::try_from(settings.key.clone())
            .map_err(|e| bad(format!("zenoh key expression '{}': {e}", settings.key)))?;
        let in_flight = settings.max_in_flight();
        // room for every admitted request: neither channel is ever full for them
        let (tx, rx) = sync_channel::<(Admitted, bool)>(in_flight);
        let (replies, reply_rx) = sync_channel::<Outgoing>(in_flight);
        let (refusals, refusal_rx) = sync_channel::<(Query, Vec<u8>)>(REFUSED_QUEUE);
        let counters = Arc::new(Counters::default());
        let sessions = Arc::new(Sessions::new(settings.max_sessions, settings.max_active));
        let (shared, callback_counters) = (sessions.clone(), counters.clone());
        let thread = |name: &str| std::thread::Builder::new().name(name.into());
        let failed = |e: std::io::Error| StartError::Zenoh(format!("cannot start a thread: {e}"));
        thread("cliffd-zenoh-reply")
            .spawn(move || {
                while let Ok((admitted, bytes)) = reply_rx.recv() {
                    send_reply(admitted.query(), bytes);
                    // dropping it ends the query and frees its place
                }
            })
            .map_err(failed)?;
        thread("cliffd-zenoh-refuse")
            .spawn(move || {
                while let Ok((query, bytes)) = refusal_rx.recv() {
                    send_reply(&query, bytes);
                }
            })
            .map_err(failed)?;
        // zenoh's runtimes' threads start from a thread of lower priority (priority.rs)
        // and inherit it. The two reply threads above keep the daemon's: they only hand
        // encoded bytes to zenoh, and a refusal that waits too long is dropped.
        let observe_key = zenoh::key_expr::KeyExpr::try_from(observe_key_for(&settings.key))
            .map_err(|e| bad(format!("zenoh key expression of observations: {e}")))?;
        let intake = Arc::new(Intake {
            sessions: shared,
            tx,
            refusals,
            counters: callback_counters,
            wake: Box::new(wake),
        });
        let (for_predict, for_observe) = (intake.clone(), intake);
        let opened = priority::on_lowered_thread(settings.nice, move || {
            let session = zenoh::open(config)
                .wait()
                .map_err(|e| StartError::Zenoh(format!(
                    "cannot open the session: {e} (is the endpoint's port free? see docs/troubleshooting.md)"
                )))?;
            let declare = |key, intake: Arc<Intake>, observe| {
                session
                    .declare_queryable(key)
                    .callback(move |query: Query| intake.take(query, observe))
                    .wait()
                    .map_err(|e| StartError::Zenoh(format!("cannot declare the queryable: {e}")))
            };
            let queryable = declare(key, for_predict, false)?;
            let observe = declare(observe_key, for_observe, true)?;
            Ok::<_, StartError>((session.clone(), [queryable, observe]))
        });
        let (session, queryables) = opened.map_err(|e| {
            StartError::Zenoh(format!(
                "cannot start zenoh's threads at nice +{}: {e}",
                settings.nice
            ))
        })??;
        let rows = max_rows(limits);
        let description = if settings.endpoints.is_empty() {
            format!("zenoh key '{}'", settings.key)
        } else {
            format!(
                "zenoh key '{}' on {}",
                settings.key,
                settings.endpoints.join(", ")
            )
        };
        Ok(ZenohFrontend {
            rx,
            replies,
            _queryables: queryables,
            session,
            sessions,
            max_rows: rows,
            rows: Vec::with_capacity(rows),
            counters,
            malformed: 0,
            description,
            bound,
        })
    }

    /// `zenoh key 'cliff/predict' on tcp/127.0.0.1:7447`, for the ready line.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Answer map queries of daemons that follow this one's maps ([`MapServer`]),
    /// starting with `maps` (name, version, set).
    pub fn serve_maps(
        &self,
        service: &str,
        maps: Vec<(String, u32, cliff::map::MapSet)>,
    ) -> Result<MapServer, StartError> {
        MapServer::start(&self.session, service, maps)
    }

    /// The zenoh session id (for logs).
    pub fn zid(&self) -> String {
        self.session.zid().to_string()
    }

    /// What remote clients may cost this daemon in memory at most.
    pub fn memory_bound(&self) -> &MemoryBound {
        &self.bound
    }

    /// Remote requests in flight now (admitted, not yet answered).
    pub fn in_flight(&self) -> usize {
        self.sessions.in_flight()
    }

    /// Counters so far.
    pub fn stats(&self) -> FrontendStats {
        FrontendStats {
            busy: self.counters.busy.load(Ordering::Relaxed),
            too_many_sessions: self.counters.too_many_sessions.load(Ordering::Relaxed),
            dropped_replies: self.counters.dropped_replies.load(Ordering::Relaxed),
            malformed: self.malformed,
        }
    }

    /// The next queued request, decoded, or `None` when none waits. Requests that are
    /// not well-formed messages (too short, ragged, more rows than the limits allow, or
    /// another protocol version) are answered here with [`Status::BadLayout`] or
    /// [`Status::BadVersion`] (in the layout every version reads,
    /// [`wire::encode_bad_version`]) and skipped. Never blocks.
    pub fn try_next(&mut self) -> Option<RemoteRequest<'_>> {
        loop {
            let (mut admitted, observe_key) = match self.rx.try_recv() {
                Ok(q) => q,
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return None,
            };
            let decoded = {
                let bytes = admitted.query().payload().map(|p| p.to_bytes());
                let bytes: &[u8] = bytes.as_deref().unwrap_or(&[]);
                wire::decode_request(bytes, self.max_rows, &mut self.rows)
                    .map_err(|e| (e, wire::peek_request_id(bytes)))
            };
            // the rows are copied out: zenoh's buffer can go
            admitted.forget_payload();
            match decoded {
                Ok(header) => {
                    return Some(RemoteRequest {
                        admitted,
                        observe_key,
                        header,
                        rows: &self.rows,
                        replies: &self.replies,
                        counters: &self.counters,
                    });
                }
                Err((e, request_id)) => {
                    self.malformed += 1;
                    debug!(request_id, "malformed zenoh request: {e}");
                    let mut bytes = Vec::new();
                    if let wire::WireError::Version { .. } = e {
                        // in the layout every version reads
                        wire::encode_bad_version(request_id, &mut bytes);
                    } else {
                        let mut h = ResponseHeader {
                            version: PROTOCOL_VERSION,
                            request_id,
                            ..ResponseHeader::default()
                        };
                        e.rejection().write_to(&mut h);
                        wire::encode_response(&h, &[], &mut bytes);
                    }
                    send_bytes(&self.replies, &self.counters, admitted, bytes);
                }
            }
        }
    }
}

/// One decoded remote request; answer it with [`reply`](Self::reply) or
/// [`reject`](Self::reject) (dropping it unanswered ends the query with no reply).
pub struct RemoteRequest<'f> {
    admitted: Admitted,
    observe_key: bool,
    header: RequestHeader,
    rows: &'f [Observation],
    replies: &'f SyncSender<Outgoing>,
    counters: &'f Arc<Counters>,
}

impl RemoteRequest<'_> {
    /// The request header (its `listener_id` is always zero).
    pub fn header(&self) -> &RequestHeader {
        &self.header
    }

    /// The rows, as sent (validated by the caller).
    pub fn rows(&self) -> &[Observation] {
        self.rows
    }

    /// Whether the query came on the observe key ([`observe_key_for`]) rather than the
    /// prediction key: only there are observations taken.
    pub fn on_observe_key(&self) -> bool {
        self.observe_key
    }

    /// The remote session the request counts for ([`session_of`]).
    pub fn session(&self) -> u128 {
        self.admitted.session()
    }

    /// Send the response `h` with `payload` (the words [`ResponseHeader::payload_words`]
    /// says). Returns at once: the bytes go to the reply thread; `false` when its queue
    /// was full and the response was dropped.
    pub fn reply(self, h: &ResponseHeader, payload: &[u32]) -> bool {
        send(self.replies, self.counters, self.admitted, h, payload)
    }

    /// Refuse the request with `rejection` (shape zero, no payload).
    pub fn reject(self, rejection: &Rejection) -> bool {
        let h = rejected(self.header.request_id, rejection);
        send(self.replies, self.counters, self.admitted, &h, &[])
    }
}

impl<'f> RemoteRequest<'f> {
    /// Keep the query for an answer later (after the scheduler has predicted it); the
    /// rows are no longer needed once decoded.
    pub fn into_pending(self) -> PendingReply {
        PendingReply {
            request_id: self.header.request_id,
            admitted: self.admitted,
            replies: self.replies.clone(),
            counters: self.counters.clone(),
        }
    }
}

/// A remote request waiting for its answer (see [`RemoteRequest::into_pending`]).
pub struct PendingReply {
    admitted: Admitted,
    request_id: u64,
    replies: SyncSender<Outgoing>,
    counters: Arc<Counters>,
}

impl PendingReply {
    /// Send the response `h` with `payload`, as [`RemoteRequest::reply`].
    pub fn reply(self, h: &ResponseHeader, payload: &[u32]) -> bool {
        send(&self.replies, &self.counters, self.admitted, h, payload)
    }

    /// Refuse the request with `rejection`, as [`RemoteRequest::reject`].
    pub fn reject(self, rejection: &Rejection) -> bool {
        let h = rejected(self.request_id, rejection);
        send(&self.replies, &self.counters, self.admitted, &h, &[])
    }
}

/// The response header refusing request `request_id` with `rejection`.
fn rejected(request_id: u64, rejection: &Rejection) -> ResponseHeader {
    let mut h = ResponseHeader {
        version: PROTOCOL_VERSION,
        request_id,
        ..ResponseHeader::default()
    };
    rejection.write_to(&mut h);
    h
}

fn send(
    replies: &SyncSender<Outgoing>,
    counters: &Counters,
    admitted: Admitted,
    h: &ResponseHeader,
    payload: &[u32],
) -> bool {
    // zenoh takes the buffer over (no copy), so each response has its own
    let mut bytes = Vec::new();
    wire::encode_response(h, payload, &mut bytes);
    send_bytes(replies, counters, admitted, bytes)
}

fn send_bytes(
    replies: &SyncSender<Outgoing>,
    counters: &Counters,
    admitted: Admitted,
    bytes: Vec<u8>,
) -> bool {
    match replies.try_send((admitted, bytes)) {
        Ok(()) => true,
        Err(_) => {
            counters.dropped_replies.fetch_add(1, Ordering::Relaxed);
            false
        }
    }
}

/// The answer to a query refused before it was queued ([`Status::Busy`] with the
/// requests in flight per session in `limit`, or [`Status::TooManySessions`] with the
/// cap on sessions), read from its request id only; the query lets go of its payload
/// and attachment at once.
fn refusal(mut query: Query, why: Refusal, sessions: &Sessions) -> (Query, Vec<u8>) {
    // the request id is bytes 8 to 16: only the first 16 bytes are read
    let mut head = [0u8; 16];
    let mut got = 0;
    if let Some(p) = query.payload() {
        let mut reader = p.reader();
        while got < head.len() {
            match std::io::Read::read(&mut reader, &mut head[got..]) {
                Ok(0) | Err(_) => break,
                Ok(n) => got += n,
            }
        }
    }
    let request_id = wire::peek_request_id(&head[..got]);
    sessions::forget_bytes(&mut query);
    let (status, limit) = match why {
        Refusal::Busy => (Status::Busy, sessions.max_active()),
        Refusal::TooManySessions => (Status::TooManySessions, sessions.max_sessions()),
    };
    let h = rejected(
        request_id,
        &Rejection {
            status,
            agent: None,
            row: None,
            field: Field::None,
            limit: limit.min(u32::MAX as usize) as u32,
        },
    );
    let mut bytes = Vec::new();
    wire::encode_response(&h, &[], &mut bytes);
    (query, bytes)
}

/// Send one reply to `query` (the caller drops it, which ends the query).
fn send_reply(query: &Query, bytes: Vec<u8>) {
    if let Err(e) = query
        .reply(query.key_expr().clone(), ZBytes::from(bytes))
        .wait()
    {
        warn!("zenoh reply failed: {e}");
    }
}
