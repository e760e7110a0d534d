//! cliffd's life: killed and restarted under traffic, clean shutdown on signals, map
//! reloads that keep the old map when the new one fails, started from a configuration
//! file, with a motion model file.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cliff::map::{CliffMap, write_csv};
use cliff::motion::{MotionFit, MotionModel, fit_motion_model};
use cliff::predict::{Method, Params};
use cliff::tracks::{Format, read_tracks};
use cliff_client::{Client, ClientOptions, Error, Observation, Request, Status, WaitMode};
use common::*;

#[derive(Debug)]
struct Call {
    at: Instant,
    took: Duration,
    result: Result<(), Error>,
}

#[test]
fn daemon_killed_and_restarted_clients_fail_within_deadline_then_recover() {
    let ns = Namespace::new("restart");
    let mut daemon = Daemon::start_tagged(&ns, &[], "daemon1");
    let deadline = Duration::from_millis(500);
    let stop = Arc::new(AtomicBool::new(false));
    let threads: Vec<_> = [WaitMode::Spin, WaitMode::Hybrid, WaitMode::Block]
        .into_iter()
        .enumerate()
        .map(|(t, wait)| {
            let (stop, prefix) = (stop.clone(), ns.prefix.clone());
            std::thread::spawn(move || {
                let options = ClientOptions {
                    wait,
                    deadline,
                    prefix: Some(prefix),
                    ..ClientOptions::default()
                };
                let mut client = Client::connect_with(SERVICE, options).expect("connect");
                let map = CliffMap::demo();
                let mut calls = Vec::new();
                let mut i = 0u64;
                while !stop.load(Ordering::Relaxed) && calls.len() < 100_000 {
                    let req = demo_request(i * 3 + t as u64, 1, 10, Method::Cliff);
                    let want = local_bits(&map, &req).1;
                    let at = Instant::now();
                    let result = client.predict(&req).map(|p| {
                        assert_eq!(bits(p.positions(), p.lens()), want, "wrong numbers");
                    });
                    let failed = result.is_err();
                    calls.push(Call {
                        at,
                        took: at.elapsed(),
                        result,
                    });
                    if failed {
                        std::thread::sleep(Duration::from_millis(5));
                    }
                    i += 1;
                }
                calls
            })
        })
        .collect();

    std::thread::sleep(Duration::from_millis(400));
    let killed_at = Instant::now();
    daemon.signal(SIGKILL);
    daemon.wait_exit(Duration::from_secs(5)).expect("killed");
    std::thread::sleep(Duration::from_millis(1200));
    let restarted_at = Instant::now();
    let _daemon2 = Daemon::start_tagged(&ns, &[], "daemon2");
    let ready_at = Instant::now();
    std::thread::sleep(Duration::from_millis(1500));
    stop.store(true, Ordering::Relaxed);

    for (t, th) in threads.into_iter().enumerate() {
        let calls = th.join().expect("client thread");
        let slack = Duration::from_millis(300);
        for c in &calls {
            assert!(
                c.took <= deadline + slack,
                "thread {t}: a call took {:?}",
                c.took
            );
            if let Err(e) = &c.result {
                assert!(
                    matches!(
                        e,
                        Error::NoDaemon { .. } | Error::DaemonGone { .. } | Error::Deadline { .. }
                    ),
                    "thread {t}: unexpected error {e}"
                );
                assert!(
                    c.at + c.took >= killed_at,
                    "thread {t}: failure before the kill: {e}"
                );
            }
        }
        let before = calls.iter().filter(|c| c.at + c.took < killed_at).count();
        assert!(before > 0, "thread {t}: no call before the kill");
        assert!(
            calls
                .iter()
                .any(|c| c.result.is_err() && c.at < restarted_at),
            "thread {t}: no call noticed the dead daemon"
        );
        let recovered = calls
            .iter()
            .find(|c| c.at >= restarted_at && c.result.is_ok())
            .unwrap_or_else(|| panic!("thread {t}: never recovered after the restart"));
        assert!(
            recovered.at < ready_at + Duration::from_secs(1),
            "thread {t}: recovered only {:?} after the restart",
            recovered.at - ready_at
        );
        // once recovered, every later call succeeds
        let after: Vec<_> = calls.iter().filter(|c| c.at > recovered.at).collect();
        assert!(!after.is_empty());
        assert!(
            after.iter().all(|c| c.result.is_ok()),
            "thread {t}: failures after recovery"
        );
    }
}

#[test]
fn connecting_without_a_daemon_says_so() {
    let ns = Namespace::new("nodaemon");
    match Client::connect_with(SERVICE, ns.options(WaitMode::Spin)) {
        Err(Error::NoDaemon { service }) => assert_eq!(service, SERVICE),
        other => panic!("{other:?}"),
    }
    // a daemon that stopped cleanly while a client stays connected: NoDaemon per call
    let mut daemon = Daemon::start(&ns, &[]);
    let mut client = ns.connect(WaitMode::Hybrid);
    let req = demo_request(1, 1, 5, Method::Cvm);
    client.predict(&req).expect("served");
    daemon.signal(SIGTERM);
    assert!(
        daemon
            .wait_exit(Duration::from_secs(5))
            .expect("exits")
            .success()
    );
    let t = Instant::now();
    match client.predict(&req) {
        Err(Error::NoDaemon { .. }) | Err(Error::DaemonGone { .. }) => {}
        other => panic!("{other:?}"),
    }
    assert!(t.elapsed() < Duration::from_secs(2));
}

#[test]
fn sigint_and_sigterm_shut_down_cleanly() {
    for sig in [SIGINT, SIGTERM] {
        let ns = Namespace::new("sig");
        let mut daemon = Daemon::start(&ns, &[]);
        let mut client = ns.connect(WaitMode::Spin);
        client
            .predict(&demo_request(0, 1, 5, Method::Cliff))
            .expect("served");
        drop(client);
        daemon.signal(sig);
        let status = daemon
            .wait_exit(Duration::from_secs(5))
            .expect("exits within 5 s");
        assert!(status.success(), "signal {sig}: {status:?}");
        assert!(
            daemon.log_text().contains("shutting down"),
            "{}",
            daemon.log_text()
        );
        // the service is gone with it: a new daemon starts on the same name at once
        let d2 = Daemon::start(&ns, &[]);
        drop(d2);
    }
}

#[test]
fn sigterm_stops_the_daemon_under_continuous_load() {
    let ns = Namespace::new("busy");
    let mut daemon = Daemon::start(&ns, &["--workers", "2"]);
    let stop = Arc::new(AtomicBool::new(false));
    let load: Vec<_> = (0..2)
        .map(|t| {
            let (stop, prefix) = (stop.clone(), ns.prefix.clone());
            std::thread::spawn(move || {
                let options = ClientOptions {
                    wait: WaitMode::Spin,
                    deadline: Duration::from_secs(1),
                    prefix: Some(prefix),
                    ..ClientOptions::default()
                };
                let mut c = Client::connect_with(SERVICE, options).expect("connect");
                let req = demo_request(t, 1, 2, Method::Cvm);
                let mut ok = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    if c.predict(&req).is_ok() {
                        ok += 1;
                    } else {
                        std::thread::sleep(Duration::from_millis(1));
                    }
                }
                ok
            })
        })
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    daemon.signal(SIGTERM);
    let status = daemon.wait_exit(Duration::from_secs(5));
    stop.store(true, Ordering::Relaxed);
    let served: u64 = load.into_iter().map(|t| t.join().unwrap()).sum();
    assert!(served > 0);
    assert!(status.expect("exits within 5 s under load").success());
}

#[test]
fn a_second_daemon_on_the_same_service_refuses_to_start() {
    let ns = Namespace::new("twice");
    let _daemon = Daemon::start(&ns, &[]);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cliffd"))
        .args(["--service", SERVICE, "--prefix", &ns.prefix])
        .output()
        .expect("run cliffd");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("already serves"), "{err}");
}

fn walkers_on(map: &CliffMap, seed: u64) -> Request {
    walkers(map, seed, 4, 10)
}

/// `agents` people walking along x at locations of `map` (served as `hall`), k samples.
fn walkers(map: &CliffMap, seed: u64, agents: usize, k: usize) -> Request {
    let mut r = Request::new(
        "hall",
        &Params {
            k,
            seed,
            ..Params::default()
        },
    )
    .unwrap();
    for l in map.locations().iter().step_by(37).take(agents) {
        let (x, y) = (l.position.x, l.position.y);
        r.add_agent(
            (0..4).map(|j| Observation::position(j as f64 * 0.4, x - 0.4 * (3 - j) as f64, y)),
        );
    }
    r
}

#[test]
fn reload_replaces_maps_and_keeps_the_old_one_when_the_new_one_fails() {
    let ns = Namespace::new("reload");
    let dir = std::env::temp_dir().join(format!("{}maps", ns.prefix));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("hall.csv");
    // start with the real THÖR1 map
    std::fs::copy(shared_data("thor1/cliffmap.csv"), &file).expect("copy the THÖR1 map");
    let thor = CliffMap::load(&file).unwrap();
    let arg = format!("hall={}", file.display());
    let daemon = Daemon::start(&ns, &["--map", &arg]);
    assert!(daemon.ready_line.contains("hall"), "{}", daemon.ready_line);
    let mut client = ns.connect(WaitMode::Hybrid);
    let req = walkers_on(&thor, 3);
    let on_thor = local_bits(&thor, &req);
    let got = |c: &mut Client| {
        let p = c.predict(&req).expect("served");
        (p.shape(), bits(p.positions(), p.lens()))
    };
    assert_eq!(got(&mut client), on_thor);

    // a new valid map: SIGHUP swaps it in
    write_csv(&CliffMap::demo(), &file).unwrap();
    let demo = CliffMap::load(&file).unwrap();
    let on_demo = local_bits(&demo, &req);
    assert_ne!(on_demo, on_thor);
    daemon.signal(SIGHUP);
    let end = Instant::now() + Duration::from_secs(10);
    while got(&mut client) != on_demo {
        assert!(Instant::now() < end, "SIGHUP did not reload the map");
        std::thread::sleep(Duration::from_millis(20));
    }

    // a broken file: the reload request reports it, the old map stays
    std::fs::write(&file, "1.0,2.0,not-a-number\n").unwrap();
    match client.reload_maps(Duration::from_secs(10)) {
        Err(Error::Rejected(r)) => assert_eq!(r.status, Status::ReloadFailed),
        other => panic!("{other:?}"),
    }
    assert_eq!(got(&mut client), on_demo);
    daemon.signal(SIGHUP);
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(got(&mut client), on_demo);
    assert!(
        daemon.log_text().contains("keeping the old map"),
        "{}",
        daemon.log_text()
    );

    // and a good file again through the control request
    std::fs::copy(shared_data("thor1/cliffmap.csv"), &file).unwrap();
    client.reload_maps(Duration::from_secs(10)).expect("reload");
    assert_eq!(got(&mut client), on_thor);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_configuration_file_gives_maps_and_options_and_the_command_line_overrides_it() {
    let ns = Namespace::new("config");
    let dir = tempfile::tempdir().unwrap();
    let thor_file = shared_data("thor1/cliffmap.csv");
    let conf = dir.path().join("cliffd.conf");
    std::fs::write(
        &conf,
        format!(
            "# maps and limits, as in /etc/cliff/cliffd.conf\n\
             map = hall={}\n\n  max-k = 12\nmax-agents = 8\n",
            thor_file.display()
        ),
    )
    .unwrap();
    let conf_arg = conf.display().to_string();
    let daemon = Daemon::start(&ns, &["--config", &conf_arg, "--max-agents", "3"]);
    // the file's map replaces the built-in demo
    assert!(
        daemon.ready_line.contains("serving hall (") && !daemon.ready_line.contains("demo"),
        "{}",
        daemon.ready_line
    );
    let thor = CliffMap::load(&thor_file).unwrap();
    let mut client = ns.connect(WaitMode::Hybrid);
    let rejected = |c: &mut Client, r: &Request| match c.predict(r) {
        Err(Error::Rejected(rej)) => (rej.status, rej.limit),
        Err(e) => panic!("{e}"),
        Ok(p) => panic!("served {:?}", p.shape()),
    };
    // 4 people: over the command line's --max-agents 3, which overrides the file's 8
    assert_eq!(
        rejected(&mut client, &walkers(&thor, 5, 4, 10)),
        (Status::BadAgents, 3)
    );
    // k 13: over the file's max-k 12 (the default is 50)
    assert_eq!(
        rejected(&mut client, &walkers(&thor, 5, 3, 13)),
        (Status::BadK, 12)
    );
    // 3 people with k 12 are served from the file's map, as in-process
    let req = walkers(&thor, 5, 3, 12);
    let p = client.predict(&req).expect("served");
    assert_eq!(
        (p.shape(), bits(p.positions(), p.lens())),
        local_bits(&thor, &req)
    );
    assert!(
        daemon.log_text().contains("options read from"),
        "{}",
        daemon.log_text()
    );
}

#[test]
fn a_bad_configuration_file_stops_cliffd_naming_the_file_and_the_line() {
    let ns = Namespace::new("badconfig");
    let dir = tempfile::tempdir().unwrap();
    let conf = dir.path().join("cliffd.conf");
    let start = |conf: &std::path::Path| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_cliffd"))
            .args(["--service", SERVICE, "--prefix", &ns.prefix, "--config"])
            .arg(conf)
            .output()
            .expect("run cliffd");
        assert!(!out.status.success(), "cliffd started");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let path = conf.display();
    std::fs::write(&conf, "workers = 1\n# misspelt\nwrokers = 2\n").unwrap();
    let err = start(&conf);
    assert!(
        err.contains(&format!("{path} line 3: cliffd has no option --wrokers")),
        "{err}"
    );
    std::fs::write(&conf, "max-agents =\n").unwrap();
    let err = start(&conf);
    assert!(
        err.contains(&format!("{path}: line 1: `max-agents =` has no value")),
        "{err}"
    );
    // a value clap refuses is reported by clap, naming the option
    std::fs::write(&conf, "max-agents = many\n").unwrap();
    let err = start(&conf);
    assert!(
        err.contains("--max-agents") && err.contains("many"),
        "{err}"
    );
    let missing = dir.path().join("missing.conf");
    let err = start(&missing);
    assert!(
        err.contains(&format!("--config {}: No such file", missing.display())),
        "{err}"
    );
}

/// A motion model fitted on THÖR1's round 2 (unlike the built-in one, fitted on ATC),
/// written to `dir`.
fn thor_motion_model(dir: &std::path::Path) -> (std::path::PathBuf, Arc<MotionModel>) {
    let tracks = read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
    let model = fit_motion_model(&tracks, &MotionFit::default()).expect("fit");
    let file = dir.join("thor1.motion");
    model.save(&file).unwrap();
    (file, Arc::new(model))
}

#[test]
fn a_motion_model_file_is_what_motion_and_improved_start_from() {
    let ns = Namespace::new("motionmodel");
    let dir = tempfile::tempdir().unwrap();
    let (file, model) = thor_motion_model(dir.path());
    let thor_file = shared_data("thor1/cliffmap.csv");
    let thor = CliffMap::load(&thor_file).unwrap();
    let map_arg = format!("hall={}", thor_file.display());
    let model_arg = file.display().to_string();
    let _daemon = Daemon::start(&ns, &["--map", &map_arg, "--motion-model", &model_arg]);
    let mut client = ns.connect(WaitMode::Hybrid);
    for method in [Method::Motion, Method::Improved] {
        let mut req = Request::new(
            "hall",
            &Params {
                method,
                k: 8,
                seed: 3,
                ..Params::default()
            },
        )
        .unwrap();
        for l in thor.locations().iter().step_by(37).take(3) {
            let (x, y) = (l.position.x, l.position.y);
            req.add_agent((0..6).map(|j| {
                // a walker turning a little: the models' forecasts differ
                let t = j as f64 * 0.4;
                Observation::position(t, x + 0.5 * t, y + 0.05 * t * t)
            }));
        }
        let p = client.predict(&req).expect("served");
        let served = (p.shape(), bits(p.positions(), p.lens()));
        let with_file = {
            let mut lp = cliff_client::LocalPredictor::default().with_motion_model(model.clone());
            let b = lp.predict(&thor, req.header(), req.rows()).unwrap();
            (b.shape(), bits(b.positions(), b.lens()))
        };
        assert_eq!(
            served, with_file,
            "{method:?}: the daemon = in-process with the file's model"
        );
        assert_ne!(
            served,
            local_bits(&thor, &req),
            "{method:?}: the file's model is not the built-in one"
        );
    }
}

#[test]
fn a_bad_motion_model_file_stops_cliffd_naming_it() {
    let ns = Namespace::new("badmotion");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("broken.motion");
    std::fs::write(&file, b"CLIFFMOT but not a model").unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_cliffd"))
        .args([
            "--service",
            SERVICE,
            "--prefix",
            &ns.prefix,
            "--motion-model",
        ])
        .arg(&file)
        .output()
        .expect("run cliffd");
    assert!(!out.status.success(), "cliffd started");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("motion model") && err.contains(&file.display().to_string()),
        "{err}"
    );
}
