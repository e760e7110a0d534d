//! cliffd as a real process: answers match the in-process predictor.

mod common;

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::WaitMode;
use common::*;

#[test]
fn daemon_answers_like_the_in_process_predictor() {
    let ns = Namespace::new("basic");
    let daemon = Daemon::start(&ns, &[]);
    assert!(daemon.ready_line.contains("demo"), "{}", daemon.ready_line);
    let map = CliffMap::demo();
    for wait in [WaitMode::Spin, WaitMode::Hybrid, WaitMode::Block] {
        let mut client = ns.connect(wait);
        for i in 0..20 {
            let method = if i % 5 == 4 {
                Method::Cvm
            } else {
                Method::Cliff
            };
            let req = demo_request(i, 1 + (i as usize % 3), 20, method);
            let (shape, want) = local_bits(&map, &req);
            let p = client
                .predict(&req)
                .unwrap_or_else(|e| panic!("{wait} request {i}: {e}"));
            assert_eq!(p.shape(), shape);
            assert_eq!(bits(p.positions(), p.lens()), want, "{wait} request {i}");
            // the iterators see the same data
            let n: usize = p
                .agents()
                .map(|a| a.samples().map(|s| s.len()).sum::<usize>())
                .sum();
            assert_eq!(n, p.lens().iter().map(|&l| l as usize).sum::<usize>());
        }
    }
}

#[test]
fn responses_say_how_long_the_daemon_stays_awake() {
    let map = CliffMap::demo();
    let req = demo_request(5, 1, 20, Method::Cliff);
    let want = local_bits(&map, &req);
    // default: the daemon polls for 1 ms after a request, then sleeps on its event
    let ns = Namespace::new("awake");
    let _daemon = Daemon::start(&ns, &[]);
    let mut client = ns.connect(WaitMode::Hybrid);
    assert!(
        client.daemon_awake(),
        "nothing is known before the first response"
    );
    let got = |c: &mut cliff_client::Client| {
        let p = c.predict(&req).expect("served");
        (p.shape(), bits(p.positions(), p.lens()))
    };
    assert_eq!(got(&mut client), want);
    std::thread::sleep(Duration::from_millis(30));
    assert!(
        !client.daemon_awake(),
        "the daemon said it sleeps after 1 ms"
    );
    // a hybrid client then sleeps at once, and the sleeping daemon still answers
    for _ in 0..3 {
        assert_eq!(got(&mut client), want);
        std::thread::sleep(Duration::from_millis(30));
    }
    // a daemon told to stay awake for 10 s says so
    let ns = Namespace::new("awake10");
    let _daemon = Daemon::start(&ns, &["--idle-spin-us", "10000000"]);
    let mut client = ns.connect(WaitMode::Hybrid);
    assert_eq!(got(&mut client), want);
    std::thread::sleep(Duration::from_millis(30));
    assert!(client.daemon_awake());
}

#[test]
fn a_client_moves_to_another_thread_and_can_be_shared() {
    let ns = Namespace::new("send");
    let _daemon = Daemon::start(&ns, &[]);
    let map = CliffMap::demo();
    // connected here, used on a worker thread (a robot's prediction thread)
    let mut client = ns.connect(WaitMode::Hybrid);
    let req = demo_request(3, 2, 20, Method::Cliff);
    let want = local_bits(&map, &req);
    let (client, got) = std::thread::spawn(move || {
        let got = {
            let p = client.predict(&req).expect("served on the worker thread");
            (p.shape(), bits(p.positions(), p.lens()))
        };
        (client, got)
    })
    .join()
    .unwrap();
    assert_eq!(got, want);
    // and shared behind a mutex by two threads taking turns
    let shared = std::sync::Arc::new(std::sync::Mutex::new(client));
    let workers: Vec<_> = (0..2u64)
        .map(|t| {
            let shared = shared.clone();
            let map = map.clone();
            std::thread::spawn(move || {
                for i in 0..10 {
                    let req = demo_request(100 * t + i, 1, 10, Method::Cliff);
                    let want = local_bits(&map, &req);
                    let mut c = shared.lock().unwrap();
                    let p = c.predict(&req).expect("served");
                    assert_eq!((p.shape(), bits(p.positions(), p.lens())), want);
                }
            })
        })
        .collect();
    for w in workers {
        w.join().unwrap();
    }
}

use std::time::Duration;

use cliff::tracks::{Format, read_tracks};
use cliff_client::protocol::{FLAG_SCORES, FLAG_VELOCITY, Field, METHOD_CVM, TIME_AT};
use cliff_client::{Error, Observation, Request, RequestHeader, Status};

/// A request in wire form with one or two agents walking in the demo hall.
fn good(agents: u32) -> (RequestHeader, Vec<Observation>) {
    let r = demo_request(9, agents as usize, 5, cliff::predict::Method::Cliff);
    (*r.header(), r.rows().to_vec())
}

#[test]
fn every_kind_of_bad_request_gets_its_status_and_the_daemon_keeps_serving() {
    let ns = Namespace::new("bad");
    let daemon = Daemon::start(
        &ns,
        &[
            "--max-agents",
            "4",
            "--max-k",
            "10",
            "--max-steps",
            "40",
            "--max-history",
            "8",
        ],
    );
    let mut client = ns.connect(WaitMode::Hybrid);
    let mut bystander = ns.connect(WaitMode::Spin);
    let map = CliffMap::demo();
    let step = map.grid().step();
    type Case = (
        &'static str,
        Box<dyn Fn(&mut RequestHeader, &mut Vec<Observation>)>,
        Status,
        Option<u32>,
    );
    let cases: Vec<Case> = vec![
        (
            "version 1",
            Box::new(|h, _| h.version = 1),
            Status::BadVersion,
            Some(2),
        ),
        (
            "version 3",
            Box::new(|h, _| h.version = 3),
            Status::BadVersion,
            Some(2),
        ),
        (
            "NaN speed_beta",
            Box::new(|h, _| h.speed_beta = f64::NAN),
            Status::NonFinite,
            None,
        ),
        (
            "negative speed_beta",
            Box::new(|h, _| h.speed_beta = -0.1),
            Status::BadValue,
            None,
        ),
        (
            "infinite coast",
            Box::new(|h, _| h.coast = f64::INFINITY),
            Status::NonFinite,
            None,
        ),
        (
            "negative coast",
            Box::new(|h, _| h.coast = -1.0),
            Status::BadValue,
            None,
        ),
        (
            "coast beyond the horizon",
            Box::new(|h, _| h.coast = h.horizon + 0.4),
            Status::BadValue,
            None,
        ),
        (
            "unknown flag",
            Box::new(|h, _| h.flags = 1 << 5),
            Status::BadValue,
            None,
        ),
        (
            "unknown time mode",
            Box::new(|h, _| h.time_mode = 9),
            Status::BadValue,
            None,
        ),
        (
            "NaN time",
            Box::new(|h, _| {
                h.time_mode = TIME_AT;
                h.time = f64::NAN
            }),
            Status::NonFinite,
            None,
        ),
        (
            "radius over the map's limit with CVM and scores (they look the map up)",
            Box::new(move |h, _| {
                h.method = METHOD_CVM;
                h.flags = FLAG_SCORES;
                h.radius = 4.0 * step + 0.01
            }),
            Status::RadiusTooLarge,
            Some((4000.0 * step) as u32),
        ),
        (
            "unknown map",
            Box::new(|h, _| h.set_map_name("nowhere").unwrap()),
            Status::UnknownMap,
            None,
        ),
        (
            "unknown method",
            Box::new(|h, _| h.method = 7),
            Status::UnknownMethod,
            None,
        ),
        (
            "unknown heading rule",
            Box::new(|h, _| h.heading_rule = 9),
            Status::UnknownMethod,
            None,
        ),
        (
            "unknown kind",
            Box::new(|h, _| h.kind = 42),
            Status::UnknownKind,
            None,
        ),
        (
            "unknown kind and unknown map (the kind is checked first)",
            Box::new(|h, _| {
                h.kind = 42;
                h.set_map_name("nowhere").unwrap();
            }),
            Status::UnknownKind,
            None,
        ),
        (
            "NaN dt",
            Box::new(|h, _| h.dt = f64::NAN),
            Status::NonFinite,
            None,
        ),
        (
            "infinite beta",
            Box::new(|h, _| h.beta = f64::INFINITY),
            Status::NonFinite,
            None,
        ),
        (
            "NaN position",
            Box::new(|_, r| r[2].x = f64::NAN),
            Status::NonFinite,
            None,
        ),
        (
            "infinite time",
            Box::new(|_, r| r[1].t = f64::NEG_INFINITY),
            Status::NonFinite,
            None,
        ),
        (
            "negative radius",
            Box::new(|h, _| h.radius = -1.0),
            Status::BadValue,
            None,
        ),
        (
            "radius over the map's limit (4 grid steps)",
            Box::new(move |h, _| h.radius = 4.0 * step + 0.01),
            Status::RadiusTooLarge,
            Some((4000.0 * step) as u32),
        ),
        (
            "radius far over the limit",
            Box::new(|h, _| h.radius = 150.0),
            Status::RadiusTooLarge,
            Some((4000.0 * step) as u32),
        ),
        ("k zero", Box::new(|h, _| h.k = 0), Status::BadK, Some(10)),
        (
            "k over limit",
            Box::new(|h, _| h.k = 11),
            Status::BadK,
            Some(10),
        ),
        (
            "steps zero",
            Box::new(|h, _| h.horizon = 0.0),
            Status::BadSteps,
            Some(40),
        ),
        (
            "steps over limit",
            Box::new(|h, _| h.horizon = 41.0 * h.dt),
            Status::BadSteps,
            Some(40),
        ),
        (
            "no agents",
            Box::new(|h, r| {
                h.agents = 0;
                r.clear();
            }),
            Status::BadAgents,
            Some(4),
        ),
        (
            "agents over limit",
            Box::new(|h, r| {
                let one: Vec<Observation> = r.clone();
                for a in 1..5 {
                    r.extend(one.iter().map(|o| Observation { agent: a, ..*o }));
                }
                h.agents = 5;
            }),
            Status::BadAgents,
            Some(4),
        ),
        (
            "history too short",
            Box::new(|_, r| {
                r.truncate(1);
                r[0].flags = 0;
            }),
            Status::HistoryTooShort,
            None,
        ),
        (
            "time not increasing",
            Box::new(|_, r| r[3].t = r[2].t),
            Status::HistoryNotIncreasing,
            None,
        ),
        (
            "time going back",
            Box::new(|_, r| r[4].t = 0.0),
            Status::HistoryNotIncreasing,
            None,
        ),
        (
            "history too long",
            Box::new(|_, r| {
                let last = r[r.len() - 1];
                for j in 1..=5 {
                    r.push(Observation {
                        t: last.t + j as f64,
                        ..last
                    });
                }
            }),
            Status::HistoryTooLong,
            Some(8),
        ),
        (
            "rows of an undeclared agent",
            Box::new(|_, r| {
                let mut o = r[0];
                o.agent = 1;
                r.push(o);
            }),
            Status::BadLayout,
            None,
        ),
        (
            "mixed velocity flags",
            Box::new(|_, r| r[1].flags ^= FLAG_VELOCITY),
            Status::BadLayout,
            None,
        ),
    ];
    for (i, (name, mutate, status, limit)) in cases.iter().enumerate() {
        let (mut h, mut rows) = good(1);
        mutate(&mut h, &mut rows);
        match client.predict_raw(&h, &rows, Duration::from_secs(5)) {
            Err(Error::Rejected(r)) => {
                assert_eq!(r.status, *status, "{name}: {r}");
                if let Some(l) = limit {
                    assert_eq!(r.limit, *l, "{name}: {r}");
                }
            }
            Err(e) => panic!("{name}: {e}"),
            Ok(p) => panic!("{name}: accepted with shape {:?}", p.shape()),
        }
        // and the daemon keeps serving, this client and the others
        let req = demo_request(i as u64, 2, 8, cliff::predict::Method::Cliff);
        let want = local_bits(&map, &req);
        for c in [&mut client, &mut bystander] {
            let p = c
                .predict(&req)
                .unwrap_or_else(|e| panic!("after {name}: {e}"));
            assert_eq!(
                (p.shape(), bits(p.positions(), p.lens())),
                want,
                "after {name}"
            );
        }
    }
    // a rejection names the place: agent 1, row 2, position
    let (mut h, mut rows) = good(2);
    let at = rows.iter().position(|o| o.agent == 1).unwrap() + 2;
    rows[at].y = f64::INFINITY;
    let e = client
        .predict_raw(&h, &rows, Duration::from_secs(5))
        .unwrap_err();
    let Error::Rejected(r) = e else { panic!("{e}") };
    assert_eq!(
        (r.status, r.agent, r.row, r.field),
        (Status::NonFinite, Some(1), Some(2), Field::Position)
    );
    assert!(e.to_string().contains("agent 1 row 2"), "{e}");
    // CVM with the largest allowed request goes through
    h.method = METHOD_CVM;
    h.k = 10;
    h.horizon = 40.0 * h.dt;
    rows[at].y = 0.0;
    let p = client
        .predict_raw(&h, &rows, Duration::from_secs(5))
        .expect("at the limits");
    assert_eq!(p.shape(), (2, 10, 40));
    assert!(daemon.child.id() > 0);
}

#[test]
fn real_thor_tracks_on_the_real_thor_map_match_in_process() {
    let ns = Namespace::new("thor");
    let map_path = shared_data("thor1/cliffmap.csv");
    let arg = format!("thor1={}", map_path.display());
    let _daemon = Daemon::start(&ns, &["--map", &arg]);
    let map = CliffMap::load(&map_path).unwrap();
    let tracks = read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
    let mut client = ns.connect(WaitMode::Hybrid);
    let params = cliff::predict::Params {
        k: 20,
        seed: 11,
        ..Default::default()
    };
    let mut checked = 0;
    let mut moved = 0;
    for (n, t) in tracks
        .iter()
        .filter(|t| t.rows.len() >= 20)
        .take(12)
        .enumerate()
    {
        let mut req = Request::new("thor1", &params).unwrap();
        // an 8-row history (3.2 s) from the middle of the track, two ways
        let w = &t.rows[t.rows.len() / 2 - 8..t.rows.len() / 2];
        req.add_agent(w.iter().map(|r| {
            Observation::with_velocity(r.t, r.position.x, r.position.y, r.speed, r.angle)
        }));
        req.add_agent(
            w.iter()
                .map(|r| Observation::position(r.t, r.position.x, r.position.y)),
        );
        req.set_seed(100 + n as u64);
        let want = local_bits(&map, &req);
        let p = client
            .predict(&req)
            .unwrap_or_else(|e| panic!("track {}: {e}", t.id));
        assert_eq!(
            (p.shape(), bits(p.positions(), p.lens())),
            want,
            "track {}",
            t.id
        );
        moved += p.lens().iter().filter(|&&l| l > 0).count();
        checked += 1;
    }
    assert_eq!(checked, 12);
    assert!(
        moved > 100,
        "most samples of real people on their own map make steps: {moved}"
    );
}

#[test]
fn random_garbage_requests_are_answered_and_never_stop_the_daemon() {
    use rand::{RngExt, SeedableRng};
    let ns = Namespace::new("garbage");
    let mut daemon = Daemon::start(&ns, &[]);
    let mut client = ns.connect(WaitMode::Hybrid);
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(99);
    let (good_h, good_rows) = good(2);
    let (mut ok, mut rejected) = (0, 0);
    for i in 0..400 {
        let mut h = good_h;
        let mut rows = good_rows.clone();
        // scramble a few fields with arbitrary bit patterns
        for _ in 0..rng.random_range(1..4) {
            match rng.random_range(0..12) {
                0 => h.version = rng.random(),
                1 => h.kind = rng.random_range(0..3),
                2 => h.method = rng.random(),
                3 => h.k = rng.random(),
                4 => h.agents = rng.random_range(0..40),
                5 => h.dt = f64::from_bits(rng.random()),
                6 => h.horizon = f64::from_bits(rng.random()),
                7 => h.radius = f64::from_bits(rng.random()),
                8 => h.map[rng.random_range(0..64)] = rng.random(),
                9 => {
                    let r = rng.random_range(0..rows.len());
                    rows[r].t = f64::from_bits(rng.random());
                }
                10 => {
                    let r = rng.random_range(0..rows.len());
                    rows[r].agent = rng.random();
                }
                _ => rows.truncate(rng.random_range(0..rows.len())),
            }
        }
        if h.kind == cliff_client::KIND_RELOAD {
            h.kind = 2; // reloads are not garbage
        }
        match client.predict_raw(&h, &rows, Duration::from_secs(5)) {
            Ok(p) => {
                let (a, k, s) = p.shape();
                assert_eq!(p.positions().len(), a * k * s);
                ok += 1;
            }
            Err(Error::Rejected(_)) => rejected += 1,
            Err(e) => panic!("request {i}: {e}"),
        }
    }
    assert!(rejected > 200, "{ok} accepted, {rejected} rejected");
    // still serving, with the right numbers
    let req = demo_request(3, 2, 10, cliff::predict::Method::Cliff);
    let p = client.predict(&req).expect("served after the garbage");
    assert_eq!(
        (p.shape(), bits(p.positions(), p.lens())),
        local_bits(&CliffMap::demo(), &req)
    );
    assert!(daemon.child.try_wait().unwrap().is_none());
}

#[test]
fn the_largest_requests_run_in_chunks_with_the_bytes_of_one_call_beside_small_ones() {
    let ns = Namespace::new("chunks");
    let _daemon = Daemon::start(&ns, &["--chunk-positions", "5000"]);
    let map = CliffMap::demo();
    // small requests from another client, all the while
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let small = {
        let (stop, map) = (stop.clone(), map.clone());
        let mut client = ns.connect(WaitMode::Hybrid);
        std::thread::spawn(move || {
            let mut n = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) || n < 20 {
                let req = demo_request(n, 1, 20, Method::Cliff);
                let want = local_bits(&map, &req);
                let p = client.predict(&req).expect("small request served");
                assert_eq!((p.shape(), bits(p.positions(), p.lens())), want);
                n += 1;
            }
            n
        })
    };
    let mut client = ns.options(WaitMode::Hybrid);
    client.deadline = Duration::from_secs(10);
    let mut client = cliff_client::Client::connect_with(SERVICE, client).unwrap();
    // the default limits' largest request: 32 agents x 50 samples x 100 steps, with a
    // radius that has no table yet (grid scan, then the table built in the background)
    for (i, radius) in [(0, 0.9), (1, 0.9), (2, std::f64::consts::FRAC_1_SQRT_2)] {
        let mut req = demo_request(50 + i, 32, 50, Method::Cliff);
        req.set_params(&Params {
            k: 50,
            horizon: 40.0,
            radius,
            seed: 77 + i,
            ..Params::default()
        });
        let want = local_bits(&map, &req);
        let p = client.predict(&req).expect("largest request served");
        assert_eq!(p.shape(), (32, 50, 100));
        assert_eq!(
            (p.shape(), bits(p.positions(), p.lens())),
            want,
            "request {i}"
        );
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    assert!(small.join().unwrap() >= 20);
}
