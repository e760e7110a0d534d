//! Protocol version 2 through a live `cliffd`: the options beyond the paper, scores and
//! the time of day give the in-process bytes; clients of version 1 get `bad-version`
//! (not silence), and a client of version 2 names a daemon of version 1.

mod common;

use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff::tracks::{Format, read_tracks};
use cliff_client::protocol::{self, MapTime};
use cliff_client::{
    Error, Field, Observation, PROTOCOL_VERSION, Request, Status, WaitMode, legacy,
};
use common::*;
use iceoryx2::prelude::*;

/// Requests of real THÖR1 people: 8-row histories from the middle of tracks.
fn thor_requests(params: &Params, n: usize) -> Vec<Request> {
    let tracks = read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
    tracks
        .iter()
        .filter(|t| t.rows.len() >= 20)
        .take(n)
        .enumerate()
        .map(|(i, t)| {
            let mut r = Request::new("thor1", params).unwrap();
            r.set_seed(500 + i as u64);
            let w = &t.rows[t.rows.len() / 2 - 8..t.rows.len() / 2];
            r.add_agent(w.iter().map(|o| {
                Observation::with_velocity(o.t, o.position.x, o.position.y, o.speed, o.angle)
            }));
            r.add_agent(
                w.iter()
                    .map(|o| Observation::position(o.t, o.position.x, o.position.y)),
            );
            r
        })
        .collect()
}

#[test]
fn options_scores_and_time_through_the_daemon_give_the_in_process_bytes() {
    let ns = Namespace::new("v2opts");
    let map_path = shared_data("thor1/cliffmap.csv");
    let arg = format!("thor1={}", map_path.display());
    // small chunks: most requests below are predicted in several rounds
    let daemon = Daemon::start(&ns, &["--map", &arg, "--chunk-positions", "600"]);
    assert!(
        daemon.ready_line.contains("protocol v2"),
        "{}",
        daemon.ready_line
    );
    let map = CliffMap::load(&map_path).unwrap();
    let mut client = ns.connect(WaitMode::Hybrid);
    let params = Params {
        k: 20,
        ..Params::default()
    };
    let requests = thor_requests(&params, 6);
    let times = [MapTime::Now, MapTime::At(1_351_700_000.0), MapTime::AllDay];
    let mut with_scores = 0;
    let mut best_differs = 0;
    let mut kept = cliff::predict::TrajectoryBatch::new();
    for (i, base) in requests.iter().enumerate() {
        for method in Method::ALL {
            for (j, (speed_beta, coast, scores)) in [
                (0.0, 0.0, true),
                (2.0, 0.0, false),
                (0.0, 6.0, true),
                (1.5, 12.0, true),
            ]
            .into_iter()
            .enumerate()
            {
                let mut req = base
                    .clone()
                    .method(method)
                    .speed_beta(speed_beta)
                    .coast(coast)
                    .scores(scores);
                req.set_map_time(times[(i + j) % 3]);
                let want = local_scored(&map, &req);
                let p = client
                    .predict(&req)
                    .unwrap_or_else(|e| panic!("request {i} {method} {j}: {e}"));
                let got = scored(&p);
                assert_eq!(got, want, "request {i} {method} options {j}");
                // a copy keeps the scores (and none when there are none)
                p.to_batch(&mut kept);
                assert_eq!(score_bits(kept.scores()), want.1);
                assert_eq!(kept.best_sample(1), p.best_sample(1));
                // the improved method scores its samples, asked or not
                let scored = scores || method == Method::Improved;
                assert_eq!(p.has_scores(), scored);
                assert_eq!(p.scores().len(), if scored { 2 * 20 } else { 0 });
                if scored {
                    with_scores += 1;
                    for a in 0..2 {
                        let best = p.best_sample(a).expect("scores");
                        assert_eq!(p.agent(a).best_sample(), Some(best));
                        assert_eq!(p.agent(a).scores(), &p.scores()[a * 20..(a + 1) * 20]);
                        let top = p.score(a, best).unwrap();
                        assert!(p.agent(a).scores().iter().all(|s| *s <= top));
                        best_differs += usize::from(best != 0);
                    }
                } else {
                    assert_eq!(p.best_sample(0), None);
                }
            }
        }
    }
    // scores asked for (3 of the 4 option sets) for 4 methods, and improved's always
    assert_eq!(with_scores, 6 * (4 * 3 + 4));
    // the scores rank samples: the best one is not always the first
    assert!(best_differs > 10, "{best_differs}");
}

#[test]
fn the_largest_request_with_options_and_scores_is_chunked_and_identical() {
    let ns = Namespace::new("v2big");
    let _daemon = Daemon::start(&ns, &["--chunk-positions", "5000"]);
    let map = CliffMap::demo();
    let mut client = ns.options(WaitMode::Hybrid);
    client.deadline = Duration::from_secs(10);
    let mut client = cliff_client::Client::connect_with(SERVICE, client).unwrap();
    let mut req = demo_request(3, 32, 50, Method::Cliff)
        .speed_beta(2.0)
        .coast(8.0)
        .scores(true);
    req.set_params(&Params {
        k: 50,
        horizon: 40.0,
        seed: 9,
        ..Params::default()
    });
    assert_eq!(req.options().coast, 8.0, "set_params keeps the options");
    let want = local_scored(&map, &req);
    let p = client.predict(&req).expect("largest request served");
    assert_eq!(p.shape(), (32, 50, 100));
    assert_eq!(p.scores().len(), 32 * 50);
    assert_eq!(scored(&p), want);
}

/// What a client of protocol version 1 does: open the bare service name with version
/// 1's types, send a version 1 request, wait for the answer.
fn version_1_round_trip(ns: &Namespace, request_id: u64) -> (legacy::ResponseHeader, usize) {
    let config = cliff_client::iceoryx_config(Some(&ns.prefix)).unwrap();
    let node = NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .unwrap();
    let service = node
        .service_builder(&ServiceName::new(&legacy::ipc_service_name(SERVICE)).unwrap())
        .request_response::<[legacy::Observation], [u32]>()
        .request_user_header::<legacy::RequestHeader>()
        .response_user_header::<legacy::ResponseHeader>()
        .open()
        .expect("a daemon of version 2 still serves version 1's name");
    assert!(service.dynamic_config().number_of_servers() > 0);
    let port = service
        .client_builder()
        .initial_max_slice_len(64)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .unwrap();
    let rows: Vec<legacy::Observation> = (0..3)
        .map(|j| legacy::Observation {
            t: 0.4 * j as f64,
            x: -10.0 + 0.5 * j as f64,
            y: 0.5,
            ..Default::default()
        })
        .collect();
    let mut map = [0u8; protocol::MAP_NAME_BYTES];
    map[..4].copy_from_slice(b"demo");
    let mut req = port
        .loan_slice_uninit(rows.len())
        .unwrap()
        .write_from_slice(&rows);
    *req.user_header_mut() = legacy::RequestHeader {
        request_id,
        map,
        agents: 1,
        ..Default::default()
    };
    let pending = req.send().unwrap();
    assert_eq!(pending.number_of_server_connections(), 1);
    // a version 1 client waits up to its deadline (1 s by default)
    let end = Instant::now() + Duration::from_secs(1);
    loop {
        if let Some(r) = pending.receive().unwrap() {
            return (*r.user_header(), r.payload().len());
        }
        assert!(
            Instant::now() < end,
            "no answer within a version 1 client's deadline"
        );
        std::thread::sleep(Duration::from_micros(200));
    }
}

#[test]
fn a_version_1_client_gets_bad_version_with_the_daemons_version() {
    let ns = Namespace::new("v1client");
    let _daemon = Daemon::start(&ns, &[]);
    for id in [7u64, 8, 9] {
        let (h, words) = version_1_round_trip(&ns, id);
        assert_eq!(words, 0);
        assert_eq!(
            (h.version, h.status, h.request_id, h.field, h.limit),
            (
                PROTOCOL_VERSION,
                Status::BadVersion.code(),
                id,
                Field::Version as u32,
                PROTOCOL_VERSION
            )
        );
        assert_eq!((h.agents, h.k, h.steps), (0, 0, 0));
        // (a version 1 client reads this as "daemon speaks protocol 2, this client 1")
    }
    // after a pause the daemon sleeps on its event; an old client is still answered
    std::thread::sleep(Duration::from_millis(100));
    let (h, _) = version_1_round_trip(&ns, 10);
    assert_eq!(h.status, Status::BadVersion.code());
    // and version 2 clients are served as before
    let mut client = ns.connect(WaitMode::Block);
    let req = demo_request(1, 2, 10, Method::Cliff);
    let p = client.predict(&req).expect("served");
    assert_eq!(
        (p.shape(), bits(p.positions(), p.lens())),
        local_bits(&CliffMap::demo(), &req)
    );
}

#[test]
fn a_version_2_client_names_a_daemon_of_version_1() {
    // a daemon of version 1: its service under the bare name, with version 1's types
    let ns = Namespace::new("v1daemon");
    let config = cliff_client::iceoryx_config(Some(&ns.prefix)).unwrap();
    let node = NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .unwrap();
    let service = node
        .service_builder(&ServiceName::new(SERVICE).unwrap())
        .request_response::<[legacy::Observation], [u32]>()
        .request_user_header::<legacy::RequestHeader>()
        .response_user_header::<legacy::ResponseHeader>()
        .create()
        .unwrap();
    let e = cliff_client::Client::connect_with(SERVICE, ns.options(WaitMode::Hybrid))
        .expect_err("no service of version 2");
    // without a server the old service is no daemon
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    let _server = service.server_builder().create().unwrap();
    let e = cliff_client::Client::connect_with(SERVICE, ns.options(WaitMode::Hybrid))
        .expect_err("a daemon of version 1");
    assert!(matches!(e, Error::Protocol(_)), "{e}");
    assert!(
        e.to_string()
            .contains("the daemon speaks protocol version 1, this client 2"),
        "{e}"
    );
}

#[test]
fn a_daemon_refuses_to_start_beside_a_daemon_of_version_1() {
    let ns = Namespace::new("v1beside");
    let config = cliff_client::iceoryx_config(Some(&ns.prefix)).unwrap();
    let node = NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .unwrap();
    let service = node
        .service_builder(&ServiceName::new(SERVICE).unwrap())
        .request_response::<[legacy::Observation], [u32]>()
        .request_user_header::<legacy::RequestHeader>()
        .response_user_header::<legacy::ResponseHeader>()
        .max_servers(2)
        .create()
        .unwrap();
    let _server = service.server_builder().create().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cliffd"))
        .args(["--service", SERVICE, "--prefix", &ns.prefix])
        .output()
        .expect("run cliffd");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("'{SERVICE}'"))
            && (err.contains("protocol version 1") || err.contains("already serves")),
        "{err}"
    );
}

/// A 1 m grid over x, y in [-10, 10] whose locations all hold the flows `thetas`.
fn flow_map(thetas: &[f64]) -> CliffMap {
    use cliff::glam::DVec2;
    use cliff::map::{Component, Location};
    let mut locs = vec![];
    for ix in -10..=10 {
        for iy in -10..=10 {
            locs.push(Location {
                position: DVec2::new(ix as f64, iy as f64),
                components: thetas
                    .iter()
                    .map(|&theta| Component {
                        theta,
                        rho: 1.0,
                        cov: [0.02, 0.0, 0.0, 0.01],
                        weight: 1.0 / thetas.len() as f64,
                    })
                    .collect(),
                motion_ratio: 1.0,
                observation_ratio: 1.0,
            });
        }
    }
    CliffMap::new(locs).unwrap()
}

#[test]
fn a_time_of_day_set_is_served_by_the_slice_of_the_time_asked_for() {
    use cliff::map::{MapSet, SetParts};
    use std::f64::consts::FRAC_PI_2;
    use std::sync::Arc;
    // north-going people before noon, south-going after; the all-day map has both
    let (north, south, both) = (
        flow_map(&[FRAC_PI_2]),
        flow_map(&[3.0 * FRAC_PI_2]),
        flow_map(&[FRAC_PI_2, 3.0 * FRAC_PI_2]),
    );
    let slices = (0..24)
        .map(|h| match h {
            0..12 => Some(Arc::new(north.clone())),
            _ => Some(Arc::new(south.clone())),
        })
        .collect();
    let set = MapSet::from_parts(SetParts {
        all_day: Arc::new(both.clone()),
        slices,
        slice_length: 3600.0,
        clock_offset: 3600.0, // local time is UTC+1
        smoothing: None,
        observations: vec![],
    })
    .unwrap();
    let dir = std::env::temp_dir().join(format!("cliffd-tod-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("set.cliff");
    set.save(&path).unwrap();
    let ns = Namespace::new("v2tod");
    let arg = format!("hall={}", path.display());
    let _daemon = Daemon::start(&ns, &["--map", &arg]);
    let mut client = ns.connect(WaitMode::Hybrid);
    let params = Params {
        k: 20,
        dt: 1.0,
        horizon: 5.0,
        radius: 1.0,
        ..Params::default()
    };
    // a walker heading east at the centre: the slice's flow decides where it turns
    let mut req = Request::new("hall", &params).unwrap();
    req.add_agent((0..4).map(|i| Observation::position(i as f64, -3.0 + i as f64, 0.0)));
    let day = 86_400.0 * 15_000.0; // a midnight, UTC
    for (when, map, turns) in [
        (MapTime::At(day + 9.0 * 3600.0), &north, 1.0), // 10:00 local
        (MapTime::At(day + 14.0 * 3600.0), &south, -1.0), // 15:00 local
        (MapTime::AllDay, &both, 0.0),
    ] {
        req.set_map_time(when);
        let p = client.predict(&req).unwrap();
        assert_eq!(scored(&p), local_scored(map, &req), "{when:?}");
        // the mean last y says which way the samples turned
        let ys: Vec<f64> = (0..20)
            .map(|s| p.agent(0).sample(s).last().unwrap()[1] as f64)
            .collect();
        let mean = ys.iter().sum::<f64>() / 20.0;
        if turns != 0.0 {
            assert!(mean * turns > 1.0, "{when:?}: mean y {mean}");
        } else {
            assert!(ys.iter().any(|y| *y > 0.5) && ys.iter().any(|y| *y < -0.5));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
