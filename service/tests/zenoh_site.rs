//! A site with many robots, on loopback: a site cliffd learns THÖR1's map from remote
//! sessions' observations (each row once per session, track and time; the local
//! budgets per session; observations only on the observe key), and a robot's cliffd in
//! another iceoryx2 namespace follows it over zenoh (`--follow`): it serves the site's
//! versions under their numbers, byte for byte, keeps serving while the site is away,
//! restarts on its snapshot, and follows again when the site comes back. A link that
//! drops under a session's requests costs it nothing but time.
#![cfg(feature = "zenoh")]

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff::tracks::{Format, Track, read_tracks};
use cliff_client::protocol::{KIND_OBSERVE, RequestHeader, ResponseHeader};
use cliff_client::{
    Client, ClientOptions, Error, Field, Observation, ObserveRequest, PROTOCOL_VERSION, Request,
    Status, WaitMode, wire,
};
use common::*;
use zenoh::Wait;

const PORT_OBSERVE: u16 = 27_481;
const PORT_FOLLOW: u16 = 27_482;
const PORT_C: u16 = 27_484;
const PORT_CUT: u16 = 27_485;
const PORT_CUT_PROXY: u16 = 27_486;

fn endpoint(port: u16) -> String {
    format!("tcp/127.0.0.1:{port}")
}

fn remote(port: u16) -> Client {
    Client::connect_zenoh_with(
        &[endpoint(port)],
        None,
        SERVICE,
        ClientOptions {
            deadline: Duration::from_secs(5),
            ..ClientOptions::default()
        },
    )
    .expect("connect over zenoh")
}

fn thor1_round2() -> Vec<Track> {
    read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).expect("THÖR1 round 2")
}

fn thor1_map() -> String {
    format!("thor1={}", shared_data("thor1/cliffmap.csv").display())
}

fn rejection(r: Result<cliff_client::ObserveReply, Error>) -> cliff_client::Rejection {
    match r {
        Err(Error::Rejected(rej)) => rej,
        other => panic!("expected a rejection, got {other:?}"),
    }
}

/// A person of THÖR1 round 2 as a prediction request on `map`.
fn thor1_request(map: &str, tracks: &[Track]) -> Request {
    let mut r = Request::new(map, &Params::default()).unwrap();
    let t = tracks.iter().max_by_key(|t| t.rows.len()).unwrap();
    r.add_agent(
        t.rows[..3]
            .iter()
            .map(|row| Observation::position(row.t, row.position.x, row.position.y)),
    );
    r
}

#[test]
fn remote_sessions_observe_with_the_local_meaning_and_budgets() {
    let ns = Namespace::new("zsite_obs");
    let ep = endpoint(PORT_OBSERVE);
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "1000000",
            "--observe-tracks",
            "40",
            "--zenoh",
            &ep,
        ],
    );
    let tracks = thor1_round2();
    let rows: u64 = tracks.iter().map(|t| t.rows.len() as u64).sum();
    let mut a = remote(PORT_OBSERVE);
    let (accepted, duplicates, _) = observe_like_a_robot(&mut a, "thor1", &tracks, 8);
    assert_eq!(accepted, rows, "every row of the recording once");
    assert!(duplicates > 3 * rows, "{duplicates} duplicates");
    // the same session again: all duplicates, whatever ObserveRequest carries them
    let (again, _, _) = observe_like_a_robot(&mut a, "thor1", &tracks, 8);
    assert_eq!(again, 0);
    // another session's track ids are other people
    let mut b = remote(PORT_OBSERVE);
    let (other, _, _) = observe_like_a_robot(&mut b, "thor1", &tracks[..10], 4);
    assert_eq!(
        other,
        tracks[..10]
            .iter()
            .map(|t| t.rows.len() as u64)
            .sum::<u64>()
    );

    // the open-track budget holds per session: 41 fabricated tracks at once are refused
    let mut c = remote(PORT_OBSERVE);
    let mut fake = ObserveRequest::new("thor1").unwrap();
    for id in 0..41 {
        fake.add_track(id, [Observation::position(1.0, id as f64 * 0.1, 0.0)]);
    }
    let rej = rejection(c.observe(&fake));
    assert_eq!(
        (rej.status, rej.field, rej.limit),
        (Status::OverBudget, Field::Tracks, 40)
    );
    // a bad row: a status, and the session goes on
    let mut bad = ObserveRequest::new("thor1").unwrap();
    bad.add_track(
        1,
        [
            Observation::position(0.0, 1.0, 1.0),
            Observation::position(1.0, f64::NAN, 1.0),
        ],
    );
    let rej = rejection(c.observe(&bad));
    assert_eq!((rej.status, rej.row), (Status::NonFinite, Some(1)));
    let mut ok = ObserveRequest::new("thor1").unwrap();
    ok.add_track(
        1,
        (0..5).map(|i| Observation::position(i as f64, 1.0 + 0.4 * i as f64, 1.0)),
    );
    assert_eq!(c.observe(&ok).unwrap().accepted, 5);

    // an observe request sent as a plain query on the prediction key: not-allowed, and
    // a prediction on the observe key: unknown-kind
    let session =
        zenoh::open(cliff_client::zenoh::client_config(std::slice::from_ref(&ep), None).unwrap())
            .wait()
            .unwrap();
    let ask = |key: &str, h: &RequestHeader, rows: &[Observation]| -> ResponseHeader {
        let mut bytes = Vec::new();
        wire::encode_request(h, rows, &mut bytes);
        let replies = session
            .get(key)
            .payload(bytes)
            .consolidation(zenoh::query::ConsolidationMode::None)
            .timeout(Duration::from_secs(5))
            .wait()
            .unwrap();
        let reply = replies.recv().expect("one reply").into_result().unwrap();
        let mut words = Vec::new();
        wire::decode_response(&reply.payload().to_bytes(), 0, &mut words).unwrap()
    };
    let mut h = RequestHeader {
        version: PROTOCOL_VERSION,
        kind: KIND_OBSERVE,
        request_id: 77,
        ..RequestHeader::default()
    };
    h.set_map_name("thor1").unwrap();
    let rows: Vec<Observation> = (0..4)
        .map(|i| Observation {
            agent: 900,
            ..Observation::position(i as f64, 0.5 * i as f64, 2.0)
        })
        .collect();
    let r = ask(SERVICE, &h, &rows);
    assert_eq!((r.status, r.request_id), (Status::NotAllowed.code(), 77));
    let observe_key = cliff_client::map_wire::observe_key_for(SERVICE);
    let r = ask(&observe_key, &h, &rows);
    assert_eq!((r.status, r.agent), (Status::Ok.code(), 4));
    let predict = thor1_request("thor1", &tracks);
    let r = ask(&observe_key, predict.header(), predict.rows());
    assert_eq!(r.status, Status::UnknownKind.code());
    // predictions go on
    assert_eq!(a.predict(&predict).unwrap().shape().0, 1);
}

/// The learned snapshot file of `version` in `dir`.
fn snapshot(dir: &Path, version: u32) -> PathBuf {
    dir.join(format!("thor1.v{version:08}.cliff"))
}

/// Ask until `f` holds for a response's map version, at most `limit`; that version.
fn wait_version(
    client: &mut Client,
    request: &Request,
    limit: Duration,
    f: impl Fn(u32) -> bool,
) -> u32 {
    let end = Instant::now() + limit;
    loop {
        let v = client
            .predict(request)
            .expect("the robot serves")
            .map_version();
        if f(v) {
            return v;
        }
        assert!(Instant::now() < end, "version {v} after {limit:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_robot_follows_the_sites_map_and_serves_through_the_sites_absence() {
    let dir = tempfile::tempdir().unwrap();
    let (site_dir, robot_dir) = (dir.path().join("site"), dir.path().join("robot"));
    let ep = endpoint(PORT_FOLLOW);
    let map = thor1_map();
    let site_args = [
        "--map",
        &map,
        "--learn",
        "thor1",
        "--learn-dir",
        site_dir.to_str().unwrap(),
        "--learn-every-s",
        "0.5",
        "--snapshot-every-s",
        "0.2",
        "--observe-rate",
        "1000000",
        "--zenoh",
        &ep,
    ];
    let follow = format!("thor1={ep}");
    let robot_args = [
        "--map",
        &map,
        "--follow",
        &follow,
        "--follow-dir",
        robot_dir.to_str().unwrap(),
        "--follow-every-ms",
        "100",
    ];
    let site_ns = Namespace::new("zsite_site");
    let robot_ns = Namespace::new("zsite_robot");
    let mut site = Daemon::start_tagged(&site_ns, &site_args, "site");
    let robot = Daemon::start_tagged(&robot_ns, &robot_args, "robot");
    assert!(
        robot.ready_line.contains("thor1 (") && robot.ready_line.contains("following, version"),
        "{}",
        robot.ready_line
    );
    let tracks = thor1_round2();
    let request = thor1_request("thor1", &tracks);
    let mut local = robot_ns.connect(WaitMode::Hybrid);

    // a teacher sends the recording to the site; the robot serves the site's version
    let mut teacher = remote(PORT_FOLLOW);
    let (accepted, _, _) = observe_like_a_robot(&mut teacher, "thor1", &tracks, 8);
    assert!(accepted > 0);
    let mut site_client = remote(PORT_FOLLOW);
    let site_version = wait_version(&mut site_client, &request, Duration::from_secs(20), |v| {
        v > 0
    });
    let robot_version = wait_version(&mut local, &request, Duration::from_secs(10), |v| {
        v >= site_version
    });
    // the same map, byte for byte: the robot's snapshot of that version is the site's
    let end = Instant::now() + Duration::from_secs(10);
    while !(snapshot(&site_dir, robot_version).exists()
        && snapshot(&robot_dir, robot_version).exists())
    {
        assert!(Instant::now() < end, "snapshots of version {robot_version}");
        std::thread::sleep(Duration::from_millis(50));
    }
    let site_bytes = std::fs::read(snapshot(&site_dir, robot_version)).unwrap();
    assert_eq!(
        std::fs::read(snapshot(&robot_dir, robot_version)).unwrap(),
        site_bytes
    );
    // and the same predictions, pinned to that version on both
    let pinned = |c: &mut Client| {
        let mut r = request.clone();
        r.set_map(&format!("thor1@{robot_version}")).unwrap();
        let p = c.predict(&r).unwrap();
        (p.map_version(), bits(p.positions(), p.lens()))
    };
    let here = pinned(&mut local);
    assert_eq!(here.0, robot_version);
    assert_eq!(here, pinned(&mut site_client));

    // the site dies: every request of the robot is still served, with that version
    site.signal(SIGKILL);
    site.wait_exit(Duration::from_secs(5)).expect("site killed");
    let last = wait_version(&mut local, &request, Duration::from_secs(5), |_| true);
    let end = Instant::now() + Duration::from_secs(2);
    let mut served = 0;
    while Instant::now() < end {
        let p = local
            .predict(&request)
            .expect("served while the site is away");
        assert_eq!(p.map_version(), last);
        served += 1;
    }
    assert!(served > 10);
    // a robot restarted while the site is away serves its snapshot
    drop(local);
    drop(robot);
    let robot = Daemon::start_tagged(&robot_ns, &robot_args, "robot2");
    assert!(
        robot
            .ready_line
            .contains(&format!("following, version {last}")),
        "{}",
        robot.ready_line
    );
    let mut local = robot_ns.connect(WaitMode::Hybrid);
    assert_eq!(local.predict(&request).unwrap().map_version(), last);

    // the site comes back (from its own snapshot), learns more, and the robot follows
    let _site = Daemon::start_tagged(&site_ns, &site_args, "site2");
    let mut teacher = remote(PORT_FOLLOW);
    let (accepted, _, _) = observe_like_a_robot(&mut teacher, "thor1", &tracks[..20], 8);
    assert!(accepted > 0);
    let mut site_client = remote(PORT_FOLLOW);
    let newer = wait_version(&mut site_client, &request, Duration::from_secs(20), |v| {
        v > last
    });
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let p = local
            .predict(&request)
            .expect("the robot serves throughout");
        if p.map_version() >= newer {
            break;
        }
        assert!(
            Instant::now() < end,
            "the robot did not catch up with {newer}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn the_c_abi_observes_over_zenoh_once_per_row() {
    use cliff_client::ffi::*;
    use std::ffi::{CStr, CString};
    let ns = Namespace::new("zsite_c");
    let ep = endpoint(PORT_C);
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "1000000",
            "--zenoh",
            &ep,
        ],
    );
    let (endpoint, service) = (CString::new(ep).unwrap(), CString::new(SERVICE).unwrap());
    let map = CString::new("thor1").unwrap();
    let mut client = std::ptr::null_mut();
    // SAFETY: valid strings and out pointer; no configuration file
    assert_eq!(
        unsafe {
            cliff_client_connect_zenoh(
                endpoint.as_ptr(),
                service.as_ptr(),
                std::ptr::null(),
                &mut client,
            )
        },
        CLIFF_OK
    );
    let tracks = thor1_round2();
    let mut total = 0;
    for (id, track) in tracks.iter().take(10).enumerate() {
        let t: Vec<f64> = track.rows.iter().map(|r| r.t).collect();
        let x: Vec<f64> = track.rows.iter().map(|r| r.position.x).collect();
        let y: Vec<f64> = track.rows.iter().map(|r| r.position.y).collect();
        let n = t.len().min(1024);
        for round in 0..2 {
            let mut out = CliffObserved::default();
            // SAFETY: n doubles each; speed and heading NULL; a valid client
            let code = unsafe {
                cliff_observe(
                    client,
                    map.as_ptr(),
                    id as u32,
                    n,
                    t.as_ptr(),
                    x.as_ptr(),
                    y.as_ptr(),
                    std::ptr::null(),
                    std::ptr::null(),
                    0,
                    &mut out,
                )
            };
            assert_eq!(code, CLIFF_OK);
            // the second time every row is a duplicate
            let want = if round == 0 {
                (n as u32, 0)
            } else {
                (0, n as u32)
            };
            assert_eq!((out.accepted, out.duplicates), want);
        }
        total += n;
    }
    assert!(total > 100);
    // SAFETY: a static string
    let name = unsafe { CStr::from_ptr(cliff_status_name(Status::NotAllowed.code())) };
    assert_eq!(name.to_str().unwrap(), "not-allowed");
    // SAFETY: the client made above, freed once
    unsafe { cliff_client_free(client) };
}

#[test]
fn requests_whose_link_drops_are_sent_again_and_counted_once() {
    let ns = Namespace::new("zsite_cut");
    let _daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &thor1_map(),
            "--learn",
            "thor1",
            "--observe-rate",
            "1000000",
            "--zenoh",
            &endpoint(PORT_CUT),
        ],
    );
    let proxy = common::proxy::Proxy::start(PORT_CUT_PROXY, PORT_CUT);
    let mut robot = remote(PORT_CUT_PROXY);
    let tracks = thor1_round2();
    let predict = thor1_request("thor1", &tracks);
    robot.predict(&predict).expect("before any cut");

    // the link is cut every few milliseconds while the robot predicts and observes
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cutter = {
        let stop = std::sync::Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut cuts = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(15));
                cuts += proxy.cut();
            }
            (cuts, proxy.connections())
        })
    };
    let started = Instant::now();
    let mut predicted = 0;
    while started.elapsed() < Duration::from_secs(2) {
        let p = robot.predict(&predict).expect("answered despite the cuts");
        assert_eq!(p.shape().0, 1);
        predicted += 1;
    }
    let rows: u64 = tracks.iter().map(|t| t.rows.len() as u64).sum();
    let (accepted, _, _) = observe_like_a_robot(&mut robot, "thor1", &tracks, 8);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let (cuts, connections) = cutter.join().unwrap();
    eprintln!("{predicted} predictions; {cuts} cuts, {connections} connections");
    assert!(cuts >= 20, "only {cuts} cuts");
    assert!(
        connections >= 20,
        "the session came back {connections} times"
    );
    // every row once, although some requests were sent twice
    assert_eq!(accepted, rows);
}
