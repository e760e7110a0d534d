//! cliffd over zenoh on loopback: the daemon and its clients are separate processes
//! (each test on its own TCP port and iceoryx2 namespace). Same numbers as in-process,
//! every bad request gets its status, a killed remote client disturbs nobody, a
//! restarted daemon is found again, nothing listens beyond what was asked.
#![cfg(feature = "zenoh")]

mod common;

use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::protocol::{KIND_RELOAD, RequestHeader, ResponseHeader};
use cliff_client::{
    Client, ClientOptions, Error, Field, MapTime, Observation, PROTOCOL_VERSION, Request, Status,
    WaitMode, wire,
};
use common::*;
use zenoh::Wait;

/// Ports of this file's tests (distinct, so that they run in parallel).
const PORT_SAME_NUMBERS: u16 = 27_461;
const PORT_BAD_REQUESTS: u16 = 27_462;
const PORT_KILLED_CLIENT: u16 = 27_463;
const PORT_RESTART: u16 = 27_464;
const PORT_NO_DAEMON: u16 = 27_465;
const PORT_DEFAULTS: u16 = 27_466;

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

fn remote(port: u16, deadline: Duration) -> Client {
    Client::connect_zenoh_with(
        &[endpoint(port)],
        None,
        SERVICE,
        ClientOptions {
            deadline,
            ..ClientOptions::default()
        },
    )
    .expect("connect over zenoh")
}

#[test]
#[ignore = "helper: the remote client process the other tests spawn (does nothing on its own)"]
fn zenoh_child_client() {
    // CLIFF_ZENOH_CHILD = port,requests,agents,tag
    let Ok(spec) = std::env::var("CLIFF_ZENOH_CHILD") else {
        return;
    };
    let f: Vec<&str> = spec.split(',').collect();
    let port: u16 = f[0].parse().unwrap();
    let requests: u64 = f[1].parse().unwrap();
    let agents: usize = f[2].parse().unwrap();
    let tag = f[3];
    let mut client = remote(port, Duration::from_secs(5));
    let map = CliffMap::demo();
    let base = tag.bytes().map(u64::from).sum::<u64>() * 1000;
    for i in 0..requests {
        let method = if i % 5 == 2 {
            Method::Cvm
        } else {
            Method::Cliff
        };
        let req = demo_request(base + i, agents, 20, method);
        let (shape, want) = local_bits(&map, &req);
        let p = client
            .predict(&req)
            .unwrap_or_else(|e| panic!("remote child {tag} request {i}: {e}"));
        assert_eq!(p.shape(), shape, "remote child {tag} request {i}");
        assert_eq!(
            bits(p.positions(), p.lens()),
            want,
            "remote child {tag} request {i}"
        );
        if i == 0 {
            println!("CHILD {tag} started");
        }
    }
    println!("CHILD {tag} done {requests}");
}

/// Requests on the real THÖR1 map: people walking from well-observed locations.
fn thor_request(map: &CliffMap, i: u64, agents: usize) -> Request {
    let params = Params {
        k: 20,
        seed: 77 + i,
        method: if i % 4 == 3 {
            Method::Cvm
        } else {
            Method::Cliff
        },
        ..Params::default()
    };
    let mut r = Request::new("thor1", &params).unwrap();
    let locs = map.locations();
    for a in 0..agents {
        let l = &locs[(i as usize * 31 + a * 57) % locs.len()];
        let (x, y) = (l.position.x, l.position.y);
        r.add_agent((0..4).map(|j| {
            Observation::position(j as f64 * 0.4, x - 0.3 * (3 - j) as f64, y + 0.1 * j as f64)
        }));
    }
    r
}

#[test]
fn remote_answers_are_identical_to_in_process_and_to_iceoryx2() {
    let ns = Namespace::new("zsame");
    let thor_path = shared_data("thor1/cliffmap.csv");
    let thor = CliffMap::load(&thor_path).expect("THÖR1 map");
    let maps = format!("thor1={}", thor_path.display());
    let daemon = Daemon::start(
        &ns,
        &["--map", &maps, "--zenoh", &endpoint(PORT_SAME_NUMBERS)],
    );
    assert!(
        daemon
            .ready_line
            .contains("zenoh key 'cliff/test' on tcp/127.0.0.1"),
        "{}",
        daemon.ready_line
    );
    let mut far = remote(PORT_SAME_NUMBERS, Duration::from_secs(5));
    assert_eq!(far.transport(), "zenoh");
    let mut near = ns.connect(WaitMode::Hybrid);
    for i in 0..40u64 {
        let req = thor_request(&thor, i, 1 + (i as usize % 5));
        let (shape, want) = local_bits(&thor, &req);
        let p = far.predict(&req).expect("remote prediction");
        assert_eq!(p.shape(), shape, "request {i}");
        assert!(
            p.lens().iter().any(|&l| l > 0),
            "request {i}: empty samples"
        );
        assert_eq!(
            bits(p.positions(), p.lens()),
            want,
            "request {i}: remote vs in-process"
        );
        let mut kept = cliff::predict::TrajectoryBatch::new();
        p.to_batch(&mut kept);
        let q = near.predict(&req).expect("local prediction");
        assert_eq!(
            bits(q.positions(), q.lens()),
            want,
            "request {i}: iceoryx2 vs in-process"
        );
        assert_eq!(kept.lens(), q.lens());
    }
    // the largest request the default limits allow (32 agents, k 50, 100 steps: 1.3 MB)
    let mut big = Request::new(
        "thor1",
        &Params {
            k: 50,
            horizon: 40.0,
            seed: 3,
            ..Params::default()
        },
    )
    .unwrap();
    for a in 0..32 {
        let l = &thor.locations()[a * 7];
        big.add_agent((0..64).map(|j| {
            Observation::position(j as f64 * 0.1, l.position.x + 0.01 * j as f64, l.position.y)
        }));
    }
    let (shape, want) = local_bits(&thor, &big);
    assert_eq!(shape, (32, 50, 100));
    let p = far.predict(&big).expect("largest request");
    assert_eq!(bits(p.positions(), p.lens()), want);
    // options beyond the paper, scores and the time of day: the same bytes and scores
    for i in 0..12u64 {
        let mut req = thor_request(&thor, 100 + i, 1 + (i as usize % 3))
            .speed_beta([0.0, 2.0][i as usize % 2])
            .coast([0.0, 4.0, 12.0][i as usize % 3])
            .scores(i % 4 != 3);
        req.set_map_time(
            [
                MapTime::Now,
                MapTime::At(1.35e9 + i as f64),
                MapTime::AllDay,
            ][i as usize % 3],
        );
        let want = local_scored(&thor, &req);
        assert_eq!(want.1.is_empty(), i % 4 == 3);
        let p = far.predict(&req).expect("remote prediction with options");
        assert_eq!(scored(&p), want, "request {i}: remote vs in-process");
        let q = near.predict(&req).expect("local prediction with options");
        assert_eq!(scored(&q), want, "request {i}: iceoryx2 vs in-process");
    }
}

#[test]
fn every_bad_request_gets_its_status_over_zenoh() {
    let ns = Namespace::new("zbad");
    let _daemon = Daemon::start(
        &ns,
        &["--zenoh", &endpoint(PORT_BAD_REQUESTS), "--max-agents", "4"],
    );
    let mut c = remote(PORT_BAD_REQUESTS, Duration::from_secs(5));
    let good = demo_request(1, 2, 10, Method::Cliff);
    let rejected = |c: &mut Client, h: &RequestHeader, rows: &[Observation]| match c.predict_raw(
        h,
        rows,
        Duration::from_secs(5),
    ) {
        Err(Error::Rejected(r)) => r,
        Ok(p) => panic!("accepted: {p:?}"),
        Err(e) => panic!("not a rejection: {e}"),
    };
    let with = |f: &dyn Fn(&mut RequestHeader)| {
        let mut h = *good.header();
        f(&mut h);
        h
    };
    let rows = good.rows();
    let cases: Vec<(RequestHeader, Status, Field)> = vec![
        (with(&|h| h.version = 9), Status::BadVersion, Field::Version),
        (with(&|h| h.version = 1), Status::BadVersion, Field::Version),
        (
            with(&|h| h.speed_beta = f64::NAN),
            Status::NonFinite,
            Field::SpeedBeta,
        ),
        (
            with(&|h| h.speed_beta = -1.0),
            Status::BadValue,
            Field::SpeedBeta,
        ),
        (
            with(&|h| h.coast = h.horizon + 0.4),
            Status::BadValue,
            Field::Coast,
        ),
        (with(&|h| h.flags = 6), Status::BadValue, Field::Flags),
        (
            with(&|h| h.time_mode = 3),
            Status::BadValue,
            Field::TimeMode,
        ),
        (
            with(&|h| {
                h.time_mode = cliff_client::protocol::TIME_AT;
                h.time = f64::INFINITY
            }),
            Status::NonFinite,
            Field::MapTime,
        ),
        (
            with(&|h| h.set_map_name("nowhere").unwrap()),
            Status::UnknownMap,
            Field::Map,
        ),
        (
            with(&|h| h.method = 7),
            Status::UnknownMethod,
            Field::Method,
        ),
        (with(&|h| h.dt = f64::NAN), Status::NonFinite, Field::Dt),
        (with(&|h| h.k = 51), Status::BadK, Field::K),
        (
            with(&|h| h.horizon = 1000.0),
            Status::BadSteps,
            Field::Steps,
        ),
        (with(&|h| h.radius = -1.0), Status::BadValue, Field::Radius),
        (with(&|h| h.agents = 3), Status::BadLayout, Field::Agents),
        (with(&|h| h.kind = 5), Status::UnknownKind, Field::None),
        // reloads are for local clients
        (
            with(&|h| h.kind = KIND_RELOAD),
            Status::UnknownKind,
            Field::None,
        ),
    ];
    for (h, status, field) in cases {
        let r = rejected(&mut c, &h, rows);
        assert_eq!((r.status, r.field), (status, field), "{r}");
    }
    // the client's own reload request (it names no map) is refused for its kind
    match c.reload_maps(Duration::from_secs(5)) {
        Err(Error::Rejected(r)) => {
            assert_eq!((r.status, r.field), (Status::UnknownKind, Field::None))
        }
        other => panic!("reload over zenoh: {other:?}"),
    }
    // too many agents for --max-agents 4
    let r = rejected(
        &mut c,
        &demo_request(2, 5, 10, Method::Cliff).header().clone(),
        demo_request(2, 5, 10, Method::Cliff).rows(),
    );
    assert_eq!((r.status, r.limit), (Status::BadAgents, 4));
    // rows: too short, not increasing, non-finite, too long
    let mut short = good.clone();
    short.clear_agents();
    short.add_agent([Observation::position(0.0, 1.0, 1.0)]);
    let r = rejected(&mut c, short.header(), short.rows());
    assert_eq!((r.status, r.agent), (Status::HistoryTooShort, Some(0)));
    let mut bad_rows = rows.to_vec();
    bad_rows[2].t = bad_rows[1].t;
    let r = rejected(&mut c, good.header(), &bad_rows);
    assert_eq!(
        (r.status, r.agent, r.row),
        (Status::HistoryNotIncreasing, Some(0), Some(2))
    );
    let mut bad_rows = rows.to_vec();
    bad_rows[6].x = f64::INFINITY;
    let r = rejected(&mut c, good.header(), &bad_rows);
    assert_eq!(
        (r.status, r.field, r.agent, r.row),
        (Status::NonFinite, Field::Position, Some(1), Some(1))
    );
    let mut long = good.clone();
    long.clear_agents();
    long.add_agent((0..65).map(|j| Observation::position(j as f64, 0.0, 0.0)));
    let r = rejected(&mut c, long.header(), long.rows());
    assert_eq!((r.status, r.limit), (Status::HistoryTooLong, 64));
    // the client still works after all that
    let p = c.predict(&good).expect("a good request after the bad ones");
    assert_eq!(
        bits(p.positions(), p.lens()),
        local_bits(&CliffMap::demo(), &good).1
    );

    // malformed messages, sent as raw zenoh queries (as a client in another language)
    let mut config = zenoh::Config::default();
    for (k, v) in [
        ("mode", r#""client""#.to_string()),
        (
            "connect/endpoints",
            format!("[{:?}]", endpoint(PORT_BAD_REQUESTS)),
        ),
        ("scouting/multicast/enabled", "false".into()),
    ] {
        config.insert_json5(k, &v).unwrap();
    }
    let session = zenoh::open(config).wait().expect("raw session");
    let ask_bytes = |bytes: Vec<u8>| -> Vec<u8> {
        let replies = session
            .get(SERVICE)
            .payload(bytes)
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(Duration::from_secs(5))
            .wait()
            .unwrap();
        let reply = replies.recv().expect("one reply");
        let sample = reply.into_result().expect("an Ok reply");
        assert!(replies.recv().is_err(), "exactly one reply");
        sample.payload().to_bytes().to_vec()
    };
    let ask = |bytes: Vec<u8>| -> ResponseHeader {
        let mut payload = Vec::new();
        let h = wire::decode_response(&ask_bytes(bytes), usize::MAX, &mut payload)
            .expect("a well-formed response");
        assert!(payload.is_empty());
        h
    };
    let mut h = *good.header();
    h.request_id = 4242;
    let mut bytes = Vec::new();
    wire::encode_request(&h, rows, &mut bytes);
    let status = |r: &ResponseHeader| Status::from_code(r.status).unwrap();
    // empty, shorter than the header, a torn row
    let r = ask(Vec::new());
    assert_eq!((status(&r), r.request_id), (Status::BadLayout, 0));
    let r = ask(bytes[..100].to_vec());
    assert_eq!((status(&r), r.request_id), (Status::BadLayout, 4242));
    let r = ask(bytes[..bytes.len() - 5].to_vec());
    assert_eq!((status(&r), r.request_id), (Status::BadLayout, 4242));
    // another version: refused before anything else is read
    let mut v3 = bytes[..40].to_vec();
    v3[0] = 3;
    let r = ask(v3);
    assert_eq!(
        (status(&r), r.field, r.limit),
        (Status::BadVersion, Field::Version as u32, PROTOCOL_VERSION)
    );
    // a client of version 1 (its 152-byte header, two rows) gets bad-version in the 48
    // bytes version 1 reads: version 2, the request's id, limit 2
    let mut v1 = bytes[..152].to_vec();
    v1[0..4].copy_from_slice(&1u32.to_le_bytes());
    v1.extend_from_slice(&bytes[wire::REQUEST_HEADER_BYTES..][..2 * wire::ROW_BYTES]);
    let reply = ask_bytes(v1);
    assert_eq!(reply.len(), 48);
    let word = |i: usize| u32::from_le_bytes(reply[i..i + 4].try_into().unwrap());
    assert_eq!(
        (word(0), word(4), word(36), word(40)),
        (
            PROTOCOL_VERSION,
            Status::BadVersion.code(),
            Field::Version as u32,
            PROTOCOL_VERSION
        )
    );
    assert_eq!(&reply[8..16], &4242u64.to_le_bytes());
    // more rows than --max-agents 4 x 64 history rows: refused before decoding
    let mut huge = bytes[..wire::REQUEST_HEADER_BYTES].to_vec();
    huge.resize(wire::REQUEST_HEADER_BYTES + 257 * wire::ROW_BYTES, 0);
    let r = ask(huge);
    assert_eq!((status(&r), r.limit), (Status::BadLayout, 256));
    // a good request as raw bytes is answered with the batch
    let replies = session
        .get(SERVICE)
        .payload(bytes.clone())
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(Duration::from_secs(5))
        .wait()
        .unwrap();
    let sample = replies.recv().unwrap().into_result().unwrap();
    let mut payload = Vec::new();
    let r = wire::decode_response(&sample.payload().to_bytes(), usize::MAX, &mut payload).unwrap();
    assert_eq!(
        (status(&r), r.request_id, r.agents, r.k, r.steps),
        (Status::Ok, 4242, 2, 10, 30)
    );
    let (_, (pos, lens)) = local_bits(&CliffMap::demo(), &good);
    let (p, l) = payload.split_at(pos.len());
    assert_eq!((p, l), (&pos[..], &lens[..]));
    // and with scores, they follow the lengths
    h.flags = cliff_client::protocol::FLAG_SCORES;
    wire::encode_request(&h, rows, &mut bytes);
    let replies = session
        .get(SERVICE)
        .payload(bytes)
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(Duration::from_secs(5))
        .wait()
        .unwrap();
    let sample = replies.recv().unwrap().into_result().unwrap();
    let r = wire::decode_response(&sample.payload().to_bytes(), usize::MAX, &mut payload).unwrap();
    assert_eq!((status(&r), r.flags), (Status::Ok, 1));
    let (_, want_scores, _) = local_scored(&CliffMap::demo(), &good.clone().scores(true));
    assert_eq!(want_scores.len(), 2 * 10);
    assert_eq!(&payload[pos.len() + lens.len()..], &want_scores[..]);
}

#[test]
fn a_remote_client_killed_mid_request_does_not_disturb_the_others() {
    let ns = Namespace::new("zkill");
    let mut daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_KILLED_CLIENT)]);
    let spec =
        |n: u64, agents: usize, tag: &str| format!("{PORT_KILLED_CLIENT},{n},{agents},{tag}");
    let mut victim = ChildClient::spawn_with(
        "zenoh_child_client",
        "CLIFF_ZENOH_CHILD",
        &spec(1_000_000, 16, "victim"),
    );
    victim.wait_line("CHILD victim started", Duration::from_secs(30));
    let mut others: Vec<ChildClient> = (0..2)
        .map(|i| {
            ChildClient::spawn_with(
                "zenoh_child_client",
                "CLIFF_ZENOH_CHILD",
                &spec(200, 1 + i, &format!("o{i}")),
            )
        })
        .collect();
    others[0].wait_line("CHILD o0 started", Duration::from_secs(30));
    // the victim sends large requests back to back: killed, it is most likely mid-request
    std::thread::sleep(Duration::from_millis(150));
    victim.kill9();
    // a local iceoryx2 client is served meanwhile too
    let map = CliffMap::demo();
    let mut local = ns.connect(WaitMode::Block);
    for i in 0..50 {
        let req = demo_request(900 + i, 3, 20, Method::Cliff);
        let p = local.predict(&req).expect("local client served");
        assert_eq!(bits(p.positions(), p.lens()), local_bits(&map, &req).1);
    }
    for (i, c) in others.iter_mut().enumerate() {
        c.wait_line(&format!("CHILD o{i} done 200"), Duration::from_secs(90));
        assert!(c.wait_exit(Duration::from_secs(10)).success(), "child o{i}");
    }
    assert!(daemon.child.try_wait().unwrap().is_none(), "cliffd died");
    // and a new remote client is served after it all
    let mut late = remote(PORT_KILLED_CLIENT, Duration::from_secs(5));
    let req = demo_request(1, 2, 20, Method::Cliff);
    let p = late
        .predict(&req)
        .expect("served after a remote client was killed");
    assert_eq!(bits(p.positions(), p.lens()), local_bits(&map, &req).1);
}

#[test]
fn a_restarted_daemon_is_found_again_by_the_same_client() {
    let ns = Namespace::new("zrestart");
    let ep = endpoint(PORT_RESTART);
    let mut daemon = Daemon::start_tagged(&ns, &["--zenoh", &ep], "daemon1");
    let deadline = Duration::from_millis(500);
    let mut c = remote(PORT_RESTART, deadline);
    let map = CliffMap::demo();
    let req = demo_request(3, 2, 10, Method::Cliff);
    let want = local_bits(&map, &req).1;
    let p = c.predict(&req).expect("before the kill");
    assert_eq!(bits(p.positions(), p.lens()), want);
    daemon.signal(SIGKILL);
    daemon.wait_exit(Duration::from_secs(5)).expect("killed");
    // while it is down: a typed error, within the deadline
    for _ in 0..5 {
        let t = Instant::now();
        match c.predict(&req) {
            Err(Error::NoDaemon { .. } | Error::Deadline { .. }) => {}
            Ok(_) => panic!("answered by a dead daemon"),
            Err(e) => panic!("unexpected error {e}"),
        }
        assert!(
            t.elapsed() < deadline + Duration::from_millis(300),
            "took {:?}",
            t.elapsed()
        );
    }
    let _daemon2 = Daemon::start_tagged(&ns, &["--zenoh", &ep], "daemon2");
    let ready = Instant::now();
    let recovered = loop {
        match c.predict(&req) {
            Ok(p) => {
                assert_eq!(bits(p.positions(), p.lens()), want);
                break ready.elapsed();
            }
            Err(Error::NoDaemon { .. } | Error::Deadline { .. }) => {
                assert!(
                    ready.elapsed() < Duration::from_secs(5),
                    "not recovered within 5 s"
                );
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("unexpected error {e}"),
        }
    };
    eprintln!("recovered {recovered:?} after the restart");
    for i in 0..20 {
        let req = demo_request(10 + i, 1, 10, Method::Cliff);
        let p = c.predict(&req).expect("every call after recovery");
        assert_eq!(bits(p.positions(), p.lens()), local_bits(&map, &req).1);
    }
}

#[test]
fn without_a_daemon_connecting_and_deadlines_are_typed_errors() {
    let e = Client::connect_zenoh(&endpoint(PORT_NO_DAEMON), SERVICE).unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    assert!(e.to_string().contains(&endpoint(PORT_NO_DAEMON)), "{e}");
    let e = Client::connect_zenoh("tcp/127.0.0.1", SERVICE).unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. } | Error::Zenoh(_)), "{e}");

    // a daemon on another service name: connected, but nobody answers on the key
    let ns = Namespace::new("zdeadline");
    let _daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_NO_DAEMON)]);
    let mut other =
        Client::connect_zenoh(&endpoint(PORT_NO_DAEMON), "cliff/other").expect("connect");
    let e = other
        .predict(&demo_request(1, 1, 10, Method::Cliff))
        .unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    // a deadline far shorter than the largest request takes (even its round trip
    // alone: loopback TCP through zenoh takes tens of microseconds)
    let mut c = remote(PORT_NO_DAEMON, Duration::from_secs(5));
    let big = demo_request(2, 32, 50, Method::Cliff);
    c.set_deadline(Duration::from_micros(20));
    let e = c.predict(&big).unwrap_err();
    assert!(matches!(e, Error::Deadline { .. }), "{e}");
    c.set_deadline(Duration::from_secs(5));
    let p = c.predict(&big).expect("with a long deadline");
    assert_eq!(p.shape(), (32, 50, 30));
}

#[test]
fn the_daemon_listens_only_where_asked_and_does_not_scout() {
    let ns = Namespace::new("zdefaults");
    let daemon = Daemon::start(&ns, &["--zenoh", &endpoint(PORT_DEFAULTS)]);
    let pid = daemon.pid();
    let sockets = |args: &[&str]| -> Vec<String> {
        let out = std::process::Command::new("ss")
            .args(args)
            .output()
            .expect("run ss");
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.contains(&format!("pid={pid},")))
            .map(str::to_string)
            .collect()
    };
    // TCP: one listener, on the given address only
    let tcp = sockets(&["-ltnpH"]);
    assert_eq!(tcp.len(), 1, "{tcp:?}");
    assert!(
        tcp[0].contains(&format!("127.0.0.1:{PORT_DEFAULTS}")),
        "{tcp:?}"
    );
    // UDP: no scouting socket (multicast scouting uses 224.0.0.224:7446)
    let udp = sockets(&["-lunpH"]);
    assert!(udp.is_empty(), "{udp:?}");
    // without --zenoh nothing of zenoh runs at all
    let ns2 = Namespace::new("zdefaults2");
    let plain = Daemon::start(&ns2, &[]);
    let pid = plain.pid();
    let out = std::process::Command::new("ss")
        .args(["-ltunpH"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains(&format!("pid={pid},")), "{text}");
    assert!(!plain.ready_line.contains("zenoh"), "{}", plain.ready_line);
}
