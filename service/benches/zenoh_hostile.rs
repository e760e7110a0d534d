//! A hostile remote client beside two victims, against a running `cliffd --zenoh`
//! (benches/zenoh_hostile.sh starts the daemon and runs this): the victims, one remote
//! (zenoh) and one local (iceoryx2) client, each send 1-agent requests (k 20, 30
//! steps) at 100 Hz, first alone, then while a hostile zenoh session floods the daemon
//! with batches of maximum-size requests sent at once (32 agents, k 50, 100 steps) and
//! sends random, mutated and oversized payloads. Prints one JSON line per phase: the
//! victims' p50/p99/max and failures, what the hostile client got back, and the
//! daemon's resident memory (VmRSS before, VmHWM after).
//!
//! Settings from the environment (the script sets them): `CLIFF_ZENOH_ENDPOINT`,
//! `CLIFF_SERVICE`, `CLIFF_IPC_PREFIX`, `CLIFF_DAEMON_PID`, `SECONDS_PER_PHASE`
//! (default 20), `FLOOD` (requests sent at once per batch, default 4000),
//! `HOSTILE_NICE` (the hostile process's nice value, default 0).
//!
//! The hostile client runs as a process of its own (this program again, with
//! `CLIFF_HOSTILE_ROLE=hostile`), so that it shares no zenoh runtime with the remote
//! victim. On one machine its own CPU (encoding hundreds of megabytes a second) is
//! taken from the daemon's cores, which a client on another host would not do;
//! `HOSTILE_NICE=19` stands in for that host.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use cliff::predict::{Method, Params};
use cliff_client::{Client, ClientOptions, Observation, Request, Status, WaitMode, wire};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use zenoh::Wait;

fn env(key: &str, default: &str) -> String {
    std::env::var(key).unwrap_or_else(|_| default.to_string())
}

/// A 1-agent victim request (k 20, 30 steps) in the demo hall.
fn small_request(i: u64) -> Request {
    let params = Params {
        k: 20,
        horizon: 12.0,
        seed: i,
        ..Params::default()
    };
    let mut r = Request::new("demo", &params).unwrap();
    let y = -2.0 + (i % 5) as f64;
    r.add_agent((0..4).map(|j| Observation::position(0.4 * j as f64, -10.0 + 0.5 * j as f64, y)));
    r
}

/// The largest request of the default limits: 32 agents of 64 rows, k 50, 100 steps.
fn largest_request(i: u64) -> Vec<u8> {
    let params = Params {
        k: 50,
        horizon: 40.0,
        seed: i,
        method: Method::Cliff,
        ..Params::default()
    };
    let mut r = Request::new("demo", &params).unwrap();
    for a in 0..32 {
        let y = -2.5 + (a % 6) as f64;
        r.add_agent(
            (0..64).map(|j| Observation::position(0.1 * j as f64, -12.0 + 0.05 * j as f64, y)),
        );
    }
    let mut bytes = Vec::new();
    wire::encode_request(r.header(), r.rows(), &mut bytes);
    bytes
}

/// Latencies (us) and failures of one victim.
#[derive(Default)]
struct Victim {
    latencies: Vec<f64>,
    failures: u64,
    first_error: Option<String>,
}

impl Victim {
    fn json(&mut self) -> String {
        self.latencies.sort_by(f64::total_cmp);
        let q = |p: f64| {
            if self.latencies.is_empty() {
                return 0.0;
            }
            let i =
                ((self.latencies.len() as f64 * p).ceil() as usize).clamp(1, self.latencies.len());
            self.latencies[i - 1]
        };
        format!(
            "{{\"requests\":{},\"failures\":{},\"p50_us\":{:.1},\"p99_us\":{:.1},\"max_us\":{:.1},\"first_error\":{:?}}}",
            self.latencies.len() + self.failures as usize,
            self.failures,
            q(0.5),
            q(0.99),
            q(1.0),
            self.first_error.clone().unwrap_or_default()
        )
    }
}

/// Send a victim's requests at 100 Hz until `stop`; the first `warmup` are not timed.
fn victim(mut client: Client, stop: &AtomicBool, warmup: usize) -> Victim {
    let mut v = Victim::default();
    let period = Duration::from_millis(10);
    let mut next = Instant::now();
    let mut i = 0u64;
    while !stop.load(Ordering::Relaxed) {
        let req = small_request(i);
        let t = Instant::now();
        let r = client.predict(&req).map(|p| p.shape());
        let us = t.elapsed().as_secs_f64() * 1e6;
        if i as usize >= warmup {
            match r {
                Ok(_) => v.latencies.push(us),
                Err(e) => {
                    v.failures += 1;
                    v.first_error.get_or_insert_with(|| e.to_string());
                }
            }
        }
        i += 1;
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
    v
}

/// What the hostile client got back.
#[derive(Default)]
struct Hostile {
    sent: AtomicU64,
    ok: AtomicU64,
    busy: AtomicU64,
    too_many_sessions: AtomicU64,
    rejected: AtomicU64,
    no_reply: AtomicU64,
}

impl Hostile {
    fn count(&self, reply: Option<&[u8]>) {
        let counter = match reply {
            None => &self.no_reply,
            Some(bytes) => {
                let mut payload = Vec::new();
                match wire::decode_response(bytes, usize::MAX, &mut payload)
                    .map(|h| Status::from_code(h.status))
                {
                    Ok(Some(Status::Ok)) => &self.ok,
                    Ok(Some(Status::Busy)) => &self.busy,
                    Ok(Some(Status::TooManySessions)) => &self.too_many_sessions,
                    _ => &self.rejected,
                }
            }
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    fn json(&self) -> String {
        let g = |c: &AtomicU64| c.load(Ordering::Relaxed);
        format!(
            "{{\"sent\":{},\"ok\":{},\"busy\":{},\"too_many_sessions\":{},\"rejected\":{},\"no_reply\":{}}}",
            g(&self.sent),
            g(&self.ok),
            g(&self.busy),
            g(&self.too_many_sessions),
            g(&self.rejected),
            g(&self.no_reply)
        )
    }
}

fn raw_session(endpoint: &str) -> zenoh::Session {
    let mut config = zenoh::Config::default();
    for (k, v) in [
        ("mode", r#""client""#.to_string()),
        ("connect/endpoints", format!("[{endpoint:?}]")),
        ("scouting/multicast/enabled", "false".into()),
        ("scouting/gossip/enabled", "false".into()),
    ] {
        config.insert_json5(k, &v).unwrap();
    }
    zenoh::open(config).wait().expect("a zenoh session")
}

/// Send `payload` as one query of `session` (with its session attachment); the reply
/// is counted by a callback (a query that ends without one, e.g. dropped by zenoh for
/// its size, counts as `sent` only).
fn send(
    session: &zenoh::Session,
    key: &str,
    payload: Vec<u8>,
    h: &Arc<Hostile>,
    timeout: Duration,
) {
    let zid = session.zid().to_le_bytes().to_vec();
    let counter = h.clone();
    h.sent.fetch_add(1, Ordering::Relaxed);
    let r = session
        .get(key)
        .payload(payload)
        .attachment(zid)
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(timeout)
        .callback(move |reply| match reply.result() {
            Ok(sample) => counter.count(Some(&sample.payload().to_bytes())),
            Err(_) => counter.count(None),
        })
        .wait();
    if r.is_err() {
        h.no_reply.fetch_add(1, Ordering::Relaxed);
    }
}

/// The flood: batches of `flood` maximum-size requests sent at once, until `stop`.
fn flood(session: &zenoh::Session, key: &str, n: usize, stop: &AtomicBool, h: &Arc<Hostile>) {
    let big = largest_request(7);
    while !stop.load(Ordering::Relaxed) {
        for _ in 0..n {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            send(session, key, big.clone(), h, Duration::from_secs(5));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Random, mutated and oversized payloads, one at a time, until `stop`.
fn fuzz(session: &zenoh::Session, key: &str, stop: &AtomicBool, h: &Arc<Hostile>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(42);
    let good = {
        let r = small_request(3);
        let mut bytes = Vec::new();
        wire::encode_request(r.header(), r.rows(), &mut bytes);
        bytes
    };
    let big = largest_request(9);
    let mut i = 0u64;
    while !stop.load(Ordering::Relaxed) {
        let payload = match i % 4 {
            // random bytes of a random length
            0 => {
                let n = rng.random_range(0..4096);
                (0..n).map(|_| rng.random::<u8>()).collect()
            }
            // a valid request with a few bytes flipped
            1 => {
                let mut b = good.clone();
                for _ in 0..rng.random_range(1..8) {
                    let at = rng.random_range(0..b.len());
                    b[at] ^= 1 << rng.random_range(0..8);
                }
                b
            }
            // a maximum-size request with its header mutated
            2 => {
                let mut b = big.clone();
                let at = rng.random_range(0..wire::REQUEST_HEADER_BYTES);
                b[at] = rng.random();
                b
            }
            // oversized: twice the largest request
            _ => {
                let mut b = big.clone();
                b.extend_from_slice(&big[wire::REQUEST_HEADER_BYTES..]);
                b
            }
        };
        send(session, key, payload, h, Duration::from_millis(500));
        i += 1;
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn proc_kib(pid: &str, key: &str) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with(key))
                .and_then(|l| l.split_whitespace().nth(1).map(str::to_string))
        })
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// The hostile client's process: floods and fuzzes for `seconds`, then prints what it
/// got back (one JSON object) and ends.
fn hostile_process(endpoint: &str, key: &str, n: usize, seconds: u64) {
    let stop = AtomicBool::new(false);
    let hostile = Arc::new(Hostile::default());
    let session = raw_session(endpoint);
    std::thread::scope(|s| {
        s.spawn(|| flood(&session, key, n, &stop, &hostile));
        s.spawn(|| fuzz(&session, key, &stop, &hostile));
        std::thread::sleep(Duration::from_secs(seconds));
        stop.store(true, Ordering::Relaxed);
    });
    // late replies of the flood
    std::thread::sleep(Duration::from_secs(1));
    println!("{}", hostile.json());
}

/// Start this program again as the hostile client, at nice `nice` (0: the victims'
/// priority).
fn spawn_hostile(seconds: u64, nice: u32) -> std::process::Child {
    let exe = std::env::current_exe().expect("the bench's own path");
    std::process::Command::new("nice")
        .arg("-n")
        .arg(nice.to_string())
        .arg(exe)
        .env("CLIFF_HOSTILE_ROLE", "hostile")
        .env("SECONDS_PER_PHASE", seconds.to_string())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("start the hostile client (nice, from coreutils)")
}

fn main() {
    let endpoint = env("CLIFF_ZENOH_ENDPOINT", "tcp/127.0.0.1:7447");
    let service = env("CLIFF_SERVICE", cliff_client::DEFAULT_SERVICE);
    let prefix = std::env::var("CLIFF_IPC_PREFIX").ok();
    let pid = env("CLIFF_DAEMON_PID", "0");
    let seconds: u64 = env("SECONDS_PER_PHASE", "20")
        .parse()
        .expect("SECONDS_PER_PHASE");
    let n: usize = env("FLOOD", "4000").parse().expect("FLOOD");
    let hostile_nice: u32 = env("HOSTILE_NICE", "0").parse().expect("HOSTILE_NICE");
    let key = cliff_client::zenoh::key_expr_for(&service);
    if std::env::var("CLIFF_HOSTILE_ROLE").as_deref() == Ok("hostile") {
        return hostile_process(&endpoint, &key, n, seconds);
    }
    for phase in ["alone", "beside-hostile"] {
        let stop = Arc::new(AtomicBool::new(false));
        let rss_before = proc_kib(&pid, "VmRSS:");
        let options = ClientOptions {
            deadline: Duration::from_secs(2),
            wait: WaitMode::Hybrid,
            prefix: prefix.clone(),
            ..ClientOptions::default()
        };
        let far = Client::connect_zenoh_with(
            std::slice::from_ref(&endpoint),
            None,
            &service,
            options.clone(),
        )
        .expect("connect over zenoh");
        let near = Client::connect_with(&service, options).expect("connect over iceoryx2");
        // the hostile client is a process of its own, as it would be on another host:
        // it shares no zenoh runtime with the remote victim
        let hostile = (phase == "beside-hostile").then(|| {
            let child = spawn_hostile(seconds, hostile_nice);
            // its session and first batch are on their way before the victims start
            std::thread::sleep(Duration::from_millis(500));
            child
        });
        let (mut far, mut near) = std::thread::scope(|s| {
            let far = s.spawn(|| victim(far, &stop, 20));
            let near = s.spawn(|| victim(near, &stop, 20));
            std::thread::sleep(Duration::from_secs(seconds));
            stop.store(true, Ordering::Relaxed);
            (far.join().unwrap(), near.join().unwrap())
        });
        let hostile_json = match hostile {
            Some(child) => {
                let out = child
                    .wait_with_output()
                    .expect("the hostile client's report");
                String::from_utf8_lossy(&out.stdout).trim().to_string()
            }
            None => Hostile::default().json(),
        };
        println!(
            "{{\"phase\":\"{phase}\",\"seconds\":{seconds},\"flood\":{n},\"hostile_nice\":{hostile_nice},\"remote\":{},\"local\":{},\"hostile\":{hostile_json},\"daemon_rss_kib_before\":{rss_before},\"daemon_hwm_kib\":{}}}",
            far.json(),
            near.json(),
            proc_kib(&pid, "VmHWM:")
        );
    }
}
