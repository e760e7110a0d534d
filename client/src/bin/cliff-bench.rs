//! `cliff-bench`: round-trip latency and throughput of a running `cliffd`, next to the
//! same predictions made in-process.

use std::hint::black_box;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Barrier};
use std::time::{Duration, Instant};

use clap::Parser;
use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::{Client, ClientOptions, Error, LocalPredictor, Observation, Request, WaitMode};

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
struct Args {
    /// iceoryx2 service name of the daemon.
    #[arg(long, default_value = cliff_client::DEFAULT_SERVICE)]
    service: String,

    /// iceoryx2 prefix (namespace) of the daemon. Default: the CLIFF_IPC_PREFIX
    /// environment variable, else iceoryx2's default.
    #[arg(long, env = "CLIFF_IPC_PREFIX")]
    prefix: Option<String>,

    /// Concurrent clients (threads, one iceoryx2 client each).
    #[arg(long, default_value_t = 1)]
    clients: usize,

    /// Measured requests per client.
    #[arg(long, default_value_t = 10_000)]
    requests: usize,

    /// Unmeasured warm-up requests per client.
    #[arg(long, default_value_t = 500)]
    warmup: usize,

    /// Agents (people) per request.
    #[arg(long, default_value_t = 1)]
    agents: usize,

    /// Samples per agent.
    #[arg(long, default_value_t = 20)]
    k: usize,

    /// Steps per sample (the horizon is steps x dt).
    #[arg(long, default_value_t = 30)]
    steps: usize,

    /// Time step (s).
    #[arg(long, default_value_t = 0.4)]
    dt: f64,

    /// Prediction method: cliff (CLiFF-LHMP), cvm (constant velocity) or improved (a
    /// preset of the options beyond the paper).
    #[arg(long, default_value = "cliff")]
    method: Method,

    /// Ask for a score per sample (the response carries agents x k more words, read
    /// with the positions; --verify compares them too).
    #[arg(long)]
    scores: bool,

    /// How clients wait: spin (busy-poll), hybrid (spin, then sleep) or block (sleep
    /// on an event). Spin gives the lowest latency but keeps a core busy per client:
    /// with more spinning clients than free cores, use hybrid or block.
    #[arg(long, default_value = "spin")]
    wait: WaitMode,

    /// Requests per second of each client (and of the in-process side), paced on a fixed
    /// schedule; default: back to back. The measured time excludes the pauses.
    #[arg(long)]
    rate: Option<f64>,

    /// Microseconds a hybrid client spins before it sleeps.
    #[arg(long, default_value_t = 200)]
    spin_us: u64,

    /// Deadline of each request (ms).
    #[arg(long, default_value_t = 2000)]
    deadline_ms: u64,

    /// Map name on the daemon.
    #[arg(long, default_value = "demo")]
    map: String,

    /// The map file the daemon serves under --map (CSV or snapshot), for the in-process
    /// side; not needed for the built-in `demo`.
    #[arg(long)]
    map_file: Option<PathBuf>,

    /// Also compare every response with the in-process result, bit for bit (outside the
    /// timed part; lowers throughput).
    #[arg(long)]
    verify: bool,

    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,

    /// Go on after a failed request (no daemon, daemon gone, deadline), as a robot
    /// would: retry after a pause of 10 ms and count the failure. For fault tests (a
    /// daemon killed and restarted under load): the output then says how long the
    /// slowest failure took to be reported and how many requests succeeded after the
    /// last one. The run ends after --requests successful requests or --give-up-s.
    #[arg(long)]
    keep_going: bool,

    /// With --keep-going: stop when no request has succeeded for this long (s).
    #[arg(long, default_value_t = 30.0)]
    give_up_s: f64,

    /// Reach the daemon over zenoh at this endpoint (e.g. tcp/127.0.0.1:7447) instead of
    /// iceoryx2 shared memory; repeatable. --wait and --spin-us do not apply (a zenoh
    /// client blocks on its reply).
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "ENDPOINT")]
    zenoh: Vec<String>,

    /// A zenoh configuration file for the client (TLS certificates, ...); implies zenoh.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
}

impl Args {
    /// Whether the daemon is reached over zenoh.
    fn remote(&self) -> bool {
        #[cfg(feature = "zenoh")]
        return !self.zenoh.is_empty() || self.zenoh_config.is_some();
        #[cfg(not(feature = "zenoh"))]
        false
    }

    fn connect(&self, options: ClientOptions) -> Result<Client, Error> {
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

/// Distinct requests cycled through by every client.
const POOL: usize = 64;

/// Requests with `agents` people each, walking along the map's main flow at
/// well-observed locations (so that samples run their full length).
fn request_pool(map: &CliffMap, a: &Args) -> Result<Vec<Request>, String> {
    let params = Params {
        method: a.method,
        k: a.k,
        dt: a.dt,
        horizon: a.steps as f64 * a.dt,
        ..Params::default()
    };
    let mut locs: Vec<_> = map
        .locations()
        .iter()
        .filter(|l| !l.components.is_empty())
        .collect();
    if locs.is_empty() {
        return Err("the map has no location with a component".into());
    }
    locs.sort_by(|x, y| y.observation_ratio.total_cmp(&x.observation_ratio));
    let locs = &locs[..locs.len().div_ceil(2)];
    let mut pool = Vec::with_capacity(POOL);
    for i in 0..POOL {
        let mut r = Request::new(&a.map, &params)
            .map_err(|e| e.to_string())?
            .scores(a.scores);
        r.set_seed(i as u64 * 7919 + 1);
        for ag in 0..a.agents {
            let l = locs[(i * 131 + ag * 17) % locs.len()];
            let c = l
                .components
                .iter()
                .max_by(|x, y| x.weight.total_cmp(&y.weight))
                .expect("non-empty");
            let (speed, heading) = (c.rho.clamp(0.3, 2.0), c.theta);
            let (dx, dy) = (heading.cos() * speed, heading.sin() * speed);
            let with_velocity = (i + ag) % 2 == 0;
            r.add_agent((0..5).map(|j| {
                let back = (4 - j) as f64 * 0.4;
                let (t, x, y) = (
                    10.0 - back,
                    l.position.x - dx * back,
                    l.position.y - dy * back,
                );
                if with_velocity {
                    Observation::with_velocity(t, x, y, speed, heading)
                } else {
                    Observation::position(t, x, y)
                }
            }));
        }
        pool.push(r);
    }
    Ok(pool)
}

/// Read every valid position (what a real client does with the answer).
fn consume<'a>(samples: impl Iterator<Item = &'a [[f32; 2]]>) -> f32 {
    let mut s = 0.0f32;
    for sample in samples {
        for p in sample {
            s += p[0] + p[1];
        }
    }
    s
}

#[derive(Default)]
struct ClientResult {
    latencies_ns: Vec<u64>,
    errors: Vec<String>,
    /// Failed requests (all of them, while `errors` keeps the first few messages).
    failures: usize,
    /// The longest time a failed request took to report its failure (ns).
    slowest_failure_ns: u64,
    /// Successful requests after the last failure.
    after_last_failure: usize,
    mismatches: usize,
    finished: Option<Instant>,
}

fn run_client(
    a: &Args,
    pool: &[Request],
    map: &CliffMap,
    barrier: &Barrier,
    offset: usize,
) -> ClientResult {
    let mut out = ClientResult::default();
    let options = ClientOptions {
        wait: a.wait,
        spin: Duration::from_micros(a.spin_us),
        deadline: Duration::from_millis(a.deadline_ms),
        prefix: a.prefix.clone().filter(|p| !p.is_empty()),
    };
    let client = a.connect(options);
    let mut client = match client {
        Ok(c) => c,
        Err(e) => {
            out.errors.push(format!("connect: {e}"));
            barrier.wait();
            return out;
        }
    };
    for i in 0..a.warmup {
        if let Err(e) = client.predict(&pool[(offset + i) % pool.len()]) {
            out.errors.push(format!("warm-up: {e}"));
            barrier.wait();
            return out;
        }
    }
    let mut local = LocalPredictor::default();
    out.latencies_ns.reserve(a.requests);
    barrier.wait();
    let mut pace = Pace::new(a.rate);
    let mut last_success = Instant::now();
    let mut i = 0;
    while out.latencies_ns.len() < a.requests && (a.keep_going || i < a.requests) {
        let req = &pool[(offset + i) % pool.len()];
        i += 1;
        pace.wait();
        let t0 = Instant::now();
        let r = client.predict(req);
        match r {
            Ok(p) => {
                last_success = Instant::now();
                out.after_last_failure += 1;
                black_box(consume(p.agents().flat_map(|ag| ag.samples())));
                black_box(p.scores().iter().sum::<f32>());
                out.latencies_ns.push(t0.elapsed().as_nanos() as u64);
                if a.verify {
                    let same = match local.predict(map, req.header(), req.rows()) {
                        Ok(b) => {
                            b.shape() == p.shape()
                                && b.lens() == p.lens()
                                && b.positions()
                                    .iter()
                                    .flatten()
                                    .zip(p.positions().iter().flatten())
                                    .all(|(x, y)| x.to_bits() == y.to_bits())
                                && b.scores().len() == p.scores().len()
                                && b.scores()
                                    .iter()
                                    .zip(p.scores())
                                    .all(|(x, y)| x.to_bits() == y.to_bits())
                        }
                        Err(_) => false,
                    };
                    if !same {
                        out.mismatches += 1;
                    }
                }
            }
            Err(e) => {
                out.failures += 1;
                out.after_last_failure = 0;
                out.slowest_failure_ns = out.slowest_failure_ns.max(t0.elapsed().as_nanos() as u64);
                let fatal = matches!(e, Error::NoDaemon { .. } | Error::DaemonGone { .. });
                if out.errors.len() < 20 {
                    out.errors.push(e.to_string());
                }
                if a.keep_going {
                    if last_success.elapsed().as_secs_f64() > a.give_up_s {
                        break;
                    }
                    std::thread::sleep(Duration::from_millis(10));
                    continue;
                }
                if fatal {
                    break;
                }
            }
        }
    }
    out.finished = Some(Instant::now());
    out
}

/// A fixed schedule of requests (`--rate`): `wait` sleeps until the next slot.
struct Pace {
    period: Option<Duration>,
    next: Instant,
}

impl Pace {
    fn new(rate: Option<f64>) -> Pace {
        Pace {
            period: rate.map(|r| Duration::from_secs_f64(1.0 / r)),
            next: Instant::now(),
        }
    }

    fn wait(&mut self) {
        let Some(period) = self.period else {
            return;
        };
        let now = Instant::now();
        if let Some(pause) = self.next.checked_duration_since(now) {
            std::thread::sleep(pause);
        }
        // a late request does not make the next ones early
        self.next = self.next.max(now) + period;
    }
}

struct Summary {
    p50: f64,
    p90: f64,
    p99: f64,
    p999: f64,
    max: f64,
}

fn summarize(ns: &mut [u64]) -> Summary {
    ns.sort_unstable();
    let q = |p: f64| {
        if ns.is_empty() {
            return f64::NAN;
        }
        let rank = ((p * ns.len() as f64).ceil() as usize).clamp(1, ns.len());
        ns[rank - 1] as f64 / 1000.0
    };
    Summary {
        p50: q(0.50),
        p90: q(0.90),
        p99: q(0.99),
        p999: q(0.999),
        max: q(1.0),
    }
}

fn main() -> ExitCode {
    let a = Args::parse();
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    match run(a) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(a: Args) -> Result<ExitCode, String> {
    if a.clients == 0 || a.requests == 0 || a.agents == 0 || a.k == 0 || a.steps == 0 {
        return Err("--clients, --requests, --agents, --k and --steps must be at least 1".into());
    }
    if let Some(r) = a.rate
        && !(r.is_finite() && r > 0.0 && r <= 1e6)
    {
        return Err(format!(
            "--rate {r}: expected requests per second, more than 0 and at most 1000000"
        ));
    }
    let map = match (&a.map_file, a.map.as_str()) {
        (Some(p), _) => CliffMap::load(p).map_err(|e| e.to_string())?,
        (None, "demo") => CliffMap::demo(),
        (None, other) => {
            return Err(format!(
                "map '{other}' is not the built-in demo: pass --map-file with the file the daemon serves it from"
            ));
        }
    };
    let pool = Arc::new(request_pool(&map, &a)?);
    let map = Arc::new(map);
    let a = Arc::new(a);

    // -- through the daemon
    let barrier = Arc::new(Barrier::new(a.clients + 1));
    let handles: Vec<_> = (0..a.clients)
        .map(|c| {
            let (a, pool, map, barrier) = (a.clone(), pool.clone(), map.clone(), barrier.clone());
            std::thread::spawn(move || run_client(&a, &pool, &map, &barrier, c * 13))
        })
        .collect();
    barrier.wait();
    let start = Instant::now();
    let results: Vec<ClientResult> = handles
        .into_iter()
        .map(|h| h.join().unwrap_or_default())
        .collect();
    let end = results
        .iter()
        .filter_map(|r| r.finished)
        .max()
        .unwrap_or_else(Instant::now);
    let wall = end.duration_since(start).as_secs_f64();
    let errors: Vec<String> = results.iter().flat_map(|r| r.errors.clone()).collect();
    let failures: usize = results.iter().map(|r| r.failures).sum();
    let slowest_failure_ms = results
        .iter()
        .map(|r| r.slowest_failure_ns)
        .max()
        .unwrap_or(0) as f64
        / 1e6;
    // the client that recovered least: its successful requests after its last failure
    let recovered = results
        .iter()
        .map(|r| r.after_last_failure)
        .min()
        .unwrap_or(0);
    let mismatches: usize = results.iter().map(|r| r.mismatches).sum();
    let mut ipc: Vec<u64> = results.into_iter().flat_map(|r| r.latencies_ns).collect();
    let done = ipc.len();
    if done == 0 {
        let first = errors
            .first()
            .map(|s| s.as_str())
            .unwrap_or("no request completed");
        return Err(format!("no request succeeded: {first}"));
    }

    // -- the same requests in-process
    let mut local = LocalPredictor::default();
    for r in pool.iter().take(a.warmup.min(pool.len())) {
        local
            .predict(&map, r.header(), r.rows())
            .map_err(|e| e.to_string())?;
    }
    let mut inproc = Vec::with_capacity(a.requests);
    let mut pace = Pace::new(a.rate);
    for i in 0..a.requests {
        let req = &pool[i % pool.len()];
        pace.wait();
        let t0 = Instant::now();
        let b = local
            .predict(&map, req.header(), req.rows())
            .map_err(|e| format!("in-process prediction refused the request: {e}"))?;
        let (_, k, steps) = b.shape();
        black_box(consume((0..b.shape().0 * k).map(|s| {
            &b.positions()[s * steps..s * steps + b.lens()[s] as usize]
        })));
        black_box(b.scores().iter().sum::<f32>());
        inproc.push(t0.elapsed().as_nanos() as u64);
    }

    let s = summarize(&mut ipc);
    let l = summarize(&mut inproc);
    let rps = done as f64 / wall;
    let aps = rps * a.agents as f64;
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(0);

    if a.json {
        let v = serde_json::json!({
            "service": a.service,
            "transport": if a.remote() { "zenoh" } else { "iceoryx2" },
            "clients": a.clients,
            "requests_per_client": a.requests,
            "completed": done,
            "agents": a.agents,
            "k": a.k,
            "steps": a.steps,
            "dt": a.dt,
            "method": a.method.name(),
            "scores": a.scores,
            "map": a.map,
            "wait": a.wait.to_string(),
            "rate_hz": a.rate,
            "p50_us": s.p50,
            "p90_us": s.p90,
            "p99_us": s.p99,
            "p999_us": s.p999,
            "max_us": s.max,
            "requests_per_s": rps,
            "agent_predictions_per_s": aps,
            "inprocess_p50_us": l.p50,
            "inprocess_p90_us": l.p90,
            "inprocess_p99_us": l.p99,
            "inprocess_p999_us": l.p999,
            "inprocess_max_us": l.max,
            "overhead_p50_us": s.p50 - l.p50,
            "overhead_p99_us": s.p99 - l.p99,
            "ratio_p50": s.p50 / l.p50,
            "errors": errors.len(),
            "failures": failures,
            "slowest_failure_ms": slowest_failure_ms,
            "min_successes_after_last_failure": recovered,
            "mismatches": if a.verify { Some(mismatches) } else { None },
            "cpus": cores,
        });
        println!("{v}");
    } else {
        println!(
            "cliff-bench: {} client(s) x {} requests (+{} warm-up each) to cliffd '{}' over {}{}",
            a.clients,
            a.requests,
            a.warmup,
            a.service,
            if a.remote() { "zenoh" } else { "iceoryx2" },
            match a.rate {
                Some(r) => format!(", each client paced at {r} requests/s"),
                None => ", back to back".to_string(),
            }
        );
        println!(
            "  each request: {} agent(s) x k {} samples x {} steps (dt {} s, horizon {:.1} s), method {}{}, map {}; client wait: {}",
            a.agents,
            a.k,
            a.steps,
            a.dt,
            a.steps as f64 * a.dt,
            a.method,
            if a.scores { " with scores" } else { "" },
            a.map,
            a.wait
        );
        println!();
        println!(
            "  {:<26} {:>9} {:>9} {:>9} {:>9} {:>9}   (microseconds)",
            "", "p50", "p90", "p99", "p99.9", "max"
        );
        for (name, x) in [
            ("round trip through cliffd", &s),
            ("in-process prediction", &l),
        ] {
            println!(
                "  {:<26} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
                name, x.p50, x.p90, x.p99, x.p999, x.max
            );
        }
        println!();
        println!(
            "  daemon overhead: p50 {:+.1} us, p99 {:+.1} us (round trip / in-process at p50: {:.2}x)",
            s.p50 - l.p50,
            s.p99 - l.p99,
            s.p50 / l.p50
        );
        println!(
            "  throughput: {:.0} requests/s = {:.0} agent-predictions/s ({} clients, {:.2} s, {} CPUs)",
            rps, aps, a.clients, wall, cores
        );
        if a.verify {
            println!(
                "  verified: {} of {} responses identical to the in-process result",
                done - mismatches,
                done
            );
        }
        if a.keep_going && failures > 0 {
            println!(
                "  failures: {failures} requests failed (slowest reported after {slowest_failure_ms:.1} ms); every client then succeeded {recovered}+ times"
            );
        }
        println!();
        println!(
            "  round trip = send the request, cliffd validates it and predicts into shared memory,"
        );
        println!("               the client receives the response and reads every position.");
        println!(
            "  in-process = the same requests decoded and predicted here, one thread, no IPC."
        );
        if a.wait != WaitMode::Block && cores > 0 && a.clients + 1 > cores {
            println!(
                "  note: {} {} clients + cliffd on {} CPUs compete for cores (a {} client busy-polls{}),\n        so latency measures the scheduler; use --wait block for throughput runs.",
                a.clients,
                a.wait,
                cores,
                a.wait,
                if a.wait == WaitMode::Hybrid {
                    format!(" for up to {} us", a.spin_us)
                } else {
                    String::new()
                }
            );
        }
    }
    if !errors.is_empty() {
        eprintln!("{failures} request(s) failed; first errors:");
        for e in errors.iter().take(5) {
            eprintln!("  {e}");
        }
    }
    // with --keep-going, failures are the point of the run: it fails only when a client
    // never recovered
    let failed = if a.keep_going {
        recovered == 0 && failures > 0
    } else {
        !errors.is_empty()
    };
    if failed || mismatches > 0 {
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}
