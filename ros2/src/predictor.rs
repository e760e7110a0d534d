//! Where predictions come from: a running `cliffd` (through `cliff-client`: shared
//! memory on this host, or zenoh to a cliffd on another host with the cargo feature
//! `zenoh`) or an in-process [`LocalPredictor`] on a map file. All decode the same
//! request the same way, so the same histories and seed give the same numbers.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use cliff::map::{CliffMap, MapSet};
use cliff::predict::{Method, Params};
use cliff_client::protocol::Limits;
use cliff_client::protocol::{Field, ObserveReply, Rejection, Status};
use cliff_client::{
    Client, ClientOptions, Error as ClientError, LocalPredictor, MapTime, Observation,
    ObserveRequest, Request,
};

/// Which map of the time of day to predict with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimeOfDay {
    /// The slice holding the input stamp plus the clock offset.
    #[default]
    Stamp,
    /// The all-day map.
    AllDay,
    /// The slice of the wall clock now (the daemon's clock for a daemon).
    Now,
}

impl std::str::FromStr for TimeOfDay {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "stamp" => Ok(TimeOfDay::Stamp),
            "all-day" | "all_day" => Ok(TimeOfDay::AllDay),
            "now" => Ok(TimeOfDay::Now),
            _ => Err(format!(
                "unknown time_of_day '{s}' (expected stamp, all-day or now)"
            )),
        }
    }
}

/// What a prediction asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictSettings {
    /// Method, samples, step, horizon, kernel, radius, seed.
    pub params: Params,
    /// Score every sample.
    pub scores: bool,
    /// Which map of a time-of-day set.
    pub time_of_day: TimeOfDay,
    /// Seconds added to the stamps to get the map's clock.
    pub clock_offset: f64,
}

impl Default for PredictSettings {
    fn default() -> Self {
        PredictSettings {
            params: Params::default(),
            scores: false,
            time_of_day: TimeOfDay::Stamp,
            clock_offset: 0.0,
        }
    }
}

/// The method's name as in the messages and settings.
pub fn method_name(m: Method) -> &'static str {
    m.name()
}

/// How the node reaches its `cliffd`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Link {
    /// iceoryx2 shared memory: a cliffd on this host.
    #[default]
    SharedMemory,
    /// zenoh: a cliffd on any host, at these endpoints (`tcp/HOST:7447`) and as the zenoh
    /// configuration file says (TLS certificates, ...; see
    /// [`cliff_client::Client::connect_zenoh_with`]). Needs the cargo feature `zenoh`;
    /// without it every attempt fails with [`ZENOH_MISSING`].
    Zenoh {
        /// Endpoints (may be empty when the file names them).
        endpoints: Vec<String>,
        /// A zenoh configuration file for the client.
        config: Option<PathBuf>,
    },
}

/// Why a build without the cargo feature `zenoh` cannot reach a cliffd over zenoh, with
/// the build line that can.
pub const ZENOH_MISSING: &str = "this cliff-ros2 is built without zenoh; build it with: cargo build --release -p cliff-ros2 --features zenoh";

/// Where predictions come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A `cliffd` serving `service` with a map named `map`.
    Daemon {
        /// The daemon's service name (iceoryx2 service, zenoh key expression).
        service: String,
        /// How the daemon is reached.
        link: Link,
        /// The map's name at the daemon.
        map: String,
        /// Deadline of one call.
        deadline: Duration,
    },
    /// In-process from this map file (a time-of-day set or one map).
    Local(PathBuf),
    /// In-process on the built-in demo scene.
    Demo,
}

/// The predicted samples of one cycle: `agents x k` samples of up to `steps` points
/// (`positions` holds `steps` slots per sample, `lens` the filled ones).
#[derive(Debug, Clone, Default)]
pub struct Samples {
    /// Agents.
    pub agents: usize,
    /// Samples per agent.
    pub k: usize,
    /// Slots per sample.
    pub steps: usize,
    /// Points, `(agent * k + sample) * steps + step`.
    pub positions: Vec<[f32; 2]>,
    /// Filled points per sample.
    pub lens: Vec<u32>,
    /// Scores per sample, or empty.
    pub scores: Vec<f32>,
}

impl Samples {
    /// Sample `s` of agent `a`.
    pub fn sample(&self, a: usize, s: usize) -> &[[f32; 2]] {
        let i = a * self.k + s;
        let start = i * self.steps;
        &self.positions[start..start + self.lens[i] as usize]
    }

    /// Score of sample `s` of agent `a`.
    pub fn score(&self, a: usize, s: usize) -> Option<f32> {
        self.scores.get(a * self.k + s).copied()
    }

    fn clear(&mut self, k: usize, steps: usize) {
        self.agents = 0;
        self.k = k;
        self.steps = steps;
        self.positions.clear();
        self.lens.clear();
        self.scores.clear();
    }

    fn append(&mut self, agents: usize, positions: &[[f32; 2]], lens: &[u32], scores: &[f32]) {
        self.agents += agents;
        self.positions.extend_from_slice(positions);
        self.lens.extend_from_slice(lens);
        self.scores.extend_from_slice(scores);
    }
}

/// Why observations were not taken.
#[derive(Debug, thiserror::Error)]
pub enum ObserveError {
    /// The daemon is not there: the rows wait for it.
    #[error("cliffd unavailable: {0}")]
    Unavailable(String),
    /// The daemon's budget for this client is spent (`over-budget`: new rows per second,
    /// open tracks or rows held, with its limit): nothing was taken, the rows are sent
    /// again later.
    #[error("over the daemon's observe budget ({0})")]
    OverBudget(Rejection),
    /// The request held more rows than the daemon takes in one (`cliffd
    /// --max-observe-rows`, the limit): nothing was taken.
    #[error("more rows than cliffd takes in one request (at most {0})")]
    TooManyRows(u32),
    /// The daemon turned the rows down with a status: `not-allowed` (over zenoh, a
    /// session that access control keeps off the observe key), `not-learning` (a map it
    /// serves but does not learn), bad rows. Nothing was taken.
    #[error("observations refused by cliffd: {0}")]
    Rejected(Rejection),
    /// The rows could not be sent (no daemon to send them to, a failure that is not the
    /// daemon's absence).
    #[error("observations refused: {0}")]
    Refused(String),
}

/// Why a cycle has no prediction.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    /// The daemon is not there (not started yet, restarting): no prediction until it is.
    #[error("cliffd unavailable: {0}")]
    Unavailable(String),
    /// The request was refused (by the daemon or the in-process decoder).
    #[error("prediction refused: {0}")]
    Refused(String),
}

enum Backend {
    Daemon {
        service: String,
        link: Link,
        options: ClientOptions,
        client: Option<Client>,
        next_try: Instant,
    },
    Local {
        maps: MapSet,
        predictor: LocalPredictor,
    },
}

/// Predicts histories in requests of at most [`Limits::max_agents`] agents each; chunk
/// `c` (0-based) is seeded with `seed + c`.
pub struct Predictor {
    backend: Backend,
    map_label: String,
    settings: PredictSettings,
    request: Request,
    chunk: usize,
    samples: Samples,
}

/// How long to wait between two attempts to reach an absent daemon.
const RECONNECT: Duration = Duration::from_millis(500);

impl Predictor {
    /// A predictor from `source` with `settings`. A map file is loaded here (an error
    /// names it); a daemon is only looked for on the first prediction.
    pub fn new(source: &Source, settings: PredictSettings) -> anyhow::Result<Predictor> {
        use anyhow::Context as _;
        let (backend, map_name, map_label) = match source {
            Source::Daemon {
                service,
                link,
                map,
                deadline,
            } => (
                Backend::Daemon {
                    service: service.clone(),
                    link: checked(link)?,
                    options: ClientOptions {
                        deadline: *deadline,
                        ..ClientOptions::default()
                    },
                    client: None,
                    next_try: Instant::now(),
                },
                map.clone(),
                map.clone(),
            ),
            Source::Local(path) => {
                let maps = MapSet::load(path)
                    .with_context(|| format!("loading map {}", path.display()))?;
                (
                    Backend::Local {
                        maps,
                        predictor: LocalPredictor::new(Limits::default()),
                    },
                    "local".to_string(),
                    path.display().to_string(),
                )
            }
            Source::Demo => (
                Backend::Local {
                    maps: MapSet::single(CliffMap::demo()),
                    predictor: LocalPredictor::new(Limits::default()),
                },
                "demo".to_string(),
                "demo".to_string(),
            ),
        };
        let mut request = Request::new(&map_name, &settings.params)
            .map_err(|e| anyhow::anyhow!("map name '{map_name}': {e}"))?;
        request = request.scores(settings.scores);
        let chunk = Limits::default().max_agents as usize;
        Ok(Predictor {
            backend,
            map_label,
            settings,
            request,
            chunk,
            samples: Samples::default(),
        })
    }

    /// The map as the messages name it.
    pub fn map_label(&self) -> &str {
        &self.map_label
    }

    /// The settings.
    pub fn settings(&self) -> &PredictSettings {
        &self.settings
    }

    /// Agents per request.
    pub fn chunk(&self) -> usize {
        self.chunk
    }

    /// The in-process map set (None for a daemon).
    pub fn local_maps(&self) -> Option<&MapSet> {
        match &self.backend {
            Backend::Local { maps, .. } => Some(maps),
            Backend::Daemon { .. } => None,
        }
    }

    /// The samples of the last successful [`Predictor::predict`].
    pub fn samples(&self) -> &Samples {
        &self.samples
    }

    /// Whether a daemon connection is up (always true in-process).
    pub fn connected(&self) -> bool {
        match &self.backend {
            Backend::Local { .. } => true,
            Backend::Daemon { client, .. } => client.is_some(),
        }
    }

    /// Predict every history of `agents` (each oldest first, at least two rows) at
    /// stamp `stamp` (s, the newest input stamp).
    pub fn predict<I>(&mut self, agents: I, stamp: f64) -> Result<&Samples, PredictError>
    where
        I: IntoIterator,
        I::Item: IntoIterator<Item = (f64, f64, f64)>,
    {
        let p = &self.settings.params;
        let steps = p.steps();
        self.samples.clear(p.k, steps);
        let when = match self.settings.time_of_day {
            TimeOfDay::Stamp => MapTime::At(stamp + self.settings.clock_offset),
            TimeOfDay::AllDay => MapTime::AllDay,
            TimeOfDay::Now => MapTime::Now,
        };
        self.request.set_map_time(when);
        let seed = p.seed;
        let mut chunk = 0u64;
        self.request.clear_agents();
        let mut agents = agents.into_iter().peekable();
        while agents.peek().is_some() {
            let history = agents.next().expect("peeked");
            self.request.add_agent(
                history
                    .into_iter()
                    .map(|(t, x, y)| Observation::position(t, x, y)),
            );
            if self.request.agents() == self.chunk || agents.peek().is_none() {
                self.request.set_seed(seed.wrapping_add(chunk));
                Self::run(&mut self.backend, &self.request, when, &mut self.samples)?;
                self.request.clear_agents();
                chunk += 1;
            }
        }
        Ok(&self.samples)
    }

    fn run(
        backend: &mut Backend,
        request: &Request,
        when: MapTime,
        out: &mut Samples,
    ) -> Result<(), PredictError> {
        match backend {
            Backend::Local { maps, predictor } => {
                let map: &Arc<CliffMap> = when.map_in(maps);
                let b = predictor
                    .predict(map, request.header(), request.rows())
                    .map_err(|r| PredictError::Refused(r.to_string()))?;
                let (agents, _, _) = b.shape();
                out.append(agents, b.positions(), b.lens(), b.scores());
                Ok(())
            }
            Backend::Daemon {
                service,
                link,
                options,
                client,
                next_try,
            } => {
                let c = connect(service, link, options, client, next_try)
                    .map_err(PredictError::Unavailable)?;
                match c.predict(request) {
                    Ok(p) => {
                        let (agents, _, _) = p.shape();
                        let scores = if p.has_scores() { p.scores() } else { &[] };
                        out.append(agents, p.positions(), p.lens(), scores);
                        Ok(())
                    }
                    Err(e) => Err(match away(e, client) {
                        Ok(why) => PredictError::Unavailable(why),
                        Err(e) => PredictError::Refused(e.to_string()),
                    }),
                }
            }
        }
    }
}

/// The daemon connection, made now if it is not up (at most one attempt per
/// [`RECONNECT`]); the error says why there is none.
fn connect<'a>(
    service: &str,
    link: &Link,
    options: &ClientOptions,
    client: &'a mut Option<Client>,
    next_try: &mut Instant,
) -> Result<&'a mut Client, String> {
    if client.is_none() {
        let now = Instant::now();
        if now < *next_try {
            return Err(format!("no cliffd serves '{service}' yet"));
        }
        *next_try = now + RECONNECT;
        *client = Some(open(service, link, options).map_err(|e| e.to_string())?);
    }
    Ok(client.as_mut().expect("connected above"))
}

/// `link`, once its zenoh configuration is known to be good (a file that does not read
/// or parse, an endpoint that is not one: an error naming it, at start rather than at
/// every attempt to connect).
fn checked(link: &Link) -> anyhow::Result<Link> {
    match link {
        Link::SharedMemory => {}
        #[cfg(feature = "zenoh")]
        Link::Zenoh { endpoints, config } => {
            cliff_client::zenoh::client_config(endpoints, config.as_deref())
                .map_err(|e| anyhow::anyhow!("reaching cliffd over zenoh: {e}"))?;
        }
        #[cfg(not(feature = "zenoh"))]
        Link::Zenoh { .. } => anyhow::bail!("reaching cliffd over zenoh: {ZENOH_MISSING}"),
    }
    Ok(link.clone())
}

/// A connection to the daemon serving `service` over `link`.
fn open(service: &str, link: &Link, options: &ClientOptions) -> Result<Client, ClientError> {
    match link {
        Link::SharedMemory => Client::connect_with(service, options.clone()),
        #[cfg(feature = "zenoh")]
        Link::Zenoh { endpoints, config } => {
            Client::connect_zenoh_with(endpoints, config.as_deref(), service, options.clone())
        }
        #[cfg(not(feature = "zenoh"))]
        Link::Zenoh { .. } => Err(ClientError::InvalidRequest(ZENOH_MISSING.into())),
    }
}

/// Whether a failed call means the daemon is away (`Ok`, with why; an iceoryx2 failure
/// also drops the connection, rebuilt on the next try) or refused it (`Err`).
fn away(e: ClientError, client: &mut Option<Client>) -> Result<String, ClientError> {
    match e {
        ClientError::NoDaemon { .. }
        | ClientError::DaemonGone { .. }
        | ClientError::Deadline { .. } => Ok(e.to_string()),
        ClientError::Ipc(_) => {
            *client = None;
            Ok(e.to_string())
        }
        e => Err(e),
    }
}

impl Predictor {
    /// Send observations to the daemon (over the prediction's connection), for a map it
    /// learns (`cliffd --learn NAME`). In-process there is no one to send them to:
    /// [`ObserveError::Refused`].
    pub fn observe(&mut self, request: &ObserveRequest) -> Result<ObserveReply, ObserveError> {
        let Backend::Daemon {
            service,
            link,
            options,
            client,
            next_try,
        } = &mut self.backend
        else {
            return Err(ObserveError::Refused(
                "observations need a daemon (map_file is set)".into(),
            ));
        };
        let c =
            connect(service, link, options, client, next_try).map_err(ObserveError::Unavailable)?;
        match c.observe(request) {
            Ok(reply) => Ok(reply),
            Err(ClientError::Rejected(r)) if r.status == Status::OverBudget => {
                Err(ObserveError::OverBudget(r))
            }
            Err(ClientError::Rejected(r))
                if r.status == Status::HistoryTooLong && r.field == Field::Rows =>
            {
                Err(ObserveError::TooManyRows(r.limit))
            }
            Err(ClientError::Rejected(r)) => Err(ObserveError::Rejected(r)),
            Err(e) => Err(match away(e, client) {
                Ok(why) => ObserveError::Unavailable(why),
                Err(e) => ObserveError::Refused(e.to_string()),
            }),
        }
    }
}
