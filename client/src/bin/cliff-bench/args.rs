//! The command line of `cliff-bench` ([`Args`]) and how it connects to the daemon.

use std::path::PathBuf;

use clap::Parser;
use cliff::predict::Method;
use cliff_client::{Client, ClientOptions, Error, WaitMode};

/// cliff-bench: measures how long a prediction takes through a running cliffd.
///
/// Starts N client threads; each sends M requests (after a warm-up) and times every
/// round trip: build and send the request, cliffd validates it and predicts straight
/// into shared memory, the client receives the response and reads every position.
/// Then the same requests are predicted in this process (one thread, same map, same
/// seeds), so the output shows what the daemon adds on top of the prediction itself.
///
/// Example (daemon with the built-in scene in another terminal: `cliffd`):
///
///   cliff-bench --clients 1 --requests 20000 --agents 1 --k 20 --steps 30 --wait spin
///
/// With `cliffd --map hall=hall.csv`, pass `--map hall --map-file hall.csv` so the
/// in-process side uses the same map.
///
/// Back-to-back requests keep every cache and core warm. A robot asks a few times a
/// second, and between its requests the daemon goes to sleep; `--rate 10` paces each
/// client (and the in-process side) at 10 requests per second to measure that case:
///
///   cliff-bench --requests 200 --rate 10 --wait hybrid
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

    /// Concurrent clients (threads, one iceoryx2 client each).
    #[arg(long, default_value_t = 1)]
    pub(crate) clients: usize,

    /// Measured requests per client.
    #[arg(long, default_value_t = 10_000)]
    pub(crate) requests: usize,

    /// Unmeasured warm-up requests per client.
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

    /// How clients wait: spin (busy-poll), hybrid (spin, then sleep) or block (sleep
    /// on an event). Spin gives the lowest latency but keeps a core busy per client:
    /// with more spinning clients than free cores, use hybrid or block.
    #[arg(long, default_value = "spin")]
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

    /// Also compare every response with the in-process result, bit for bit (outside the
    /// timed part; lowers throughput).
    #[arg(long)]
    pub(crate) verify: bool,

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
    /// client blocks on its reply).
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

    pub(crate) fn connect(&self, options: ClientOptions) -> Result<Client, Error> {
        #[cfg(feature = "zenoh")]
        if self.remote() {
            return Client::connect_zenoh_with(
                &self.zenoh,
                self.zenoh_config.as_deref(),
                &self.service,
                options,
            );
        }
        Client::connect_with(&self.service, options)
    }
}
