//! The command line of `cliff-bench` ([`Args`]) and how it connects to the daemon.

use std::path::PathBuf;
use std::time::Duration;

use clap::Parser;
use cliff::predict::Method;
use cliff_client::{Client, ClientOptions, Error, WaitMode};

/// cliff-bench: measures how long a prediction takes through a running cliffd.
///
/// Starts N client threads; each sends M requests after a warm-up (the warm-up is not
/// counted) and times every round trip: build and send the request, cliffd validates it
/// and predicts straight into shared memory, the client receives the response and reads
/// every position. Then the same requests are predicted in this process (one thread,
/// same map, same seeds), so the output shows what the daemon adds on top of the
/// prediction itself. Percentiles come from every timed request (sorted, nearest rank),
/// not from histogram buckets.
///
/// Clients wait the way the client library does by default (hybrid: spin briefly, then
/// sleep), so the figures are what a program using `Client::connect` gets. A client that
/// spins needs a core of its own: when spinning clients outnumber the free cores (the
/// cores less one for cliffd's serving thread, less its other workers when requests are
/// large enough to be split), the run warns on stderr and in the JSON (`cores`), because
/// the latency then measures the scheduler.
///
/// Example (daemon with the built-in scene in another terminal: `cliffd`):
///
///   cliff-bench --clients 1 --requests 20000 --agents 1 --k 20 --steps 30
///
/// With `cliffd --map hall=hall.csv`, pass `--map hall --map-file hall.csv` so the
/// in-process side uses the same map.
///
/// Every way in, side by side (`--compare`): the prediction in-process, the bare iceoryx2
/// round trip of the same request and response sizes (a small echo server that cliff-bench
/// starts, no prediction: the transport's floor), the round trip through cliffd, and with
/// `--zenoh ENDPOINT` (feature zenoh) a bare zenoh query and cliffd over zenoh; each at every
/// client count of `--clients`, with the same requests and seeds, back to back. It writes a
/// report directory: report.md (a table), report.json, latency-cdf.png and throughput.png:
///
///   cliff-bench --compare --clients 1,2 --requests 5000 --out bench-report
///
/// Back-to-back requests keep every cache and core warm. A robot asks a few times a
/// second, and between its requests the daemon goes to sleep; `--rate 10` paces each
/// client (and the in-process side) at 10 requests per second to measure that case:
///
///   cliff-bench --requests 200 --rate 10
#[derive(Parser, Debug)]
#[command(name = "cliff-bench", version, about, long_about)]
pub(crate) struct Args {
    /// iceoryx2 service name of the daemon.
    #[arg(long, default_value = cliff_client::DEFAULT_SERVICE)]
    pub(crate) service: String,

    /// iceoryx2 prefix (namespace) of the daemon. Default: the CLIFF_IPC_PREFIX
    /// environment variable, else iceoryx2's default.
    #[arg(long, env = "CLIFF_IPC_PREFIX")]
    pub(crate) prefix: Option<String>,

    /// Concurrent clients (threads, one iceoryx2 client each). With --compare a
    /// comma-separated list of counts (default 1,2,4): every way in runs at each, and
    /// throughput.png draws requests per second against them. Default 1.
    #[arg(long, value_delimiter = ',', value_name = "N[,N...]")]
    pub(crate) clients: Vec<usize>,

    /// Measured requests per client.
    #[arg(long, default_value_t = 10_000)]
    pub(crate) requests: usize,

    /// Warm-up requests per client, sent before the timed ones and not counted in any
    /// figure (connections made, caches and the daemon's tables warm).
    #[arg(long, default_value_t = 500)]
    pub(crate) warmup: usize,

    /// Agents (people) per request.
    #[arg(long, default_value_t = 1)]
    pub(crate) agents: usize,

    /// Samples per agent.
    #[arg(long, default_value_t = 20)]
    pub(crate) k: usize,

    /// Steps per sample (the horizon is steps x dt).
    #[arg(long, default_value_t = 30)]
    pub(crate) steps: usize,

    /// Time step (s).
    #[arg(long, default_value_t = 0.4)]
    pub(crate) dt: f64,

    /// Prediction method: cliff (CLiFF-LHMP), cvm (constant velocity) or improved (a
    /// preset of the options beyond the paper).
    #[arg(long, default_value = "cliff")]
    pub(crate) method: Method,

    /// Ask for a score per sample (the response carries agents x k more words, read
    /// with the positions; --verify compares them too).
    #[arg(long)]
    pub(crate) scores: bool,

    /// How clients wait: hybrid (spin up to --spin-us, then sleep on an event; the client
    /// library's default, so the default measures what programs get), spin (busy-poll:
    /// the lowest latency, but a core busy per client) or block (sleep on an event at
    /// once). With more spinning clients than free cores, use hybrid or block.
    #[arg(long, default_value_t = WaitMode::default())]
    pub(crate) wait: WaitMode,

    /// Requests per second of each client (and of the in-process side), paced on a fixed
    /// schedule; default: back to back. The measured time excludes the pauses.
    #[arg(long)]
    pub(crate) rate: Option<f64>,

    /// Microseconds a hybrid client spins before it sleeps.
    #[arg(long, default_value_t = 200)]
    pub(crate) spin_us: u64,

    /// Deadline of each request (ms).
    #[arg(long, default_value_t = 2000)]
    pub(crate) deadline_ms: u64,

    /// Map name on the daemon.
    #[arg(long, default_value = "demo")]
    pub(crate) map: String,

    /// The map file the daemon serves under --map (CSV or snapshot), for the in-process
    /// side; not needed for the built-in `demo`.
    #[arg(long)]
    pub(crate) map_file: Option<PathBuf>,

    /// Compare every response with the in-process result, bit for bit (the default; the
    /// check runs between requests, outside the timed part). A mismatch fails the run.
    #[arg(long, overrides_with = "no_verify")]
    pub(crate) verify: bool,

    /// Do not check the responses. The check costs the client about one in-process
    /// prediction per request between its requests: it lowers throughput and leaves the
    /// caches as a busier client would. Use it for throughput figures once a verified run
    /// has shown the responses right.
    #[arg(long, overrides_with = "verify")]
    pub(crate) no_verify: bool,

    /// Run every way in side by side (in-process, the iceoryx2 floor, iceoryx2 through
    /// cliffd, and with --zenoh the zenoh floor and zenoh through cliffd) at every count of
    /// --clients, and write the report directory --out.
    #[arg(long)]
    pub(crate) compare: bool,

    /// Where --compare writes its report (created if missing; its report files are
    /// replaced).
    #[arg(long, default_value = "cliff-bench-report", value_name = "DIR")]
    pub(crate) out: PathBuf,

    /// The daemon's --workers, for counting the free cores (default: cliffd's default,
    /// the number of cores).
    #[arg(long, value_name = "N")]
    pub(crate) daemon_workers: Option<usize>,

    /// Internal: serve the floor (an echo of responses of this shape: agents,k,steps,scores)
    /// on --service; what --compare starts as a child process.
    #[arg(long, hide = true, value_name = "SHAPE")]
    pub(crate) serve_floor: Option<String>,

    /// Internal: with --serve-floor, also answer zenoh queries on this endpoint.
    #[arg(long, hide = true, value_name = "ENDPOINT")]
    pub(crate) floor_zenoh: Option<String>,

    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub(crate) json: bool,

    /// Go on after a failed request (no daemon, daemon gone, deadline), as a robot
    /// would: retry after a pause of 10 ms and count the failure. For fault tests (a
    /// daemon killed and restarted under load): the output then says how long the
    /// slowest failure took to be reported and how many requests succeeded after the
    /// last one. The run ends after --requests successful requests or --give-up-s.
    #[arg(long)]
    pub(crate) keep_going: bool,

    /// With --keep-going: stop when no request has succeeded for this long (s).
    #[arg(long, default_value_t = 30.0)]
    pub(crate) give_up_s: f64,

    /// Reach the daemon over zenoh at this endpoint (e.g. tcp/127.0.0.1:7447) instead of
    /// iceoryx2 shared memory; repeatable. --wait and --spin-us do not apply (a zenoh
    /// client blocks on its reply). With --compare, zenoh is measured beside iceoryx2,
    /// its floor being a bare zenoh queryable on this host's loopback (so against a
    /// daemon on another host the floor leaves out the network).
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    pub(crate) zenoh: Vec<String>,

    /// A zenoh configuration file for the client (TLS certificates, ...); implies zenoh.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "FILE")]
    pub(crate) zenoh_config: Option<PathBuf>,
}

impl Args {
    /// Whether the daemon is reached over zenoh.
    pub(crate) fn remote(&self) -> bool {
        #[cfg(feature = "zenoh")]
        return !self.zenoh.is_empty() || self.zenoh_config.is_some();
        #[cfg(not(feature = "zenoh"))]
        false
    }

    /// Whether responses are checked against the in-process result (`--no-verify` turns
    /// it off).
    pub(crate) fn verify(&self) -> bool {
        !self.no_verify
    }

    /// The client counts: `--clients`, else 1 (1, 2 and 4 with --compare).
    pub(crate) fn client_counts(&self) -> Vec<usize> {
        match (self.clients.is_empty(), self.compare) {
            (false, _) => self.clients.clone(),
            (true, false) => vec![1],
            (true, true) => vec![1, 2, 4],
        }
    }

    /// How the daemon is reached: over zenoh when an endpoint or configuration is given,
    /// else over iceoryx2.
    pub(crate) fn daemon_target(&self) -> Target {
        #[cfg(feature = "zenoh")]
        if self.remote() {
            return Target::Zenoh {
                endpoints: self.zenoh.clone(),
                config: self.zenoh_config.clone(),
                service: self.service.clone(),
            };
        }
        Target::Ipc {
            service: self.service.clone(),
        }
    }

    /// The client options of every client thread.
    pub(crate) fn client_options(&self) -> ClientOptions {
        ClientOptions {
            wait: self.wait,
            spin: Duration::from_micros(self.spin_us),
            deadline: Duration::from_millis(self.deadline_ms),
            prefix: self.prefix.clone().filter(|p| !p.is_empty()),
        }
    }
}

/// A service a client thread connects to: cliffd or the floor, over iceoryx2 or zenoh.
#[derive(Debug, Clone)]
pub(crate) enum Target {
    /// iceoryx2 on this host (in the `--prefix` namespace).
    Ipc { service: String },
    /// zenoh at these endpoints (or as the configuration file says).
    #[cfg(feature = "zenoh")]
    Zenoh {
        endpoints: Vec<String>,
        config: Option<PathBuf>,
        service: String,
    },
}

impl Target {
    /// `"iceoryx2"` or `"zenoh"`.
    pub(crate) fn transport(&self) -> &'static str {
        match self {
            Target::Ipc { .. } => "iceoryx2",
            #[cfg(feature = "zenoh")]
            Target::Zenoh { .. } => "zenoh",
        }
    }

    pub(crate) fn connect(&self, options: ClientOptions) -> Result<Client, Error> {
        match self {
            Target::Ipc { service } => Client::connect_with(service, options),
            #[cfg(feature = "zenoh")]
            Target::Zenoh {
                endpoints,
                config,
                service,
            } => Client::connect_zenoh_with(endpoints, config.as_deref(), service, options),
        }
    }
}
