//! The README's LAN set-up, run on loopback: cliffd with the configuration of
//! docs/zenoh/cliffd-lan.json5 (mutual TLS over zenoh's QUIC link, an access-control
//! list by certificate common name) and robots with docs/zenoh/robot.json5.
//! Certificates are made with `openssl` for the test.
#![cfg(feature = "zenoh")]

mod common;

use std::time::Duration;

use cliff::map::CliffMap;
use cliff::predict::Method;
use cliff::predict::Params;
use cliff::tracks::{Format, read_tracks};
use cliff_client::{Client, ClientOptions, Error, Observation, ObserveRequest, Request, Status};
use common::tls::{certificates, docs_config as docs_config_for};
use common::*;

const PORT_TLS: u16 = 27_471;
const PORT_SITE: u16 = 27_472;

/// A file of docs/zenoh/ for this test's service ([`docs_config_for`]).
fn docs_config(file: &str, dir: &std::path::Path, cert_as: &str) -> std::path::PathBuf {
    docs_config_for(file, dir, cert_as, SERVICE)
}

#[test]
fn the_readme_lan_setup_serves_listed_robots_and_nobody_else() {
    let ns = Namespace::new("ztls");
    let dir = std::env::temp_dir().join(format!("cliff-zenoh-tls-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    certificates(&dir, &["robot-1", "intruder"]);
    let daemon_cfg = docs_config("cliffd-lan.json5", &dir, "cliffd");
    let ep = format!("quic/127.0.0.1:{PORT_TLS}");
    let cfg = daemon_cfg.to_str().unwrap();
    let _daemon = Daemon::start(&ns, &["--zenoh", &ep, "--zenoh-config", cfg]);

    let options = ClientOptions {
        deadline: Duration::from_secs(5),
        ..ClientOptions::default()
    };
    let map = CliffMap::demo();
    let req = demo_request(11, 3, 20, Method::Cliff);
    let want = local_bits(&map, &req).1;

    // robot-1 is on the list
    let robot = docs_config("robot.json5", &dir, "robot-1");
    let mut c = Client::connect_zenoh_with(
        std::slice::from_ref(&ep),
        Some(&robot),
        SERVICE,
        options.clone(),
    )
    .expect("robot-1 connects over mutual TLS");
    let p = c.predict(&req).expect("robot-1 is served");
    assert_eq!(bits(p.positions(), p.lens()), want);

    // a certificate from the same CA but not on the list: connected, never answered
    let intruder = docs_config("robot.json5", &dir, "intruder");
    let mut c = Client::connect_zenoh_with(
        std::slice::from_ref(&ep),
        Some(&intruder),
        SERVICE,
        options.clone(),
    )
    .expect("the intruder's TLS handshake succeeds");
    let e = c.predict(&req).unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");

    // no client certificate, or plain TCP: no session at all
    let e = Client::connect_zenoh_with(std::slice::from_ref(&ep), None, SERVICE, options.clone())
        .unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    let e = Client::connect_zenoh(&format!("tcp/127.0.0.1:{PORT_TLS}"), SERVICE).unwrap_err();
    assert!(matches!(e, Error::NoDaemon { .. }), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn observations_over_zenoh_come_only_from_sessions_allowed_to_teach() {
    let ns = Namespace::new("zsite_acl");
    let dir = std::env::temp_dir().join(format!("cliff-zenoh-site-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    certificates(&dir, &["robot-1", "robot-2"]);
    let daemon_cfg = docs_config("cliffd-site.json5", &dir, "cliffd");
    let ep = format!("quic/127.0.0.1:{PORT_SITE}");
    let map = format!("thor1={}", shared_data("thor1/cliffmap.csv").display());
    let daemon = Daemon::start(
        &ns,
        &[
            "--map",
            &map,
            "--learn",
            "thor1",
            "--learn-every-s",
            "0.3",
            "--observe-rate",
            "1000000",
            "--zenoh",
            &ep,
            "--zenoh-config",
            daemon_cfg.to_str().unwrap(),
        ],
    );
    let connect = |cn: &str| {
        let cfg = docs_config("robot.json5", &dir, cn);
        Client::connect_zenoh_with(
            std::slice::from_ref(&ep),
            Some(&cfg),
            SERVICE,
            ClientOptions {
                deadline: Duration::from_secs(5),
                ..ClientOptions::default()
            },
        )
        .expect("a robot of the site connects over mutual TLS")
    };
    let tracks = read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
    let person = tracks.iter().max_by_key(|t| t.rows.len()).unwrap();
    let mut predict = Request::new("thor1", &Params::default()).unwrap();
    predict.add_agent(
        person.rows[..3]
            .iter()
            .map(|r| Observation::position(r.t, r.position.x, r.position.y)),
    );

    // robot-2 may predict but not teach: every observation is refused with a status
    let mut robot2 = connect("robot-2");
    assert_eq!(robot2.predict(&predict).unwrap().map_version(), 0);
    let mut refused = 0;
    for chunk in tracks.chunks(8) {
        let mut o = ObserveRequest::new("thor1").unwrap();
        for (id, t) in chunk.iter().enumerate() {
            o.add_track_rows(id as u32, &t.rows[..t.rows.len().min(100)]);
            o.end_track();
        }
        match robot2.observe(&o) {
            Err(Error::Rejected(r)) if r.status == Status::NotAllowed => refused += 1,
            other => panic!("robot-2's observations: {other:?}"),
        }
    }
    assert_eq!(refused, tracks.chunks(8).count());
    // several learning periods later its rows have taught nothing
    std::thread::sleep(Duration::from_millis(1500));
    assert_eq!(robot2.predict(&predict).unwrap().map_version(), 0);
    assert!(
        !daemon.log_text().contains("learned a new version"),
        "{}",
        daemon.log_text()
    );

    // robot-1 is a teacher: the same people teach the map, and robot-2 is told the
    // version learned
    let mut robot1 = connect("robot-1");
    let rows: u64 = tracks.iter().map(|t| t.rows.len() as u64).sum();
    let (accepted, _, _) = observe_like_a_robot(&mut robot1, "thor1", &tracks, 8);
    assert_eq!(accepted, rows);
    assert!(first_learned_version(&mut robot2, &predict, Duration::from_secs(20)) > 0);
    let _ = std::fs::remove_dir_all(&dir);
}
