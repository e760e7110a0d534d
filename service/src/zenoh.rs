//! Remote clients over zenoh (feature `zenoh`): a queryable that hands requests to the
//! serving loop, which answers them through the same validation, limits and prediction
//! as local iceoryx2 requests.
//!
//! The serving loop sees no zenoh type: [`ZenohFrontend::try_next`] gives a decoded
//! [`RemoteRequest`] (header and rows, see [`cliff_client::wire`]) and
//! [`RemoteRequest::reply`] / [`RemoteRequest::reject`] answer it. Threads:
//!
//! * zenoh's own (network, rx, tx): the queryable's callback only moves the query into
//!   a bounded channel of [`ZenohSettings::queue`] entries and wakes the serving loop;
//!   when the channel is full it answers at once with [`Status::Internal`] (limit = the
//!   queue length: "busy, retry") without touching the serving loop;
//! * the serving loop: decodes (size checks before anything is allocated, bounded by
//!   the daemon's limits), predicts, encodes the response;
//! * `cliffd-zenoh-reply`: sends the encoded responses, so that a remote link that is
//!   slow or stuck (zenoh blocks a reply when the query asked for blocking congestion
//!   control) never stalls the serving loop. When its queue is full the response is
//!   dropped and that client sees its deadline pass.
//!
//! Safe defaults (see [`zenoh_config`]): peer mode, listening only on the given
//! endpoints, multicast and gossip scouting off, received messages limited to what the
//! largest allowed request needs.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, TrySendError, sync_channel};

use cliff_client::protocol::{
    Limits, Observation, PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader, Status,
};
use cliff_client::wire;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;
use tracing::{debug, warn};
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::query::{Query, Queryable};

use crate::settings::StartError;

/// Where and how the daemon serves remote clients.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ZenohSettings {
    /// Endpoints to listen on (`tcp/127.0.0.1:7447`, `tls/host:7447`); they replace the
    /// configuration file's `listen.endpoints`. Empty and no file: nothing listens (the
    /// daemon can still reach a router named in the file's `connect.endpoints`).
    pub endpoints: Vec<String>,
    /// A full zenoh configuration (JSON5): TLS, access control, scouting, connect.
    pub config_file: Option<PathBuf>,
    /// The key expression of the queryable ([`key_expr_for`] of the service name).
    pub key: String,
    /// Requests waiting for the serving loop at most; more are answered "busy".
    pub queue: usize,
}

impl ZenohSettings {
    /// Settings for the iceoryx2 service `service` listening on `endpoints`.
    pub fn new(service: &str, endpoints: Vec<String>, config_file: Option<PathBuf>) -> Self {
        ZenohSettings {
            endpoints,
            config_file,
            key: key_expr_for(service),
            queue: 64,
        }
    }
}

/// The zenoh key expression a daemon serving the iceoryx2 service `service` answers on:
/// the service name itself (`cliff/predict`); clients derive it the same way.
pub fn key_expr_for(service: &str) -> String {
    cliff_client::zenoh::key_expr_for(service)
}

/// The zenoh configuration of the daemon: the file (if any), then cliffd's safe values
/// for what the file does not name: `mode` peer; `scouting.multicast` and
/// `scouting.gossip` off; `transport.link.rx.max_message_size` the largest request the
/// `limits` allow plus 4 KiB; `listen.endpoints` none. `endpoints`, when given,
/// replace `listen.endpoints`. (A key counts as named when the file's text has it
/// followed by a colon: [`cliff_client::zenoh::config_names`].)
pub fn zenoh_config(s: &ZenohSettings, limits: &Limits) -> Result<zenoh::Config, String> {
    let (mut config, text) = match &s.config_file {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            let c = zenoh::Config::from_json5(&text)
                .map_err(|e| format!("zenoh config {}: {e}", p.display()))?;
            (c, text)
        }
        None => (zenoh::Config::default(), String::new()),
    };
    let named = |key: &str| cliff_client::zenoh::config_names(&text, key);
    let mut set = |key: &str, value: String| {
        config
            .insert_json5(key, &value)
            .map_err(|e| format!("zenoh config {key} = {value}: {e}"))
    };
    if !named("mode") {
        set("mode", r#""peer""#.into())?;
    }
    if !named("multicast") {
        set("scouting/multicast/enabled", "false".into())?;
    }
    if !named("gossip") {
        set("scouting/gossip/enabled", "false".into())?;
    }
    if !named("max_message_size") {
        let bytes = max_request_bytes(limits) + 4096;
        set("transport/link/rx/max_message_size", bytes.to_string())?;
    }
    if !s.endpoints.is_empty() || !named("listen") {
        let list = s
            .endpoints
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(",");
        set("listen/endpoints", format!("[{list}]"))?;
    }
    Ok(config)
}

/// Rows per request the daemon decodes at most (every agent at the longest history).
pub fn max_rows(limits: &Limits) -> usize {
    limits.max_agents as usize * limits.max_history as usize
}

/// Bytes of the largest request the limits allow.
pub fn max_request_bytes(limits: &Limits) -> usize {
    wire::REQUEST_HEADER_BYTES + max_rows(limits) * wire::ROW_BYTES
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

/// Counters of the frontend (shared with zenoh's threads).
#[derive(Debug, Default)]
struct Counters {
    busy: AtomicU64,
    dropped_replies: AtomicU64,
}

/// What the frontend counted so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrontendStats {
    /// Requests answered "busy" because the queue was full.
    pub busy: u64,
    /// Responses dropped because the reply thread was behind.
    pub dropped_replies: u64,
    /// Requests refused before decoding (bad size, bad version).
    pub malformed: u64,
}

/// The zenoh side of the daemon: a session and a queryable whose requests wait in a
/// bounded channel for [`try_next`](Self::try_next).
pub struct ZenohFrontend {
    rx: Receiver<Query>,
    replies: SyncSender<(Query, Vec<u8>)>,
    // the queryable before the session (drop order)
    _queryable: Queryable<()>,
    session: zenoh::Session,
    max_rows: usize,
    rows: Vec<Observation>,
    counters: Arc<Counters>,
    malformed: u64,
    description: String,
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
        if settings.queue == 0 {
            return Err(bad(
                "the zenoh request queue needs at least one entry".into()
            ));
        }
        let config = zenoh_config(settings, limits).map_err(bad)?;
        let key = zenoh::key_expr::KeyExpr::try_from(settings.key.clone())
            .map_err(|e| bad(format!("zenoh key expression '{}': {e}", settings.key)))?;
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| StartError::Zenoh(format!("cannot open the session: {e}")))?;
        let (tx, rx) = sync_channel::<Query>(settings.queue);
        let (replies, reply_rx) = sync_channel::<(Query, Vec<u8>)>(settings.queue);
        std::thread::Builder::new()
            .name("cliffd-zenoh-reply".into())
            .spawn(move || send_replies(reply_rx))
            .map_err(|e| StartError::Zenoh(format!("cannot start the reply thread: {e}")))?;
        let counters = Arc::new(Counters::default());
        let queue = settings.queue;
        let (busy_replies, busy_counters) = (replies.clone(), counters.clone());
        let queryable = session
            .declare_queryable(key)
            .callback(move |query: Query| match tx.try_send(query) {
                Ok(()) => wake(),
                Err(TrySendError::Full(query)) => {
                    busy_counters.busy.fetch_add(1, Ordering::Relaxed);
                    let bytes = busy_response(&query, queue);
                    // never block zenoh's thread: without room the query is dropped
                    // (its client sees no reply)
                    let _ = busy_replies.try_send((query, bytes));
                }
                Err(TrySendError::Disconnected(_)) => {} // shutting down
            })
            .wait()
            .map_err(|e| StartError::Zenoh(format!("cannot declare the queryable: {e}")))?;
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
            _queryable: queryable,
            session,
            max_rows: rows,
            rows: Vec::with_capacity(rows),
            counters,
            malformed: 0,
            description,
        })
    }

    /// `zenoh key 'cliff/predict' on tcp/127.0.0.1:7447`, for the ready line.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The zenoh session id (for logs).
    pub fn zid(&self) -> String {
        self.session.zid().to_string()
    }

    /// Counters so far.
    pub fn stats(&self) -> FrontendStats {
        FrontendStats {
            busy: self.counters.busy.load(Ordering::Relaxed),
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
            let query = match self.rx.try_recv() {
                Ok(q) => q,
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return None,
            };
            let decoded = {
                let bytes = query.payload().map(|p| p.to_bytes());
                let bytes: &[u8] = bytes.as_deref().unwrap_or(&[]);
                wire::decode_request(bytes, self.max_rows, &mut self.rows)
                    .map_err(|e| (e, wire::peek_request_id(bytes)))
            };
            match decoded {
                Ok(header) => {
                    return Some(RemoteRequest {
                        query,
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
                    send_bytes(&self.replies, &self.counters, query, bytes);
                }
            }
        }
    }
}

/// One decoded remote request; answer it with [`reply`](Self::reply) or
/// [`reject`](Self::reject) (dropping it unanswered ends the query with no reply).
pub struct RemoteRequest<'f> {
    query: Query,
    header: RequestHeader,
    rows: &'f [Observation],
    replies: &'f SyncSender<(Query, Vec<u8>)>,
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

    /// Send the response `h` with `payload` (the words [`ResponseHeader::payload_words`]
    /// says). Returns at once: the bytes go to the reply thread; `false` when its queue
    /// was full and the response was dropped.
    pub fn reply(self, h: &ResponseHeader, payload: &[u32]) -> bool {
        send(self.replies, self.counters, self.query, h, payload)
    }

    /// Refuse the request with `rejection` (shape zero, no payload).
    pub fn reject(self, rejection: &Rejection) -> bool {
        let mut h = ResponseHeader {
            version: PROTOCOL_VERSION,
            request_id: self.header.request_id,
            ..ResponseHeader::default()
        };
        rejection.write_to(&mut h);
        send(self.replies, self.counters, self.query, &h, &[])
    }
}

impl<'f> RemoteRequest<'f> {
    /// Keep the query for an answer later (after the scheduler has predicted it); the
    /// rows are no longer needed once decoded.
    pub fn into_pending(self) -> PendingReply {
        PendingReply {
            request_id: self.header.request_id,
            query: self.query,
            replies: self.replies.clone(),
            counters: self.counters.clone(),
        }
    }
}

/// A remote request waiting for its answer (see [`RemoteRequest::into_pending`]).
pub struct PendingReply {
    query: Query,
    request_id: u64,
    replies: SyncSender<(Query, Vec<u8>)>,
    counters: Arc<Counters>,
}

impl PendingReply {
    /// Send the response `h` with `payload`, as [`RemoteRequest::reply`].
    pub fn reply(self, h: &ResponseHeader, payload: &[u32]) -> bool {
        send(&self.replies, &self.counters, self.query, h, payload)
    }

    /// Refuse the request with `rejection`, as [`RemoteRequest::reject`].
    pub fn reject(self, rejection: &Rejection) -> bool {
        let mut h = ResponseHeader {
            version: PROTOCOL_VERSION,
            request_id: self.request_id,
            ..ResponseHeader::default()
        };
        rejection.write_to(&mut h);
        send(&self.replies, &self.counters, self.query, &h, &[])
    }
}

fn send(
    replies: &SyncSender<(Query, Vec<u8>)>,
    counters: &Counters,
    query: Query,
    h: &ResponseHeader,
    payload: &[u32],
) -> bool {
    // zenoh takes the buffer over (no copy), so each response has its own
    let mut bytes = Vec::new();
    wire::encode_response(h, payload, &mut bytes);
    send_bytes(replies, counters, query, bytes)
}

fn send_bytes(
    replies: &SyncSender<(Query, Vec<u8>)>,
    counters: &Counters,
    query: Query,
    bytes: Vec<u8>,
) -> bool {
    match replies.try_send((query, bytes)) {
        Ok(()) => true,
        Err(_) => {
            counters.dropped_replies.fetch_add(1, Ordering::Relaxed);
            false
        }
    }
}

/// The "busy" answer for a query that found the queue full.
fn busy_response(query: &Query, queue: usize) -> Vec<u8> {
    let request_id = query
        .payload()
        .map(|p| wire::peek_request_id(&p.to_bytes()))
        .unwrap_or(0);
    let mut h = ResponseHeader {
        version: PROTOCOL_VERSION,
        request_id,
        ..ResponseHeader::default()
    };
    Rejection {
        status: Status::Internal,
        agent: None,
        row: None,
        field: cliff_client::Field::None,
        limit: queue.min(u32::MAX as usize) as u32,
    }
    .write_to(&mut h);
    let mut bytes = Vec::new();
    wire::encode_response(&h, &[], &mut bytes);
    bytes
}

/// The reply thread: one reply per query, then the query is dropped (which ends it).
fn send_replies(rx: Receiver<(Query, Vec<u8>)>) {
    while let Ok((query, bytes)) = rx.recv() {
        if let Err(e) = query
            .reply(query.key_expr().clone(), ZBytes::from(bytes))
            .wait()
        {
            warn!("zenoh reply failed: {e}");
        }
        drop(query);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(c: &zenoh::Config, key: &str) -> String {
        c.get_json(key).unwrap()
    }

    #[test]
    fn the_daemon_config_is_a_peer_listening_only_where_asked() {
        let limits = Limits::default();
        let s = ZenohSettings::new("cliff/predict", vec!["tcp/127.0.0.1:7447".into()], None);
        assert_eq!(s.key, "cliff/predict");
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "mode"), r#""peer""#);
        assert_eq!(get(&c, "scouting/multicast/enabled"), "false");
        assert_eq!(get(&c, "scouting/gossip/enabled"), "false");
        assert_eq!(get(&c, "listen/endpoints"), r#"["tcp/127.0.0.1:7447"]"#);
        // 32 agents x 64 rows x 48 bytes + the 184-byte header + 4096
        let want = 32 * 64 * 48 + 184 + 4096;
        assert_eq!(
            get(&c, "transport/link/rx/max_message_size"),
            want.to_string()
        );
        // no endpoint and no file: no listener at all (a peer's default is every interface)
        let c = zenoh_config(&ZenohSettings::new("cliff/predict", vec![], None), &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), "[]");
    }

    #[test]
    fn a_config_file_keeps_what_it_names_and_gets_safe_values_for_the_rest() {
        let dir = std::env::temp_dir().join(format!("cliffd-zenoh-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("cliffd.json5");
        std::fs::write(
            &f,
            r#"{ scouting: { gossip: { enabled: true } },
                 listen: { endpoints: ["tcp/127.0.0.1:7999"] },
                 transport: { link: { tls: { listen_certificate: "x.pem" } } } }"#,
        )
        .unwrap();
        let limits = Limits::default();
        let mut s = ZenohSettings::new("cliff/predict", vec![], Some(f.clone()));
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "scouting/gossip/enabled"), "true");
        assert_eq!(get(&c, "scouting/multicast/enabled"), "false");
        assert!(get(&c, "listen/endpoints").contains("7999"));
        s.endpoints = vec!["tcp/127.0.0.1:7448".into()];
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), r#"["tcp/127.0.0.1:7448"]"#);
        // a file that does not name `listen` (only listen_certificate) listens nowhere
        std::fs::write(
            &f,
            r#"{ transport: { link: { tls: { listen_certificate: "x.pem" } } } }"#,
        )
        .unwrap();
        s.endpoints.clear();
        let c = zenoh_config(&s, &limits).unwrap();
        assert_eq!(get(&c, "listen/endpoints"), "[]");
        std::fs::write(&f, "{ scouting: ").unwrap();
        let e = zenoh_config(&s, &limits).unwrap_err();
        assert!(e.contains("cliffd.json5"), "{e}");
        let e = zenoh_config(
            &ZenohSettings::new("x", vec![], Some(dir.join("none.json5"))),
            &limits,
        )
        .unwrap_err();
        assert!(e.contains("none.json5"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
