//! What a remote client may cost cliffd over zenoh (daemon and clients as processes on
//! loopback, each test on its own TCP port and iceoryx2 namespace): a session that
//! floods gets `busy` beyond its requests in flight while other remote sessions and
//! local clients are all answered; sessions beyond the cap get `too-many-sessions`;
//! messages above the largest request are dropped unless raised by name; the daemon's
//! resident memory stays within the documented bound under a flood; zenoh's threads run
//! at a lower CPU priority than the serving loop.
#![cfg(feature = "zenoh")]

mod common;

use std::time::Duration;

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::protocol::ResponseHeader;
use cliff_client::{Client, ClientOptions, Observation, Request, Status, WaitMode, wire};
use common::*;
use zenoh::Wait;

const PORT_FLOOD: u16 = 27_471;
const PORT_CAP: u16 = 27_472;
const PORT_MESSAGE: u16 = 27_473;
const PORT_MESSAGE_RAISED: u16 = 27_474;
const PORT_MEMORY: u16 = 27_475;
const PORT_NICE: u16 = 27_476;

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

/// A zenoh session of the test (client mode, no scouting) connected to the daemon.
fn raw_session(port: u16) -> zenoh::Session {
    let mut config = zenoh::Config::default();
    for (k, v) in [
        ("mode", r#""client""#.to_string()),
        ("connect/endpoints", format!("[{:?}]", endpoint(port))),
        ("scouting/multicast/enabled", "false".into()),
        ("scouting/gossip/enabled", "false".into()),
    ] {
        config.insert_json5(k, &v).unwrap();
    }
    zenoh::open(config).wait().expect("a zenoh session")
}

/// The largest request the default limits allow: 32 agents of 64 history rows, k 50,
/// 100 steps.
fn largest_request(i: u64) -> Request {
    let params = Params {
        k: 50,
        horizon: 40.0,
        dt: 0.4,
        seed: 500 + i,
        method: Method::Cliff,
        ..Params::default()
    };
    let mut r = Request::new("demo", &params).unwrap();
    for a in 0..32 {
        let y = -2.5 + (a % 6) as f64;
        r.add_agent(
            (0..64)
                .map(|j| Observation::position(100.0 + 0.1 * j as f64, -12.0 + 0.05 * j as f64, y)),
        );
    }
    r
}

fn encoded(r: &Request) -> Vec<u8> {
    let mut bytes = Vec::new();
    wire::encode_request(r.header(), r.rows(), &mut bytes);
    bytes
}

/// Send `n` copies of `bytes` at once on `session` (with its zenoh id as the session
/// attachment), then wait for every answer: the response headers, `None` for a query
/// that got no reply.
fn flood(session: &zenoh::Session, bytes: &[u8], n: usize) -> Vec<Option<ResponseHeader>> {
    flood_within(session, bytes, n, Duration::from_secs(60))
}

/// [`flood`] with queries that end after `timeout`.
fn flood_within(
    session: &zenoh::Session,
    bytes: &[u8],
    n: usize,
    timeout: Duration,
) -> Vec<Option<ResponseHeader>> {
    let zid = session.zid().to_le_bytes();
    let handlers: Vec<_> = (0..n)
        .map(|_| {
            session
                .get(SERVICE)
                .payload(bytes.to_vec())
                .attachment(zid.to_vec())
                .consolidation(zenoh::query::ConsolidationMode::None)
                .timeout(timeout)
                .wait()
                .expect("send a query")
        })
        .collect();
    handlers
        .into_iter()
        .map(|h| {
            let reply = h.recv().ok()?;
            let sample = reply.into_result().ok()?;
            let mut payload = Vec::new();
            wire::decode_response(&sample.payload().to_bytes(), usize::MAX, &mut payload).ok()
        })
        .collect()
}

fn status(h: &ResponseHeader) -> Status {
    Status::from_code(h.status).expect("a known status")
}

/// Statuses counted: (ok, busy with limit `busy_limit`, too-many-sessions with limit
/// `sessions_limit`, anything else or no reply).
fn tally(
    answers: &[Option<ResponseHeader>],
    busy_limit: u32,
    sessions_limit: u32,
) -> (usize, usize, usize, usize) {
    let mut t = (0, 0, 0, 0);
    for a in answers {
        match a.as_ref().map(|h| (status(h), h.limit)) {
            Some((Status::Ok, _)) => t.0 += 1,
            Some((Status::Busy, l)) if l == busy_limit => t.1 += 1,
            Some((Status::TooManySessions, l)) if l == sessions_limit => t.2 += 1,
            _ => t.3 += 1,
        }
    }
    t
}

#[test]
fn a_flooding_session_gets_busy_and_other_sessions_and_local_clients_are_all_answered() {
    let ns = Namespace::new("zflood");
    let _daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_FLOOD)]);
    let big = encoded(&largest_request(1));
    let flooder = std::thread::spawn(move || {
        let session = raw_session(PORT_FLOOD);
        // (fewer than the 256 refusals the daemon keeps waiting to be sent: beyond them
        // a refusal is dropped, by design, and its query ends without a reply)
        flood(&session, &big, 200)
    });
    // meanwhile, a second remote session and a local client ask for small predictions
    let mut far = Client::connect_zenoh_with(
        &[endpoint(PORT_FLOOD)],
        None,
        SERVICE,
        ClientOptions {
            deadline: Duration::from_secs(10),
            ..ClientOptions::default()
        },
    )
    .expect("connect over zenoh");
    let mut near = ns.connect(WaitMode::Hybrid);
    let map = CliffMap::demo();
    for i in 0..40 {
        let req = demo_request(i, 1, 20, Method::Cliff);
        let want = local_bits(&map, &req);
        for (name, client) in [("remote", &mut far), ("local", &mut near)] {
            let p = client
                .predict(&req)
                .unwrap_or_else(|e| panic!("{name} request {i} beside the flood: {e}"));
            assert_eq!(
                (p.shape(), bits(p.positions(), p.lens())),
                want,
                "{name} request {i}"
            );
        }
    }
    let answers = flooder.join().expect("the flooding thread");
    let (ok, busy, too_many, other) = tally(&answers, 2, 8);
    // every query of the flood is answered: predicted while its session had room,
    // `busy` (limit 2, the local clients' limit) beyond
    assert_eq!((too_many, other), (0, 0), "ok {ok}, busy {busy}");
    assert_eq!(ok + busy, 200);
    assert!(ok >= 2 && busy >= 1, "ok {ok}, busy {busy}");
}

#[test]
fn sessions_beyond_the_cap_get_too_many_sessions_and_are_served_once_room_is_free() {
    let ns = Namespace::new("zcap");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--zenoh",
            &endpoint(PORT_CAP),
            "--max-remote-sessions",
            "2",
            "--max-active-requests",
            "1",
        ],
    );
    let big = encoded(&largest_request(2));
    let sessions: Vec<_> = (0..3).map(|_| raw_session(PORT_CAP)).collect();
    let answers: Vec<Vec<Option<ResponseHeader>>> = std::thread::scope(|s| {
        let floods: Vec<_> = sessions
            .iter()
            .map(|session| s.spawn(|| flood(session, &big, 40)))
            .collect();
        floods.into_iter().map(|f| f.join().unwrap()).collect()
    });
    let mut total = (0, 0, 0, 0);
    for a in &answers {
        let t = tally(a, 1, 2);
        total = (total.0 + t.0, total.1 + t.1, total.2 + t.2, total.3 + t.3);
    }
    let (ok, busy, too_many, other) = total;
    assert_eq!(other, 0, "{total:?}");
    assert_eq!(ok + busy + too_many, 120);
    // each session admitted got its first request predicted, later ones `busy` while
    // it was in flight; the session beyond the cap got `too-many-sessions`
    assert!(ok >= 2 && busy >= 1 && too_many >= 1, "{total:?}");
    // the flood is over: every session is served again
    for (i, session) in sessions.iter().enumerate() {
        let small = encoded(&demo_request(i as u64, 1, 20, Method::Cliff));
        let a = flood(session, &small, 1);
        assert_eq!(tally(&a, 1, 2), (1, 0, 0, 0), "session {i} after the flood");
    }
}

/// A message of `rows` rows after a valid header (more than the limits allow).
fn oversized(rows: usize) -> Vec<u8> {
    let mut bytes = encoded(&demo_request(7, 1, 20, Method::Cliff));
    bytes.truncate(wire::REQUEST_HEADER_BYTES);
    bytes.resize(wire::REQUEST_HEADER_BYTES + rows * wire::ROW_BYTES, 0);
    bytes
}

#[test]
fn messages_above_the_largest_request_are_dropped_unless_raised_by_name() {
    // a configuration file that raises zenoh's message size does not raise the bound
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cliffd.json5");
    std::fs::write(
        &file,
        "{ transport: { link: { rx: { max_message_size: 1073741824 } } } }",
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let ns = Namespace::new("zmsg");
    let daemon = Daemon::start(
        &ns,
        &["--zenoh", &endpoint(PORT_MESSAGE), "--zenoh-config", file],
    );
    let session = raw_session(PORT_MESSAGE);
    // 4 x the rows of the largest request (32 agents x 64 rows): about 400 KB
    let huge = oversized(4 * 32 * 64);
    let a = flood_within(&session, &huge, 1, Duration::from_secs(2));
    assert!(a[0].is_none(), "an oversized message was answered: {a:?}");
    // the daemon still serves
    let small = encoded(&demo_request(8, 1, 20, Method::Cliff));
    assert_eq!(tally(&flood(&session, &small, 1), 2, 8), (1, 0, 0, 0));
    drop(daemon);
    // raised by name, the same message reaches the daemon, which refuses it by size
    let ns = Namespace::new("zmsgr");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--zenoh",
            &endpoint(PORT_MESSAGE_RAISED),
            "--zenoh-config",
            file,
            "--zenoh-max-message-bytes",
            "1000000",
        ],
    );
    let session = raw_session(PORT_MESSAGE_RAISED);
    let a = flood(&session, &huge, 1);
    let h = a[0].expect("an answer");
    assert_eq!((status(&h), h.limit), (Status::BadLayout, 32 * 64));
}

/// A line of /proc/PID/status in KiB (`VmRSS`, `VmHWM`).
fn proc_kib(pid: i32, key: &str) -> usize {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("{key} in /proc/{pid}/status"));
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

#[test]
fn resident_memory_stays_within_the_documented_bound_under_a_flood() {
    let ns = Namespace::new("zmem");
    let daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_MEMORY)]);
    // zenoh's and the scheduler's first allocations
    let warm = raw_session(PORT_MEMORY);
    let small = encoded(&demo_request(9, 1, 20, Method::Cliff));
    assert_eq!(tally(&flood(&warm, &small, 1), 2, 8), (1, 0, 0, 0));
    let before = proc_kib(daemon.pid(), "VmRSS:") * 1024;
    // ten sessions (two more than the cap of 8) of 60 largest requests at once each
    let big = encoded(&largest_request(3));
    let sessions: Vec<_> = (0..10).map(|_| raw_session(PORT_MEMORY)).collect();
    let answers: Vec<_> = std::thread::scope(|s| {
        let floods: Vec<_> = sessions
            .iter()
            .map(|session| s.spawn(|| flood(session, &big, 60)))
            .collect();
        floods.into_iter().map(|f| f.join().unwrap()).collect()
    });
    let peak = proc_kib(daemon.pid(), "VmHWM:") * 1024;
    let mut served = 0;
    for a in &answers {
        let (ok, busy, too_many, other) = tally(a, 2, 8);
        assert_eq!(other, 0, "{a:?}");
        assert_eq!(ok + busy + too_many, 60);
        served += ok;
    }
    assert!(served >= 10, "{served} served");
    // docs/zenoh.md: sessions x active x (max(rx buffer, message) + 2 x response)
    // + transports x (tx batches x batch + rx buffer + message) + 256 x 1 KiB, with
    // the defaults: 8 sessions, 2 requests each, 16 transports, zenoh's 16 batches of
    // 65535 bytes and 65535-byte receive buffer
    let message = 32 * 64 * 48 + 184 + 4096;
    let response = 56 + 4 * 32 * 50 * (2 * 100 + 2);
    let bound = 8 * 2 * (message + 2 * response) + 16 * (16 * 65535 + 65535 + message) + 256 * 1024;
    let grew = peak.saturating_sub(before);
    println!(
        "resident memory: {:.1} MiB before, peak {:.1} MiB (+{:.1} MiB), bound {:.1} MiB",
        before as f64 / 1048576.0,
        peak as f64 / 1048576.0,
        grew as f64 / 1048576.0,
        bound as f64 / 1048576.0
    );
    assert!(
        grew <= bound,
        "the daemon grew by {grew} bytes under the flood, above the bound of {bound}"
    );
}

/// The daemon's threads: (name, nice value) read from /proc/PID/task/TID/{comm,stat}.
fn threads(pid: i32) -> Vec<(String, i32)> {
    let mut out = Vec::new();
    for task in std::fs::read_dir(format!("/proc/{pid}/task")).unwrap() {
        let tid: u32 = task.unwrap().file_name().to_str().unwrap().parse().unwrap();
        let Ok(comm) = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/comm")) else {
            continue; // ended meanwhile
        };
        let Ok(nice) = cliff_service::zenoh::nice_of(pid as u32, tid) else {
            continue;
        };
        out.push((comm.trim().to_string(), nice));
    }
    out
}

/// Thread names zenoh's runtimes give (`rx-0`, `net-1`: see zenoh-runtime's ZRuntime).
fn is_zenohs(name: &str) -> bool {
    ["app-", "acc-", "tx-", "rx-", "net-"].iter().any(|p| {
        name.strip_prefix(p)
            .is_some_and(|n| !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()))
    })
}

#[test]
fn zenohs_threads_run_at_a_lower_priority_than_the_serving_loop() {
    let ns = Namespace::new("znice");
    let daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_NICE), "--zenoh-nice", "7"]);
    // a remote request makes zenoh start its receive and send threads
    let session = raw_session(PORT_NICE);
    let small = encoded(&demo_request(11, 1, 20, Method::Cliff));
    assert_eq!(tally(&flood(&session, &small, 2), 2, 8), (2, 0, 0, 0));
    let base = cliff_service::zenoh::nice_of(std::process::id(), std::process::id()).unwrap();
    let all = threads(daemon.pid());
    let main = cliff_service::zenoh::nice_of(daemon.pid() as u32, daemon.pid() as u32).unwrap();
    assert_eq!(
        main, base,
        "the serving loop keeps the daemon's priority: {all:?}"
    );
    let zenoh: Vec<_> = all.iter().filter(|(name, _)| is_zenohs(name)).collect();
    for name in ["rx-", "tx-"] {
        assert!(
            zenoh.iter().any(|(n, _)| n.starts_with(name)),
            "a thread {name}* among {all:?}"
        );
    }
    // cliffd-zenoh-reply, -refuse and -maps (a thread's name in /proc is cut at 15 bytes)
    // keep the daemon's priority, as every thread of the daemon's own does
    let ours = all
        .iter()
        .filter(|(n, _)| n.starts_with("cliffd-zenoh"))
        .count();
    assert_eq!(ours, 3, "the reply, refusal and map threads among {all:?}");
    for (name, nice) in &zenoh {
        assert_eq!(*nice, (base + 7).min(19), "thread {name}: {all:?}");
    }
    // and the daemon's other threads keep its priority
    for (name, nice) in all.iter().filter(|(name, _)| !is_zenohs(name)) {
        assert_eq!(*nice, base, "thread {name}: {all:?}");
    }
    drop(daemon);

    // out of range: refused by name before anything starts
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cliffd"))
        .args(["--zenoh", &endpoint(PORT_NICE), "--zenoh-nice", "20"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--zenoh-nice") && err.contains("20"), "{err}");
}
