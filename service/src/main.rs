//! `cliffd`: the CLiFF-LHMP prediction daemon. See the `cliff_service` library.

use std::ffi::OsString;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use clap::{CommandFactory, Parser};
use cliff_client::protocol::{Limits, MAX_HISTORY};
use cliff_service::learn::{Budgets, Guards, LearnSettings};
use cliff_service::{
    DEFAULT_CHUNK_POSITIONS, DEFAULT_TABLE_BUDGET, DEFAULT_TABLE_RADII, Daemon, MapSpec, Settings,
    available_cores, parse_options_file,
};

/// cliffd: serves CLiFF-LHMP human motion predictions over iceoryx2 shared memory.
///
/// Clients (the cliff-client library, its C ABI, cliff-bench) send the observed
/// histories of people; cliffd answers with k sampled future trajectories per person,
/// written straight into shared memory. Without --map it serves the built-in demo
/// scene under the name `demo`. Prints a line containing `ready` once it serves.
///
/// Signals: SIGINT / SIGTERM shut down cleanly (a second SIGINT exits at once);
/// SIGHUP reloads every map from its file (a map that fails to load keeps its old
/// version). Logs go to stderr (RUST_LOG or --log to filter).
#[derive(Parser, Debug)]
#[command(name = "cliffd", version, about, long_about, args_override_self = true)]
struct Args {
    /// Read options from FILE first, one per line as NAME = VALUE (the long option
    /// without its --: `map = thor1=/var/lib/cliff/thor1.csv`, `workers = 2`; a line
    /// starting with # is a comment). The command line's options come after the file's:
    /// an option given in both takes the command line's value, and repeatable ones (map,
    /// learn) add up. The Debian package's service reads /etc/cliff/cliffd.conf.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,

    /// iceoryx2 service name to serve on.
    #[arg(long, default_value = cliff_client::DEFAULT_SERVICE)]
    service: String,

    /// iceoryx2 prefix (namespace): only clients with the same prefix see this daemon.
    /// Default: the CLIFF_IPC_PREFIX environment variable, else iceoryx2's default.
    #[arg(long, env = "CLIFF_IPC_PREFIX")]
    prefix: Option<String>,

    /// A map to serve, as NAME=PATH (CSV `.csv` or snapshot `.cliff`); repeat for
    /// several. Without any, the built-in demo scene is served as `demo`.
    #[arg(long = "map", value_name = "NAME=PATH")]
    maps: Vec<MapSpec>,

    /// Most agents in one request.
    #[arg(long, default_value_t = Limits::default().max_agents)]
    max_agents: u32,

    /// Most samples per agent (k).
    #[arg(long, default_value_t = Limits::default().max_k)]
    max_k: u32,

    /// Most steps per sample (floor(horizon / dt)).
    #[arg(long, default_value_t = Limits::default().max_steps)]
    max_steps: u32,

    /// Most history rows per agent (at most 64).
    #[arg(long, default_value_t = MAX_HISTORY)]
    max_history: u32,

    /// Largest sampling radius (m) a request may use, for every map. Default: 4 grid
    /// steps of each map (2 m on a 0.5 m grid; the paper uses up to 3 m on a 1 m grid).
    /// A lookup's work grows with the radius squared; larger radii are refused with the
    /// status radius-too-large and the limit in millimetres.
    #[arg(long, value_name = "METRES")]
    max_radius: Option<f64>,

    /// Sampling radii (m) whose neighbour tables are built when a map loads or reloads
    /// (comma-separated; those above a map's radius limit are skipped). Other radii are
    /// served by the grid scan until a background thread has built their table.
    #[arg(
        long,
        value_name = "METRES",
        value_delimiter = ',',
        default_values_t = DEFAULT_TABLE_RADII
    )]
    table_radii: Vec<f64>,

    /// Memory (MiB) the neighbour tables of one map may take together; the least
    /// recently used tables of radii not in --table-radii are evicted to stay within it.
    #[arg(long, value_name = "MIB", default_value_t = DEFAULT_TABLE_BUDGET >> 20)]
    table_budget_mib: usize,

    /// Predicted positions per chunk: a large request is cut into chunks of whole
    /// agents that take turns with other requests, so a small request never waits
    /// behind a large one for longer than about one chunk (8192 positions: about 0.2 ms).
    #[arg(long, value_name = "POSITIONS", default_value_t = DEFAULT_CHUNK_POSITIONS)]
    chunk_positions: usize,

    /// Most clients connected at once (each Client object, C client or cliff-bench
    /// thread is one).
    #[arg(long, default_value_t = Settings::default().max_clients)]
    max_clients: usize,

    /// Most requests one client may have in flight.
    #[arg(long, default_value_t = Settings::default().max_active_requests)]
    max_active_requests: usize,

    /// Microseconds the daemon keeps busy-polling after the last request before it
    /// sleeps (0: always sleep between requests, lowest CPU; higher: lowest latency
    /// under steady traffic).
    #[arg(long, default_value_t = 1000)]
    idle_spin_us: u64,

    /// Motion model file (.motion, made by `cliff motion fit`) that the methods motion
    /// and improved start from. Default: the built-in model (fitted on ATC's training
    /// hours; see docs/motion.md).
    #[arg(long, value_name = "FILE")]
    motion_model: Option<PathBuf>,

    /// Threads that predict chunks in parallel (of different requests, or of one large
    /// request alone); the serving thread is one of them. Default: the number of cores.
    /// 1: the serving thread does everything (lowest CPU use).
    #[arg(long, default_value_t = available_cores())]
    workers: usize,

    /// Milliseconds between sweeps that remove the resources of dead clients (killed
    /// with SIGKILL), freeing their client slots.
    #[arg(long, default_value_t = 1000)]
    cleanup_interval_ms: u64,

    /// Log filter (tracing env-filter syntax: error, warn, info, debug, cliff_service=debug).
    /// RUST_LOG overrides it.
    #[arg(long, default_value = "info")]
    log: String,

    /// Learn this map from the observations clients send (repeatable; off by default):
    /// a background thread folds tracked people into it with the online update and
    /// swaps in a new version every --learn-every-rows rows or --learn-every-s seconds
    /// (docs/learning.md). A time-of-day set learns each row into the slice of its time;
    /// its all-day map stays as loaded. Clients may ask for the map as loaded (NAME@0)
    /// or a recent version (NAME@VERSION).
    #[arg(long = "learn", value_name = "NAME")]
    learn: Vec<String>,

    /// Directory of the learned maps' snapshots: written every --snapshot-every-s
    /// seconds and at shutdown (atomically), and the newest good one resumed at start.
    /// Without it learned versions live in memory only.
    #[arg(long, value_name = "DIR")]
    learn_dir: Option<PathBuf>,

    /// A new learned version once this many rows wait.
    #[arg(long, value_name = "ROWS", default_value_t = LearnSettings::default().every_rows)]
    learn_every_rows: usize,

    /// A new learned version once the oldest waiting row has waited this long.
    #[arg(long, value_name = "SECONDS", default_value_t = LearnSettings::default().every.as_secs_f64())]
    learn_every_s: f64,

    /// Learned versions kept in memory before the one served, for clients that ask for
    /// one by number (NAME@VERSION; older ones are answered unknown-version).
    #[arg(long, value_name = "VERSIONS", default_value_t = LearnSettings::default().keep_versions)]
    learn_keep_versions: usize,

    /// Seconds between snapshots of the learned maps.
    #[arg(long, value_name = "SECONDS", default_value_t = LearnSettings::default().snapshot_every.as_secs_f64())]
    snapshot_every_s: f64,

    /// Decay of a learned map's counts per update, in (0, 1] (1: every row keeps its weight).
    #[arg(long, default_value_t = LearnSettings::default().decay)]
    learn_decay: f64,

    /// Moving samples that an observation ratio of 1 stands for in the served map (the
    /// "busiest node" that `cliff map build` prints). Default: the busiest node of the
    /// first update.
    #[arg(long, value_name = "SAMPLES")]
    learn_count_scale: Option<f64>,

    /// Per client: new observation rows per second.
    #[arg(long, value_name = "ROWS", default_value_t = Budgets::default().rows_per_s)]
    observe_rate: f64,

    /// Per client: open tracks.
    #[arg(long, value_name = "TRACKS", default_value_t = Budgets::default().max_tracks)]
    observe_tracks: usize,

    /// Per client: rows held in open tracks, not yet learned.
    #[arg(long, value_name = "ROWS", default_value_t = Budgets::default().max_rows_held)]
    observe_rows_held: usize,

    /// Rows per observe request (at most 4096).
    #[arg(long, value_name = "ROWS", default_value_t = LearnSettings::default().max_observe_rows)]
    max_observe_rows: u32,

    /// Seconds after which a track without new rows is finished, and a client without
    /// tracks forgotten.
    #[arg(long, value_name = "SECONDS", default_value_t = Budgets::default().track_timeout.as_secs_f64())]
    track_timeout_s: f64,

    /// Guard: one client's share of an update, in (0, 1] (1: no cap).
    #[arg(long, default_value_t = Guards::default().client_share)]
    learn_client_share: f64,

    /// Guard: rows of one track in one update.
    #[arg(long, value_name = "ROWS", default_value_t = Guards::default().track_rows)]
    learn_track_rows: usize,

    /// Guard: a new version whose mean log-likelihood on held-out recent rows is this
    /// much (nats) below the served version's is not swapped in.
    #[arg(long, value_name = "NATS", default_value_t = Guards::default().max_score_drop)]
    learn_max_score_drop: f64,

    /// Guard (damping): a location's mixture moves at most this far per minute, as a
    /// total-variation distance (an update: this times the minutes since the previous
    /// one, counted up to --learn-every-s); inf: no damping.
    #[arg(long, value_name = "TV", default_value_t = Guards::default().max_move_per_min)]
    learn_move_per_min: f64,

    /// Guard: rows held out of learning to judge new versions (0: no check).
    #[arg(long, value_name = "ROWS", default_value_t = Guards::default().held_rows)]
    learn_held_rows: usize,

    /// Write the process id to this file once ready.
    #[arg(long)]
    pid_file: Option<PathBuf>,

    /// Also serve remote clients over zenoh, listening on this endpoint (repeatable;
    /// e.g. tcp/127.0.0.1:7447, quic/0.0.0.0:7447). The queryable's key expression is the
    /// service name. Nothing listens unless asked; multicast and gossip scouting are off.
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    zenoh: Vec<String>,

    /// A full zenoh configuration file (JSON5: TLS, access control, scouting, connect to
    /// a router). What it does not name keeps cliffd's safe values (peer mode, scouting
    /// off, no listener); --zenoh endpoints replace its listen endpoints.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,

    /// Remote (zenoh) sessions with requests in flight at once; a request from another
    /// session gets status too-many-sessions. Each session may have
    /// --max-active-requests in flight; beyond, requests get status busy at once.
    #[cfg(feature = "zenoh")]
    #[arg(long, default_value_t = Settings::default().max_remote_sessions)]
    max_remote_sessions: usize,

    /// The largest zenoh message the daemon accepts, in bytes (by default the largest
    /// request the limits allow plus 4096, whatever the zenoh configuration file says).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "BYTES")]
    zenoh_max_message_bytes: Option<usize>,

    /// How much lower than the daemon's own the CPU priority of zenoh's threads is (a
    /// Linux nice increment, 0 to 19). While the serving loop has work it gets the CPU
    /// first, so a remote client flooding the daemon with large messages delays local
    /// clients less (other remote clients share zenoh's threads with it, and wait
    /// more). 0 runs zenoh at the daemon's priority.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "N", default_value_t = cliff_service::zenoh::DEFAULT_NICE,
          value_parser = clap::value_parser!(i32).range(0..=19))]
    zenoh_nice: i32,

    /// Follow the map NAME that another daemon (the site's, `--learn NAME`) serves over
    /// zenoh at ENDPOINT (repeatable; endpoints comma-separated): each version it
    /// learns is fetched, checked, written to --follow-dir and swapped in between
    /// requests, keeping the site's version numbers. The map must be served here too
    /// (--map NAME=PATH: what is served until the first version comes).
    #[cfg(feature = "zenoh")]
    #[arg(long = "follow", value_name = "NAME=ENDPOINT")]
    follow: Vec<cliff_service::zenoh::FollowSpec>,

    /// Directory of the followed maps' versions: each version taken is written there,
    /// and the newest good one is served at start (while the site is away).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "DIR")]
    follow_dir: Option<PathBuf>,

    /// How often the site is asked for a newer version (ms).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "MS", default_value_t = 500)]
    follow_every_ms: u64,

    /// The largest map version taken from the site (MiB).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "MIB", default_value_t = cliff_service::zenoh::DEFAULT_MAX_MAP_BYTES >> 20)]
    follow_max_mib: usize,

    /// A zenoh configuration file for the link to the site (JSON5: TLS certificates).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "FILE")]
    follow_config: Option<PathBuf>,

    /// The site daemon's service name (its zenoh keys derive from it); by default this
    /// daemon's --service.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "NAME")]
    follow_service: Option<String>,
}

/// A duration from seconds given on the command line; `Err` names the option.
fn seconds(s: f64, option: &str) -> Result<Duration, String> {
    if s.is_finite() && s > 0.0 && s < 1e9 {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(format!(
            "{option} {s}: must be a positive number of seconds"
        ))
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The command line with the options of `--config FILE` (if it is given) put before
/// the command line's own, so that the command line's values win. `Err` names the file,
/// and the line of an option cliffd does not have.
fn command_line() -> Result<Vec<OsString>, String> {
    let argv: Vec<OsString> = std::env::args_os().collect();
    let mut path = None;
    for (i, a) in argv.iter().enumerate().skip(1) {
        let a = a.to_string_lossy();
        if a == "--config" {
            // without a value clap reports the missing value
            path = argv.get(i + 1).map(PathBuf::from);
            break;
        }
        if let Some(p) = a.strip_prefix("--config=") {
            path = Some(PathBuf::from(p));
            break;
        }
    }
    let Some(path) = path else {
        return Ok(argv);
    };
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("--config {}: {e}", path.display()))?;
    let options = parse_options_file(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let command = Args::command();
    let mut expanded = vec![argv[0].clone()];
    for option in &options {
        let known = command
            .get_arguments()
            .any(|a| a.get_long() == Some(option.name.as_str()) && option.name != "config");
        if !known {
            return Err(format!(
                "{} line {}: cliffd has no option --{} (cliffd --help lists them)",
                path.display(),
                option.line,
                option.name
            ));
        }
        expanded.extend(option.to_args().into_iter().map(OsString::from));
    }
    expanded.extend(argv[1..].iter().cloned());
    Ok(expanded)
}

fn run() -> Result<ExitCode, String> {
    let args = Args::parse_from(command_line()?);
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .or_else(|_| tracing_subscriber::EnvFilter::try_new(&args.log))
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    if let Some(path) = &args.config {
        tracing::info!("options read from {} first", path.display());
    }

    let stop = Arc::new(AtomicBool::new(false));
    let reload = Arc::new(AtomicBool::new(false));
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    for (sig, flag) in [(SIGINT, &stop), (SIGTERM, &stop), (SIGHUP, &reload)] {
        // a second SIGINT/SIGTERM while shutting down exits at once
        if sig != SIGHUP
            && let Err(e) = signal_hook::flag::register_conditional_shutdown(sig, 1, flag.clone())
        {
            eprintln!("error: cannot install the signal handler: {e}");
            return Ok(ExitCode::FAILURE);
        }
        if let Err(e) = signal_hook::flag::register(sig, flag.clone()) {
            eprintln!("error: cannot install the signal handler: {e}");
            return Ok(ExitCode::FAILURE);
        }
    }

    let learned = args.learn.clone();
    let settings = Settings {
        service: args.service.clone(),
        prefix: args.prefix.filter(|p| !p.is_empty()),
        maps: args.maps,
        limits: Limits {
            max_agents: args.max_agents,
            max_k: args.max_k,
            max_steps: args.max_steps,
            max_history: args.max_history,
        },
        max_radius: args.max_radius,
        table_radii: args.table_radii,
        table_budget: args.table_budget_mib.saturating_mul(1 << 20),
        chunk_positions: args.chunk_positions,
        max_clients: args.max_clients,
        max_active_requests: args.max_active_requests,
        #[cfg(feature = "zenoh")]
        max_remote_sessions: args.max_remote_sessions,
        #[cfg(not(feature = "zenoh"))]
        max_remote_sessions: Settings::default().max_remote_sessions,
        idle_spin: Duration::from_micros(args.idle_spin_us),
        cleanup_interval: Duration::from_millis(args.cleanup_interval_ms.max(1)),
        workers: args.workers,
        motion_model: args.motion_model,
        learn: LearnSettings {
            maps: learned.clone(),
            dir: args.learn_dir,
            budgets: Budgets {
                rows_per_s: args.observe_rate,
                max_tracks: args.observe_tracks,
                max_rows_held: args.observe_rows_held,
                track_timeout: seconds(args.track_timeout_s, "--track-timeout-s")?,
                ..Budgets::default()
            },
            max_observe_rows: args.max_observe_rows,
            every_rows: args.learn_every_rows,
            keep_versions: args.learn_keep_versions,
            every: seconds(args.learn_every_s, "--learn-every-s")?,
            snapshot_every: seconds(args.snapshot_every_s, "--snapshot-every-s")?,
            decay: args.learn_decay,
            count_scale: args.learn_count_scale,
            guards: Guards {
                client_share: args.learn_client_share,
                track_rows: args.learn_track_rows,
                max_score_drop: args.learn_max_score_drop,
                held_rows: args.learn_held_rows,
                max_move_per_min: args.learn_move_per_min,
                ..Guards::default()
            },
            ..LearnSettings::default()
        },
    };
    let mut daemon = match Daemon::new(settings) {
        Ok(d) => d,
        Err(e) => {
            tracing::error!("{e}");
            eprintln!("error: {e}");
            return Ok(ExitCode::FAILURE);
        }
    };
    #[cfg(feature = "zenoh")]
    let mut remote_line = String::new();
    #[cfg(feature = "zenoh")]
    if !args.zenoh.is_empty() || args.zenoh_config.is_some() {
        let mut zs = cliff_service::zenoh::ZenohSettings::new(
            &args.service,
            args.zenoh.clone(),
            args.zenoh_config.clone(),
        );
        zs.max_message_bytes = args.zenoh_max_message_bytes;
        zs.nice = args.zenoh_nice;
        match daemon.serve_zenoh(&zs) {
            Ok(d) => remote_line = format!("; remote clients: {d}"),
            Err(e) => {
                tracing::error!("{e}");
                eprintln!("error: {e}");
                return Ok(ExitCode::FAILURE);
            }
        }
    }
    #[cfg(feature = "zenoh")]
    if !args.follow.is_empty() {
        let fs = cliff_service::zenoh::FollowSettings {
            maps: args.follow.clone(),
            service: args.follow_service.clone().unwrap_or(args.service.clone()),
            config_file: args.follow_config.clone(),
            dir: args.follow_dir.clone(),
            every: Duration::from_millis(args.follow_every_ms.max(1)),
            max_bytes: args.follow_max_mib.saturating_mul(1 << 20),
            keep_versions: args.learn_keep_versions,
            ..Default::default()
        };
        if let Err(e) = daemon.follow(&fs) {
            tracing::error!("{e}");
            eprintln!("error: {e}");
            return Ok(ExitCode::FAILURE);
        }
    }
    #[cfg(not(feature = "zenoh"))]
    let remote_line = "";
    if let Some(p) = &args.pid_file
        && let Err(e) = std::fs::write(p, format!("{}\n", std::process::id()))
    {
        eprintln!("error: cannot write the pid file {}: {e}", p.display());
        return Ok(ExitCode::FAILURE);
    }
    println!("{}{remote_line}", daemon.ready_line());
    let _ = std::io::stdout().flush();
    daemon.run(&stop, &reload);
    let s = daemon.stats();
    println!(
        "cliffd stopped: {} requests served, {} rejected, {} responses not delivered",
        s.served, s.rejected, s.failed
    );
    if !learned.is_empty() {
        let l = s.learn;
        println!(
            "cliffd learned: {} rows taken, {} duplicates, {} rows learned, {} versions, {} refused, {} snapshots",
            l.accepted_rows,
            l.duplicate_rows,
            l.learned_rows,
            l.versions,
            l.refused_versions,
            l.snapshots
        );
    }
    Ok(ExitCode::SUCCESS)
}
