//! The [`Client`]: a connection to a daemon (iceoryx2 on this host, or zenoh) and the
//! round trip of a request, with its wait (spin, block or both), deadline and checks of
//! the response.

use std::fmt;
use std::time::{Duration, Instant};

use iceoryx2::port::client::Client as IoxClient;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::*;

use crate::error::{Error, ipc_err, version_mismatch};
use crate::ipc::{
    ClientIpc, PredictService, iceoryx_config, request_event_name, response_event_name,
};
use crate::legacy;
use crate::options::{ClientOptions, WaitMode};
use crate::prediction::{Prediction, RawResponse, split_payload};
use crate::protocol::{
    self, KIND_RELOAD, Observation, PROTOCOL_VERSION, Rejection, RequestHeader, ResponseHeader,
};
use crate::request::Request;
#[cfg(feature = "zenoh")]
use crate::zenoh;

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
        self.predict_raw(request.header(), request.rows(), deadline)
    }

    /// Predict with an explicit deadline for this call.
    pub fn predict_with_deadline(
        &mut self,
        request: &Request,
        deadline: Duration,
    ) -> Result<Prediction<'_>, Error> {
        self.predict_raw(request.header(), request.rows(), deadline)
    }

    /// Ask the daemon to reload every map from its file (as SIGHUP does). A map that
    /// fails to load keeps its old version and the call returns
    /// [`Error::Rejected`] with [`Status::ReloadFailed`](crate::Status::ReloadFailed).
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
        Ok(match self.round_trip(header, rows, deadline)? {
            Answer::Shm(response) => Prediction::in_shared_memory(response),
            Answer::Buffered(h) => Prediction::buffered(h, self.buffered_payload()),
        })
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
