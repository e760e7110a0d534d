//! # cliff-client: talk to the `cliffd` prediction daemon over iceoryx2 shared memory
//!
//! * [`protocol`]: the wire types (`#[repr(C)]`, versioned) and the request validation
//!   shared with the daemon, plus the in-process reference [`LocalPredictor`];
//!   [`legacy`]: version 1's types, with which a daemon answers old clients
//!   `bad-version`.
//! * [`Client`]: connect to a daemon, send a [`Request`], get a [`Prediction`] that
//!   borrows the response in shared memory (no copy).
//! * [`ffi`]: the C ABI (header `client/include/cliff_client.h`).
//! * [`wire`]: the same messages as little-endian bytes, for transports other than
//!   iceoryx2 (`docs/zenoh-protocol.md`).
//! * `zenoh` (feature `zenoh`): [`Client::connect_zenoh`] reaches a daemon on another
//!   host with the same [`Request`], [`Prediction`] and errors.
//!
//! ```no_run
//! use cliff_client::{Client, Observation, Request};
//! use cliff::predict::Params;
//!
//! let mut client = Client::connect("cliff/predict")?;
//! let mut request = Request::new("demo", &Params::default())?;
//! // one person walking east, observed at 2.5 Hz
//! request.add_agent((0..4).map(|i| Observation::position(0.4 * i as f64, -10.0 + 0.5 * i as f64, 0.5)));
//! let prediction = client.predict(&request)?;
//! for agent in prediction.agents() {
//!     for sample in agent.samples() {
//!         for [x, y] in sample {
//!             let _ = (x, y); // a predicted position every dt seconds
//!         }
//!     }
//! }
//! # Ok::<(), cliff_client::Error>(())
//! ```
//!
//! ## Waiting
//!
//! [`WaitMode::Spin`] busy-polls for the response (lowest latency, one core busy while
//! waiting); [`WaitMode::Block`] sleeps on an iceoryx2 event the daemon signals (no CPU,
//! but a wake-up across cores costs tens of microseconds); [`WaitMode::Hybrid`], the
//! default, spins for [`ClientOptions::spin`] and then blocks.
//!
//! ## Failures
//!
//! Every call has a deadline ([`ClientOptions::deadline`]). [`Error::NoDaemon`] means no
//! daemon serves the service, [`Error::DaemonGone`] that it died while the request was
//! in flight, [`Error::Deadline`] that no answer came in time, [`Error::Rejected`] that
//! the daemon refused the request (with the [`Status`] and where). After a daemon
//! restart the same `Client` works again: there is nothing to rebuild.
#![warn(missing_docs)]

pub mod ffi;
pub mod legacy;
pub mod protocol;
pub mod wire;
#[cfg(feature = "zenoh")]
pub mod zenoh;

use std::fmt;
use std::marker::PhantomData;
use std::time::{Duration, Instant};

use cliff::predict::{Method, Options, Params};
use iceoryx2::port::client::Client as IoxClient;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;
use iceoryx2::response::Response;

pub use protocol::{
    Field, KIND_RELOAD, Limits, LocalPredictor, MapTime, Observation, PROTOCOL_VERSION, Rejection,
    RequestHeader, ResponseHeader, Status,
};

/// The service name `cliffd` serves on by default.
pub const DEFAULT_SERVICE: &str = "cliff/predict";

/// Environment variable naming the iceoryx2 prefix (namespace) used when
/// [`ClientOptions::prefix`] is not set; `cliffd --prefix` reads it too.
pub const PREFIX_ENV: &str = "CLIFF_IPC_PREFIX";

/// Name of the event service a client signals after sending a request (wakes a
/// sleeping daemon).
pub fn request_event_name(service: &str) -> String {
    format!("{service}/requests")
}

/// Name of the event service the daemon signals a blocking client on.
pub fn response_event_name(service: &str) -> String {
    format!("{service}/responses")
}

/// The iceoryx2 configuration for an optional prefix (namespace): processes with
/// different prefixes never see each other. Starts from iceoryx2's built-in defaults
/// (not a config file), so that daemon and clients always agree.
pub fn iceoryx_config(prefix: Option<&str>) -> Result<Config, String> {
    let mut config = Config::default();
    if let Some(p) = prefix {
        config.global.prefix = FileName::new(p.as_bytes())
            .map_err(|e| format!("iceoryx2 prefix '{p}' is not a valid file name: {e:?}"))?;
    }
    Ok(config)
}

/// The prefix from [`PREFIX_ENV`], if set and not empty.
pub fn prefix_from_env() -> Option<String> {
    std::env::var(PREFIX_ENV).ok().filter(|s| !s.is_empty())
}

/// The iceoryx2 service variant of a [`Client`]'s ports: `ipc_threadsafe`, so that a
/// client can move to (or be shared with) another thread. It talks to a daemon on plain
/// `ipc` ports: both variants use the same shared-memory resources.
pub type ClientIpc = ipc_threadsafe::Service;

/// The iceoryx2 request-response service type of the protocol (`S`: the daemon's plain
/// `ipc` by default, [`ClientIpc`] for clients).
pub type PredictService<S = ipc::Service> =
    iceoryx2::service::port_factory::request_response::PortFactory<
        S,
        [Observation],
        RequestHeader,
        [u32],
        ResponseHeader,
    >;

/// How a client waits for its response.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WaitMode {
    /// Busy-poll until the response is there. Needs a core of its own: on a host with
    /// more busy threads than cores, use [`WaitMode::Hybrid`].
    Spin,
    /// Busy-poll for [`ClientOptions::spin`], then sleep on the daemon's event. When
    /// the daemon has gone to sleep since this client's last response (its responses
    /// say how long it stays awake; other clients' requests may have kept it awake
    /// since, which this client cannot see), sleep at once: the daemon has to be woken
    /// first, and a spinning client only delays that on a busy or virtualised host.
    /// Likewise when the daemon had other requests in progress at its last response
    /// ([`ResponseHeader::busy`]), or the last round trip took longer than the spin:
    /// with clients queueing, spinning clients take the cores the daemon needs (four
    /// spinning clients on two cores cost it a third of its throughput), and a response
    /// that has to wait for others is not worth a spin. A client alone keeps spinning.
    #[default]
    Hybrid,
    /// Sleep on the daemon's event at once.
    Block,
}

impl std::str::FromStr for WaitMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "spin" => Ok(WaitMode::Spin),
            "hybrid" | "spin-then-block" => Ok(WaitMode::Hybrid),
            "block" => Ok(WaitMode::Block),
            other => Err(format!(
                "unknown wait mode '{other}' (expected spin, hybrid or block)"
            )),
        }
    }
}

impl fmt::Display for WaitMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WaitMode::Spin => "spin",
            WaitMode::Hybrid => "hybrid",
            WaitMode::Block => "block",
        })
    }
}

/// Settings of a [`Client`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClientOptions {
    /// How to wait for responses (default [`WaitMode::Hybrid`]).
    pub wait: WaitMode,
    /// How long [`WaitMode::Hybrid`] spins before it blocks (default 200 us).
    pub spin: Duration,
    /// Deadline of each call (default 1 s).
    pub deadline: Duration,
    /// iceoryx2 prefix (namespace); default: the [`PREFIX_ENV`] variable, else iceoryx2's.
    pub prefix: Option<String>,
}

impl Default for ClientOptions {
    fn default() -> Self {
        ClientOptions {
            wait: WaitMode::Hybrid,
            spin: Duration::from_micros(200),
            deadline: Duration::from_secs(1),
            prefix: prefix_from_env(),
        }
    }
}

/// Why a call failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// No daemon serves this service (never started, or stopped).
    #[error("no cliffd daemon serves '{service}' (is it running, with the same --prefix?)")]
    NoDaemon {
        /// The service name.
        service: String,
    },
    /// The daemon died or shut down while the request was in flight.
    #[error("the cliffd daemon serving '{service}' is gone (died or shut down mid-request)")]
    DaemonGone {
        /// The service name.
        service: String,
    },
    /// No response within the deadline.
    #[error("no response within the deadline of {deadline:?}")]
    Deadline {
        /// The deadline that passed.
        deadline: Duration,
    },
    /// The daemon refused the request.
    #[error("request rejected by cliffd: {0}")]
    Rejected(Rejection),
    /// The request cannot be sent as it is (caught before sending).
    #[error("invalid request: {0}")]
    InvalidRequest(String),
    /// The response breaks the protocol, or the daemon speaks another protocol version
    /// (a daemon of version 1 found at connect time; a daemon of a later version
    /// answers `bad-version`, which is reported as this).
    #[error("protocol: {0}")]
    Protocol(String),
    /// iceoryx2 failed (shared memory, permissions, limits).
    #[error("iceoryx2: {0}")]
    Ipc(String),
    /// zenoh failed (configuration, session) or answered with an error.
    #[error("zenoh: {0}")]
    Zenoh(String),
}

impl Error {
    /// The rejection status, when the daemon refused the request.
    pub fn status(&self) -> Option<Status> {
        match self {
            Error::Rejected(r) => Some(r.status),
            _ => None,
        }
    }
}

/// The error for a daemon that speaks another protocol version.
pub(crate) fn version_mismatch(daemon: u32) -> Error {
    Error::Protocol(format!(
        "the daemon speaks protocol version {daemon}, this client {PROTOCOL_VERSION}"
    ))
}

fn ipc_err(what: &str, e: impl fmt::Debug) -> Error {
    Error::Ipc(format!("{what}: {e:?}"))
}

/// A prediction request: map, parameters and the agents' observed histories. Reuse it
/// between calls ([`clear_agents`](Self::clear_agents) keeps the allocation).
///
/// Beyond [`Params`], a request may ask for another method, the options beyond the
/// paper, a score per sample and a map of the time of day:
///
/// ```
/// use cliff::predict::Params;
/// use cliff_client::{MapTime, Request};
///
/// let r = Request::new("atc", &Params::default())?
///     .speed_beta(2.0) // the speed follows the map's
///     .coast(6.0) // 6 s at constant velocity where the map has no data
///     .scores(true) // a score per sample: Prediction::scores, best_sample
///     .time(1_351_700_000.0); // the map of that time of day (default: the daemon's clock)
/// let o = r.options();
/// assert_eq!((o.speed_beta, o.coast, o.scores), (2.0, 6.0, true));
/// assert_eq!(r.map_time(), MapTime::At(1_351_700_000.0));
/// # Ok::<(), cliff_client::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    header: RequestHeader,
    rows: Vec<Observation>,
}

impl Request {
    /// A request against the map `map` with `params` and no agents yet.
    pub fn new(map: &str, params: &Params) -> Result<Self, Error> {
        let mut header = RequestHeader::from_params(params);
        header.set_map_name(map).map_err(Error::InvalidRequest)?;
        Ok(Request {
            header,
            rows: Vec::new(),
        })
    }

    /// Replace the parameters (keeps map, agents, options and map time).
    pub fn set_params(&mut self, params: &Params) {
        let keep = self.header;
        self.header = RequestHeader {
            map: keep.map,
            agents: keep.agents,
            speed_beta: keep.speed_beta,
            coast: keep.coast,
            flags: keep.flags,
            time_mode: keep.time_mode,
            time: keep.time,
            ..RequestHeader::from_params(params)
        };
    }

    /// With the method `method` (the parameters' method otherwise).
    pub fn method(mut self, method: Method) -> Self {
        self.header.method = protocol::method_code(method);
        self
    }

    /// With the speed kernel parameter ([`Options::speed_beta`]; 0, the default, keeps
    /// the observed speed).
    pub fn speed_beta(mut self, speed_beta: f64) -> Self {
        self.header.speed_beta = speed_beta;
        self
    }

    /// With `seconds` of coasting where the map has no data ([`Options::coast`], at most
    /// the horizon; 0, the default, stops a sample there).
    pub fn coast(mut self, seconds: f64) -> Self {
        self.header.coast = seconds;
        self
    }

    /// With (or without, the default) a score per sample in the response
    /// ([`Prediction::scores`], [`Prediction::best_sample`]). The improved method
    /// scores its samples either way.
    pub fn scores(mut self, on: bool) -> Self {
        let mut o = self.options();
        o.scores = on;
        self.header.set_options(&o);
        self
    }

    /// With the map of the time of day for `time` (s on the map's clock: unix time, as
    /// the tracks had it) instead of the daemon's wall clock.
    pub fn time(mut self, time: f64) -> Self {
        self.header.set_map_time(MapTime::At(time));
        self
    }

    /// With the all-day map, whatever the time.
    pub fn all_day(mut self) -> Self {
        self.header.set_map_time(MapTime::AllDay);
        self
    }

    /// Set the method.
    pub fn set_method(&mut self, method: Method) {
        self.header.method = protocol::method_code(method);
    }

    /// Set the options beyond the paper (speed kernel, coasting, scores).
    pub fn set_options(&mut self, options: &Options) {
        self.header.set_options(options);
    }

    /// The options beyond the paper, as they will be sent.
    pub fn options(&self) -> Options {
        self.header.options()
    }

    /// Set which map of the time of day to use ([`MapTime::Now`], the default: the
    /// daemon's wall clock when the request arrives).
    pub fn set_map_time(&mut self, when: MapTime) {
        self.header.set_map_time(when);
    }

    /// Which map of the time of day the request asks for.
    pub fn map_time(&self) -> MapTime {
        match self.header.time_mode {
            protocol::TIME_AT => MapTime::At(self.header.time),
            protocol::TIME_ALL_DAY => MapTime::AllDay,
            _ => MapTime::Now,
        }
    }

    /// Set the seed of the request's random generator.
    pub fn set_seed(&mut self, seed: u64) {
        self.header.seed = seed;
    }

    /// Change the map.
    pub fn set_map(&mut self, map: &str) -> Result<(), Error> {
        self.header.set_map_name(map).map_err(Error::InvalidRequest)
    }

    /// Remove all agents.
    pub fn clear_agents(&mut self) {
        self.rows.clear();
        self.header.agents = 0;
    }

    /// Add an agent with its observed history, oldest row first; returns its index in
    /// the response. Rows made with [`Observation::with_velocity`] give the observed
    /// velocity from the tracker's speed and heading, rows made with
    /// [`Observation::position`] from the positions (at least two rows then).
    pub fn add_agent(&mut self, history: impl IntoIterator<Item = Observation>) -> usize {
        let a = self.header.agents;
        self.rows
            .extend(history.into_iter().map(|o| Observation { agent: a, ..o }));
        self.header.agents += 1;
        a as usize
    }

    /// Number of agents.
    pub fn agents(&self) -> usize {
        self.header.agents as usize
    }

    /// The wire header (request id and listener are filled in when sent).
    pub fn header(&self) -> &RequestHeader {
        &self.header
    }

    /// The wire header, for the C ABI (which passes codes through as given).
    pub(crate) fn header_mut(&mut self) -> &mut RequestHeader {
        &mut self.header
    }

    /// The wire rows.
    pub fn rows(&self) -> &[Observation] {
        &self.rows
    }
}

/// A connection to a `cliffd` daemon. `Send` and `Sync` (iceoryx2 `ipc_threadsafe`
/// ports), so it can move to a worker thread; a call takes `&mut self`, so threads that
/// share one client take turns (for requests in parallel, give each thread its own).
pub struct Client {
    service_name: String,
    options: ClientOptions,
    transport: Transport,
    next_id: u64,
    stale: u64,
    /// Until when the daemon is expected to poll for requests (from its last response's
    /// [`ResponseHeader::awake_us`]); `None`: not known yet.
    daemon_awake_until: Option<Instant>,
    /// The daemon had other requests in progress when it sent the last response
    /// ([`ResponseHeader::busy`]).
    daemon_busy: bool,
    /// The last round trip took longer than the hybrid spin (a spin would not have paid).
    slow_last: bool,
}

/// How a [`Client`] reaches its daemon.
enum Transport {
    /// iceoryx2 shared memory on this host.
    Ipc(Box<IpcPorts>),
    /// zenoh, to a daemon on any host.
    #[cfg(feature = "zenoh")]
    Zenoh(Box<zenoh::ZenohLink>),
}

/// A client's iceoryx2 ports.
struct IpcPorts {
    // ports first: they drop before the services and the node
    port: IoxClient<ClientIpc, [Observation], RequestHeader, [u32], ResponseHeader>,
    wake: Notifier<ClientIpc>,
    listener: Listener<ClientIpc>,
    listener_id: [u64; 2],
    _service: PredictService<ClientIpc>,
    _wake_service: iceoryx2::service::port_factory::event::PortFactory<ClientIpc>,
    _response_events: iceoryx2::service::port_factory::event::PortFactory<ClientIpc>,
    node: Node<ClientIpc>,
}

impl fmt::Debug for Client {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Client")
            .field("service", &self.service_name)
            .field("options", &self.options)
            .field("next_id", &self.next_id)
            .finish_non_exhaustive()
    }
}

/// How often a waiting client checks whether the daemon died (a SIGKILLed daemon's
/// connection looks alive until a node cleans up its resources).
const LIVENESS_INTERVAL: Duration = Duration::from_millis(20);

/// Pause instructions between two polls of a busy-waiting client.
const SPIN_PAUSES: usize = 4;

impl Client {
    /// Connect to the daemon serving `service` with default [`ClientOptions`].
    pub fn connect(service: &str) -> Result<Client, Error> {
        Self::connect_with(service, ClientOptions::default())
    }

    /// Connect with explicit options. Fails with [`Error::NoDaemon`] when no daemon has
    /// created the service (or none serves it right now).
    pub fn connect_with(service: &str, options: ClientOptions) -> Result<Client, Error> {
        let config = iceoryx_config(options.prefix.as_deref()).map_err(Error::InvalidRequest)?;
        let node = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ClientIpc>()
            .map_err(|e| ipc_err("cannot create node", e))?;
        let name = |s: &str| -> Result<ServiceName, Error> {
            ServiceName::new(s)
                .map_err(|e| Error::InvalidRequest(format!("service name '{s}': {e:?}")))
        };
        let no_daemon = || Error::NoDaemon {
            service: service.to_string(),
        };
        use iceoryx2::service::builder::request_response::RequestResponseOpenError as E;
        let svc = match node
            .service_builder(&name(&protocol::ipc_service_name(service))?)
            .request_response::<[Observation], [u32]>()
            .request_user_header::<RequestHeader>()
            .response_user_header::<ResponseHeader>()
            .open()
        {
            Ok(svc) => svc,
            Err(E::DoesNotExist) => {
                // a daemon of version 1 serves the bare name with version 1's types (a
                // daemon of this version serves both)
                let old = node
                    .service_builder(&name(&legacy::ipc_service_name(service))?)
                    .request_response::<[legacy::Observation], [u32]>()
                    .request_user_header::<legacy::RequestHeader>()
                    .response_user_header::<legacy::ResponseHeader>()
                    .open();
                return Err(match old {
                    Ok(old) if old.dynamic_config().number_of_servers() > 0 => {
                        version_mismatch(legacy::VERSION)
                    }
                    _ => no_daemon(),
                });
            }
            Err(e) => return Err(ipc_err("cannot open the service", e)),
        };
        if svc.dynamic_config().number_of_servers() == 0 {
            return Err(no_daemon());
        }
        let wake_service = node
            .service_builder(&name(&request_event_name(service))?)
            .event()
            .open()
            .map_err(|e| ipc_err("cannot open the request event service", e))?;
        let response_events = node
            .service_builder(&name(&response_event_name(service))?)
            .event()
            .open()
            .map_err(|e| ipc_err("cannot open the response event service", e))?;
        let port = svc
            .client_builder()
            .initial_max_slice_len(64)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| ipc_err("cannot create the client port (too many clients?)", e))?;
        let wake = wake_service
            .notifier_builder()
            .create()
            .map_err(|e| ipc_err("cannot create the request notifier", e))?;
        let listener = response_events
            .listener_builder()
            .create()
            .map_err(|e| ipc_err("cannot create the response listener", e))?;
        let id = listener.id().value();
        let listener_id = [id as u64, (id >> 64) as u64];
        let ports = IpcPorts {
            port,
            wake,
            listener,
            listener_id,
            _service: svc,
            _wake_service: wake_service,
            _response_events: response_events,
            node,
        };
        Ok(Self::with_transport(
            service,
            options,
            Transport::Ipc(Box::new(ports)),
        ))
    }

    /// Connect over zenoh to the daemon serving `service` (e.g. `cliff/predict`) that
    /// listens on `endpoint` (e.g. `tcp/192.0.2.7:7447`), with default options. Fails
    /// with [`Error::NoDaemon`] when nothing answers there. Needs the feature `zenoh`.
    ///
    /// ```no_run
    /// # use cliff_client::{Client, Request, Observation};
    /// let mut client = Client::connect_zenoh("tcp/127.0.0.1:7447", "cliff/predict")?;
    /// let mut request = Request::new("demo", &Default::default())?;
    /// request.add_agent([Observation::with_velocity(0.0, -10.0, 0.5, 1.2, 0.0)]);
    /// let prediction = client.predict(&request)?; // as over iceoryx2
    /// # Ok::<(), cliff_client::Error>(())
    /// ```
    #[cfg(feature = "zenoh")]
    pub fn connect_zenoh(endpoint: &str, service: &str) -> Result<Client, Error> {
        Self::connect_zenoh_with(
            &[endpoint.to_string()],
            None,
            service,
            ClientOptions::default(),
        )
    }

    /// Connect over zenoh with explicit endpoints, an optional zenoh configuration file
    /// (TLS certificates, ...; see [`zenoh::client_config`]) and options (only the
    /// deadline applies: a zenoh client always blocks on its reply). Needs the feature
    /// `zenoh`.
    #[cfg(feature = "zenoh")]
    pub fn connect_zenoh_with(
        endpoints: &[String],
        config_file: Option<&std::path::Path>,
        service: &str,
        options: ClientOptions,
    ) -> Result<Client, Error> {
        let link = zenoh::ZenohLink::open(endpoints, config_file, service)?;
        Ok(Self::with_transport(
            service,
            options,
            Transport::Zenoh(Box::new(link)),
        ))
    }

    fn with_transport(service: &str, options: ClientOptions, transport: Transport) -> Client {
        // request ids start at a per-process value so that two clients of one service
        // (or a restarted client) do not reuse each other's ids
        let seed = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos() as u64)
            .unwrap_or(0)
            ^ ((std::process::id() as u64) << 40);
        Client {
            service_name: service.to_string(),
            options,
            transport,
            next_id: seed | 1,
            stale: 0,
            daemon_awake_until: None,
            daemon_busy: false,
            slow_last: false,
        }
    }

    /// `"iceoryx2"` or `"zenoh"`: how this client reaches its daemon.
    pub fn transport(&self) -> &'static str {
        match self.transport {
            Transport::Ipc(_) => "iceoryx2",
            #[cfg(feature = "zenoh")]
            Transport::Zenoh(_) => "zenoh",
        }
    }

    /// The options in force.
    pub fn options(&self) -> &ClientOptions {
        &self.options
    }

    /// Change the wait mode.
    pub fn set_wait(&mut self, wait: WaitMode) {
        self.options.wait = wait;
    }

    /// Change the deadline of later calls.
    pub fn set_deadline(&mut self, deadline: Duration) {
        self.options.deadline = deadline;
    }

    /// Change how long [`WaitMode::Hybrid`] spins before blocking.
    pub fn set_spin(&mut self, spin: Duration) {
        self.options.spin = spin;
    }

    /// The service name.
    pub fn service(&self) -> &str {
        &self.service_name
    }

    /// Whether the daemon is expected to be polling for requests now: it said in its
    /// last response how long it stays awake, and that time has not passed (true when
    /// nothing is known yet). A [`WaitMode::Hybrid`] client spins only then.
    pub fn daemon_awake(&self) -> bool {
        self.daemon_awake_at(Instant::now())
    }

    fn daemon_awake_at(&self, t: Instant) -> bool {
        self.daemon_awake_until.is_none_or(|until| t < until)
    }

    /// Responses dropped because their request id did not match (stale responses).
    pub fn stale_responses(&self) -> u64 {
        self.stale
    }

    /// Predict with the client's deadline.
    pub fn predict(&mut self, request: &Request) -> Result<Prediction<'_>, Error> {
        let deadline = self.options.deadline;
        self.predict_raw(&request.header, &request.rows, deadline)
    }

    /// Predict with an explicit deadline for this call.
    pub fn predict_with_deadline(
        &mut self,
        request: &Request,
        deadline: Duration,
    ) -> Result<Prediction<'_>, Error> {
        self.predict_raw(&request.header, &request.rows, deadline)
    }

    /// Ask the daemon to reload every map from its file (as SIGHUP does). A map that
    /// fails to load keeps its old version and the call returns
    /// [`Error::Rejected`] with [`Status::ReloadFailed`].
    pub fn reload_maps(&mut self, deadline: Duration) -> Result<(), Error> {
        let header = RequestHeader {
            kind: KIND_RELOAD,
            ..RequestHeader::default()
        };
        self.predict_raw(&header, &[], deadline).map(|_| ())
    }

    /// Send a request given in wire form (request id and listener are filled in) and
    /// wait for its response. The typed [`predict`](Self::predict) calls this; it is
    /// public for protocol-level tools and tests.
    pub fn predict_raw(
        &mut self,
        header: &RequestHeader,
        rows: &[Observation],
        deadline: Duration,
    ) -> Result<Prediction<'_>, Error> {
        let body = match self.round_trip(header, rows, deadline)? {
            Answer::Shm(response) => Body::Shm(response, PhantomData),
            Answer::Buffered(h) => Body::Buffered(h, self.buffered_payload()),
        };
        Ok(Prediction { body })
    }

    /// The payload of the last response read into the client's own buffer (zenoh).
    pub(crate) fn buffered_payload(&self) -> &[u32] {
        match &self.transport {
            Transport::Ipc(_) => &[],
            #[cfg(feature = "zenoh")]
            Transport::Zenoh(link) => &link.payload,
        }
    }

    /// Round trip without the borrow: the response stays valid on its own (used by the
    /// C ABI, which keeps it until the next call).
    pub(crate) fn round_trip(
        &mut self,
        header: &RequestHeader,
        rows: &[Observation],
        deadline: Duration,
    ) -> Result<Answer, Error> {
        let start = Instant::now();
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        // a hybrid wait spins only when the daemon is awake, was not busy with others, and
        // the last round trip was shorter than the spin
        let spin_pays = self.daemon_awake_at(start) && !self.daemon_busy && !self.slow_last;
        let spin = self.options.spin;
        // one arm without the zenoh feature
        #[allow(clippy::infallible_destructuring_match)]
        let ipc = match &mut self.transport {
            Transport::Ipc(ipc) => ipc,
            #[cfg(feature = "zenoh")]
            Transport::Zenoh(link) => {
                let h = RequestHeader {
                    request_id: id,
                    listener_id: [0, 0],
                    ..*header
                };
                let rh = link.round_trip(&h, rows, deadline)?;
                check_header(&rh, &link.payload, id)?;
                return Ok(Answer::Buffered(rh));
            }
        };
        let notify = self.options.wait != WaitMode::Spin;

        let request = ipc
            .port
            .loan_slice_uninit(rows.len())
            .map_err(|e| ipc_err("cannot loan request memory", e))?;
        let mut request = request.write_from_slice(rows);
        let h = request.user_header_mut();
        *h = *header;
        h.request_id = id;
        h.listener_id = if notify { ipc.listener_id } else { [0, 0] };
        let pending = request
            .send()
            .map_err(|e| ipc_err("cannot send request", e))?;
        if pending.number_of_server_connections() == 0 {
            return Err(Error::NoDaemon {
                service: self.service_name.clone(),
            });
        }
        // wakes a sleeping daemon; costs a system call only when it sleeps
        let _ = ipc.wake.notify();

        let gone = || Error::DaemonGone {
            service: self.service_name.clone(),
        };
        let mut next_liveness = start + LIVENESS_INTERVAL;
        let spin_until = match self.options.wait {
            WaitMode::Spin => None,
            WaitMode::Hybrid if spin_pays => Some(start + self.options.spin),
            WaitMode::Hybrid | WaitMode::Block => Some(start),
        };
        // the daemon's promise to stay awake, with a margin for the time the response
        // took to reach us
        let awake_until = |h: &ResponseHeader| {
            (h.awake_us > 0)
                .then(|| Instant::now() + Duration::from_micros(h.awake_us as u64) * 9 / 10)
        };
        let mut polls = 0u32;
        loop {
            match pending.receive() {
                Ok(Some(response)) => {
                    if response.user_header().request_id != id {
                        self.stale += 1;
                        continue;
                    }
                    self.daemon_awake_until = awake_until(response.user_header());
                    self.daemon_busy = response.user_header().busy() > 0;
                    self.slow_last = start.elapsed() > spin;
                    return check_response(response, id).map(Answer::Shm);
                }
                Ok(None) => {}
                Err(e) => return Err(ipc_err("cannot receive", e)),
            }
            // between the checks below only the response is polled (a tighter loop)
            polls = polls.wrapping_add(1);
            if polls % 16 != 1 {
                // a few pause instructions per poll leave the execution units to a
                // daemon on the sibling hyperthread
                for _ in 0..SPIN_PAUSES {
                    std::hint::spin_loop();
                }
                continue;
            }
            if !pending.is_connected() {
                // the daemon dropped the request: either it answered (and the response
                // is in the buffer now) or it went away
                return match pending.receive() {
                    Ok(Some(r)) if r.user_header().request_id == id => {
                        self.daemon_awake_until = awake_until(r.user_header());
                        self.daemon_busy = r.user_header().busy() > 0;
                        self.slow_last = start.elapsed() > spin;
                        check_response(r, id).map(Answer::Shm)
                    }
                    _ => Err(gone()),
                };
            }
            let now = Instant::now();
            let end = start + deadline;
            if now >= end {
                return Err(Error::Deadline { deadline });
            }
            if now >= next_liveness {
                ipc.node.try_cleanup_dead_nodes();
                next_liveness = now + LIVENESS_INTERVAL;
                continue;
            }
            match spin_until {
                Some(t) if now >= t => {
                    let wait = (end - now).min(next_liveness - now);
                    match ipc.listener.timed_wait(|_| {}, wait) {
                        Ok(_) | Err(ListenerWaitError::InterruptSignal) => {}
                        Err(e) => return Err(ipc_err("cannot wait for the response event", e)),
                    }
                }
                _ => std::hint::spin_loop(),
            }
        }
    }
}

/// An owned response (no lifetime); see [`Prediction`].
pub(crate) type RawResponse = Response<ClientIpc, [u32], ResponseHeader>;

/// A response as a round trip returns it.
pub(crate) enum Answer {
    /// In shared memory (iceoryx2).
    Shm(RawResponse),
    /// The header; the payload is in the client's buffer ([`Client::buffered_payload`]).
    #[cfg_attr(not(feature = "zenoh"), allow(dead_code))]
    Buffered(ResponseHeader),
}

fn check_response(r: RawResponse, id: u64) -> Result<RawResponse, Error> {
    check_header(r.user_header(), r.payload(), id)?;
    Ok(r)
}

/// Check a response against the request id and its own shape; a rejection becomes
/// [`Error::Rejected`].
fn check_header(h: &ResponseHeader, payload: &[u32], id: u64) -> Result<(), Error> {
    if h.request_id != id {
        return Err(Error::Protocol(format!(
            "response for request {} instead of {id}",
            h.request_id
        )));
    }
    if h.version != PROTOCOL_VERSION {
        return Err(version_mismatch(h.version));
    }
    if let Some(rej) = Rejection::from_header(h) {
        return Err(Error::Rejected(rej));
    }
    let words = payload.len();
    if words != h.payload_words() {
        return Err(Error::Protocol(format!(
            "payload holds {words} words, shape {}x{}x{}{} needs {}",
            h.agents,
            h.k,
            h.steps,
            if h.has_scores() { " with scores" } else { "" },
            h.payload_words()
        )));
    }
    if let Some(bad) = split_payload(h, payload)
        .lens
        .iter()
        .find(|&&l| l > h.steps)
    {
        return Err(Error::Protocol(format!(
            "a sample length {bad} exceeds {} steps",
            h.steps
        )));
    }
    Ok(())
}

/// A batch of predicted trajectories, read in place from shared memory (or, over zenoh,
/// from the client's own buffer). It borrows the client: drop it before the next call.
///
/// Layout as [`cliff::predict::TrajectoryBatch`]: `agents x k` samples of `steps`
/// positions each, every sample with its valid length (a CLiFF-LHMP sample ends where
/// the map has no data).
pub struct Prediction<'c> {
    body: Body<'c>,
}

/// Where a [`Prediction`]'s data lives.
enum Body<'c> {
    Shm(RawResponse, PhantomData<&'c mut Client>),
    Buffered(ResponseHeader, &'c [u32]),
}

impl fmt::Debug for Prediction<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Prediction")
            .field("request_id", &self.request_id())
            .field("shape", &self.shape())
            .finish()
    }
}

/// The parts of a checked response payload.
pub(crate) struct Parts<'a> {
    pub positions: &'a [[f32; 2]],
    pub lens: &'a [u32],
    /// Empty when the response carries no scores.
    pub scores: &'a [f32],
}

/// Split a payload whose length was checked against `h` ([`check_header`]).
pub(crate) fn split_payload<'a>(h: &ResponseHeader, payload: &'a [u32]) -> Parts<'a> {
    let samples = (h.agents as usize) * (h.k as usize);
    let points = samples * (h.steps as usize);
    let (pos, rest) = payload.split_at(points * 2);
    let (lens, scores) = rest.split_at(samples.min(rest.len()));
    Parts {
        positions: bytemuck::cast_slice(pos),
        lens,
        scores: bytemuck::cast_slice(scores),
    }
}

/// The sample with the highest score (the first of equals), as
/// [`TrajectoryBatch::best_sample`](cliff::predict::TrajectoryBatch::best_sample).
fn best_of(scores: &[f32]) -> Option<usize> {
    let mut best = None;
    for (s, v) in scores.iter().enumerate() {
        if best.is_none_or(|b: usize| *v > scores[b]) {
            best = Some(s);
        }
    }
    best
}

impl<'c> Prediction<'c> {
    fn header(&self) -> &ResponseHeader {
        match &self.body {
            Body::Shm(r, _) => r.user_header(),
            Body::Buffered(h, _) => h,
        }
    }

    fn payload(&self) -> &[u32] {
        match &self.body {
            Body::Shm(r, _) => r.payload(),
            Body::Buffered(_, p) => p,
        }
    }

    /// The request id this answers (checked against the request by the client).
    pub fn request_id(&self) -> u64 {
        self.header().request_id
    }

    /// `(agents, k, steps)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        let h = self.header();
        (h.agents as usize, h.k as usize, h.steps as usize)
    }

    /// All positions, sample-major (NaN past each sample's valid length).
    pub fn positions(&self) -> &[[f32; 2]] {
        split_payload(self.header(), self.payload()).positions
    }

    /// The valid length of every sample (`agents x k`).
    pub fn lens(&self) -> &[u32] {
        split_payload(self.header(), self.payload()).lens
    }

    /// True when the response carries scores ([`ResponseHeader::flags`]): the request
    /// asked for them ([`Request::scores`]) or its method scores its samples
    /// (`Method::Improved`).
    pub fn has_scores(&self) -> bool {
        self.header().has_scores()
    }

    /// The score of every sample (`agents x k`, sample `a * k + s`), when the response
    /// carries scores ([`has_scores`](Self::has_scores)); empty otherwise. A score is the
    /// log-likelihood of the sample under the map ([`cliff::predict::Options::scores`]):
    /// compare the samples of one response.
    pub fn scores(&self) -> &[f32] {
        split_payload(self.header(), self.payload()).scores
    }

    /// The score of sample `s` of agent `a`, when the response carries scores.
    pub fn score(&self, a: usize, s: usize) -> Option<f32> {
        let k = self.shape().1;
        if s >= k {
            return None;
        }
        self.scores().get(a * k + s).copied()
    }

    /// The sample of agent `a` with the highest score (the first of equals), when the
    /// response carries scores and `a` is in range.
    pub fn best_sample(&self, a: usize) -> Option<usize> {
        let k = self.shape().1;
        best_of(self.scores().get(a * k..(a + 1) * k)?)
    }

    /// The predictions for agent `a` (panics when `a` is out of range).
    pub fn agent(&self, a: usize) -> AgentPrediction<'_> {
        let (agents, k, steps) = self.shape();
        assert!(a < agents, "agent {a} of {agents}");
        let parts = split_payload(self.header(), self.payload());
        AgentPrediction {
            index: a,
            steps,
            positions: &parts.positions[a * k * steps..(a + 1) * k * steps],
            lens: &parts.lens[a * k..(a + 1) * k],
            scores: parts.scores.get(a * k..(a + 1) * k).unwrap_or(&[]),
        }
    }

    /// Iterate over the agents, in request order.
    pub fn agents(&self) -> impl ExactSizeIterator<Item = AgentPrediction<'_>> + '_ {
        (0..self.shape().0).map(move |a| self.agent(a))
    }

    /// Copy into a [`TrajectoryBatch`](cliff::predict::TrajectoryBatch) (for keeping the
    /// result beyond the next call), with the scores when the response carries them.
    pub fn to_batch(&self, out: &mut cliff::predict::TrajectoryBatch) {
        let (a, k, s) = self.shape();
        out.reshape(a, k, s);
        let m = out.as_mut();
        m.positions.copy_from_slice(self.positions());
        m.lens.copy_from_slice(self.lens());
        let scores = self.has_scores().then(|| self.scores());
        // a checked response holds one score per sample of its shape
        out.set_scores(scores)
            .expect("a checked response has a score per sample");
    }
}

/// The `k` samples predicted for one agent.
#[derive(Debug, Clone, Copy)]
pub struct AgentPrediction<'p> {
    index: usize,
    steps: usize,
    positions: &'p [[f32; 2]],
    lens: &'p [u32],
    scores: &'p [f32],
}

impl<'p> AgentPrediction<'p> {
    /// The agent's index in the request.
    pub fn index(&self) -> usize {
        self.index
    }

    /// Number of samples (`k`).
    pub fn len(&self) -> usize {
        self.lens.len()
    }

    /// True when `k` is zero (never for an accepted request).
    pub fn is_empty(&self) -> bool {
        self.lens.is_empty()
    }

    /// The valid positions of sample `s`, one per `dt`.
    pub fn sample(&self, s: usize) -> &'p [[f32; 2]] {
        let start = s * self.steps;
        &self.positions[start..start + self.lens[s] as usize]
    }

    /// Iterate over the samples (each a slice of valid positions).
    pub fn samples(&self) -> impl ExactSizeIterator<Item = &'p [[f32; 2]]> + use<'p> {
        let this = *self;
        (0..self.lens.len()).map(move |s| this.sample(s))
    }

    /// The samples' scores (empty when the response carries none).
    pub fn scores(&self) -> &'p [f32] {
        self.scores
    }

    /// The sample with the highest score (the first of equals), when the response
    /// carries scores.
    pub fn best_sample(&self) -> Option<usize> {
        best_of(self.scores)
    }
}
