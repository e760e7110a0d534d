//! The node reaching a cliffd on another host over zenoh (cargo feature `zenoh`): the
//! engine a node builds from its parameters (`daemon_zenoh`, `daemon_zenoh_config`,
//! `observe`) against a cliffd process listening on loopback, fed THÖR1 round 2 as a
//! tracker publishes it. Predictions are the in-process ones; the rows the node observes
//! reach the remote map (the daemon's own count, and the version it learns); a node over
//! its observe budget sends smaller requests and keeps predicting; a node that access
//! control keeps from teaching (docs/zenoh/cliffd-site.json5) gets `not-allowed` and
//! keeps predicting.
//!
//! The cliffd run is `target/release/cliffd` built with its feature `zenoh` (as
//! `cargo test -p cliff-service -p cliff-ros2 --features cliff-service/zenoh,cliff-ros2/zenoh`
//! builds it), or the one `CLIFF_ZENOH_CLIFFD` names.
#![cfg(feature = "zenoh")]

#[path = "../../service/tests/common/tls.rs"]
mod tls;

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff::tracks::{Format, read_tracks};
use cliff_client::{Client, ClientOptions, Observation, Request, Status};
use cliff_ros2::engine::Engine;
use cliff_ros2::msg::{Header, People, Person, Point, Predictions, Time};
use cliff_ros2::node;
use cliff_ros2::settings::Parameters;

const SERVICE: &str = "cliff/ros2-test";
const PORT_OBSERVE: u16 = 27_491;
const PORT_NOT_ALLOWED: u16 = 27_492;
const PORT_OVER_BUDGET: u16 = 27_493;

fn shared_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

/// The cliffd to run: `CLIFF_ZENOH_CLIFFD`, else the one beside this test's directory
/// (`target/release/cliffd`); it must have zenoh.
fn cliffd() -> PathBuf {
    let path = match std::env::var_os("CLIFF_ZENOH_CLIFFD") {
        Some(p) => PathBuf::from(p),
        None => {
            let exe = std::env::current_exe().expect("test exe");
            // target/release/deps/remote_daemon-HASH -> target/release/cliffd
            exe.parent()
                .and_then(Path::parent)
                .expect("target dir")
                .join("cliffd")
        }
    };
    let help = Command::new(&path)
        .arg("--help")
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (build it: cargo build --release -p cliff-service --features zenoh)",
                path.display()
            )
        });
    assert!(
        String::from_utf8_lossy(&help.stdout).contains("--zenoh"),
        "{} has no zenoh: build it with cargo build --release -p cliff-service --features zenoh, or set CLIFF_ZENOH_CLIFFD",
        path.display()
    );
    path
}

/// A cliffd process, stopped (SIGTERM, then SIGKILL) when dropped.
struct Daemon {
    child: Child,
    lines: mpsc::Receiver<String>,
    log: PathBuf,
}

impl Daemon {
    fn start(tag: &str, args: &[&str]) -> Daemon {
        let log = std::env::temp_dir().join(format!("cliff-ros2-{tag}-{}.log", std::process::id()));
        let prefix = format!("clr2_{tag}_{}_", std::process::id());
        let mut child = Command::new(cliffd())
            .args(["--service", SERVICE, "--prefix", &prefix])
            .args(args)
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&log).expect("log file"))
            .spawn()
            .expect("spawn cliffd");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let d = Daemon { child, lines, log };
        let end = Instant::now() + Duration::from_secs(30);
        loop {
            match d
                .lines
                .recv_timeout(end.saturating_duration_since(Instant::now()))
            {
                Ok(line) if line.contains("ready") => return d,
                Ok(_) => {}
                Err(_) => panic!("cliffd did not become ready; its log:\n{}", d.log_text()),
            }
        }
    }

    fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Stop it with SIGTERM and return its closing line on learning
    /// (`cliffd learned: N rows taken, N duplicates, ...`) as its numbers.
    fn stop(mut self) -> Vec<u64> {
        // SAFETY: kill(2) on our own child's pid
        unsafe { kill(self.child.id() as i32, 15) };
        let status = self.child.wait().expect("cliffd exits");
        assert!(
            status.success(),
            "cliffd: {status}; log:\n{}",
            self.log_text()
        );
        let closing = self
            .lines
            .try_iter()
            .find(|l| l.starts_with("cliffd learned:"))
            .unwrap_or_else(|| panic!("no closing line on learning; log:\n{}", self.log_text()));
        closing
            .split(|c: char| !c.is_ascii_digit())
            .filter(|w| !w.is_empty())
            .map(|w| w.parse().unwrap())
            .collect()
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            // SAFETY: kill(2) on our own child's pid
            unsafe { kill(self.child.id() as i32, 15) };
            let end = Instant::now() + Duration::from_secs(2);
            while Instant::now() < end && matches!(self.child.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(10));
            }
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

unsafe extern "C" {
    fn kill(pid: i32, sig: i32) -> i32;
}

/// THÖR1 round 2 as a tracker publishes it: one People message per time stamp.
fn frames() -> Vec<People> {
    let tracks = read_tracks(&shared_data("thor1/exp-1-run-2.csv"), Format::Thor).unwrap();
    let mut by_t: BTreeMap<u64, Vec<Person>> = BTreeMap::new();
    for t in &tracks {
        for r in &t.rows {
            by_t.entry(r.t.to_bits()).or_default().push(Person {
                name: t.id.to_string(),
                position: Point {
                    x: r.position.x,
                    y: r.position.y,
                    z: 0.0,
                },
                ..Person::default()
            });
        }
    }
    by_t.into_iter()
        .map(|(t, people)| People {
            header: Header {
                stamp: Time::from_secs_f64(f64::from_bits(t)),
                frame_id: "map".into(),
            },
            people,
        })
        .collect()
}

/// The parameters of a node predicting THÖR1 with few samples: in-process from the map
/// file when `zenoh` is None, else through the cliffd at that endpoint.
fn parameters(zenoh: Option<(&str, Option<&Path>)>, observe: bool) -> Parameters {
    let map = shared_data("thor1/cliffmap.csv").display().to_string();
    let mut p = Parameters {
        daemon_map: "thor1".into(),
        daemon_service: SERVICE.into(),
        daemon_deadline: 5.0,
        observe,
        k: 4,
        horizon: 4.8,
        grid: false,
        ..Parameters::default()
    };
    match zenoh {
        None => p.map_file = map,
        Some((endpoint, config)) => {
            p.daemon_zenoh = endpoint.into();
            if let Some(c) = config {
                p.daemon_zenoh_config = c.display().to_string();
            }
        }
    }
    p.check().expect("the test's parameters check");
    p
}

/// The people of a predictions message (the map's label differs between a daemon and
/// a file), with their sample points as bits.
fn people_bits(p: &Predictions) -> Vec<(String, Vec<u32>, Vec<[u32; 2]>)> {
    p.people
        .iter()
        .map(|q| {
            (
                q.track_id.clone(),
                q.lengths.clone(),
                q.points
                    .iter()
                    .map(|x| [x.x.to_bits(), x.y.to_bits()])
                    .collect(),
            )
        })
        .collect()
}

/// Feed `frames` to `remote` and to the in-process `local` one cycle per message, and
/// check that every cycle of `remote` predicts the same people and points as `local`.
/// Returns the cycles run.
fn run_beside(remote: &mut Engine, local: &mut Engine, frames: &[People]) -> u64 {
    let mut cycles = 0;
    for m in frames {
        let now = Instant::now();
        remote.on_people(m, now);
        local.on_people(m, now);
        let want = people_bits(local.cycle(now).predictions().expect("in-process predicts"));
        let got = remote.cycle(now).predictions().map(people_bits);
        assert_eq!(
            got.as_ref(),
            Some(&want),
            "cycle {cycles}: the remote cliffd's predictions are the in-process ones"
        );
        cycles += 1;
    }
    cycles
}

#[test]
fn a_node_predicts_through_a_remote_cliffd_and_its_observations_teach_the_map() {
    let ep = format!("tcp/127.0.0.1:{PORT_OBSERVE}");
    let map = format!("thor1={}", shared_data("thor1/cliffmap.csv").display());
    let daemon = Daemon::start(
        "observe",
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
        ],
    );
    let frames = frames();
    let fed: u64 = frames.iter().map(|m| m.people.len() as u64).sum();
    let people: std::collections::BTreeSet<&str> = frames
        .iter()
        .flat_map(|m| m.people.iter().map(|p| p.name.as_str()))
        .collect();

    // before anyone teaches it, the remote map is the file's: a node that only predicts
    // gets the in-process numbers
    let mut remote = node::engine(&parameters(Some((&ep, None)), false)).unwrap();
    let mut local = node::engine(&parameters(None, false)).unwrap();
    let cycles = run_beside(&mut remote, &mut local, &frames[..60]);
    assert_eq!(remote.stats().predicted, cycles);

    // a node that observes: every cycle predicts, every row the tracker published reaches
    // the daemon once, and every track's end
    let mut e = node::engine(&parameters(Some((&ep, None)), true)).unwrap();
    for m in &frames {
        e.on_people(m, Instant::now());
        e.cycle(Instant::now());
    }
    // the tracker goes quiet: a message well past the timeout ends every track
    let last = frames.last().unwrap().header.stamp.as_secs_f64();
    e.on_people(
        &People {
            header: Header {
                stamp: Time::from_secs_f64(last + 10.0),
                frame_id: "map".into(),
            },
            people: Vec::new(),
        },
        Instant::now(),
    );
    e.cycle(Instant::now());
    let s = e.stats();
    assert_eq!(
        (s.predicted, s.unavailable, s.refused),
        (frames.len() as u64 + 1, 0, 0),
        "{s:?}"
    );
    // (a person the keeper forgot and saw again is a second track with an end of its own)
    let o = e.observer().unwrap().stats();
    assert_eq!(
        (o.rows, o.duplicates, o.over_budget, o.refused, o.failed),
        (fed, o.ends, 0, 0, 0),
        "{o:?}"
    );
    assert!(o.ends >= people.len() as u64, "{o:?}");
    assert_eq!(e.observer().unwrap().pending_ends(), 0);

    // the map learns from them: a client of the daemon is served a learned version
    let mut client = Client::connect_zenoh_with(
        std::slice::from_ref(&ep),
        None,
        SERVICE,
        ClientOptions {
            deadline: Duration::from_secs(5),
            ..ClientOptions::default()
        },
    )
    .unwrap();
    let mut request = Request::new("thor1", &Params::default()).unwrap();
    request.add_agent([
        Observation::position(0.0, 1.0, 1.0),
        Observation::position(0.4, 1.4, 1.0),
    ]);
    let end = Instant::now() + Duration::from_secs(20);
    while client.predict(&request).unwrap().map_version() == 0 {
        assert!(Instant::now() < end, "no learned version within 20 s");
        std::thread::sleep(Duration::from_millis(50));
    }
    drop(client);
    drop((remote, local, e));
    // and counted them itself: every row taken once, every end a duplicate
    let closing = daemon.stop();
    assert_eq!(
        closing[..2],
        [fed, o.ends],
        "cliffd learned: rows taken, duplicates"
    );
    assert!(closing[2] > 0, "cliffd learned rows: {closing:?}");
}

#[test]
fn a_node_not_allowed_to_teach_gets_its_status_and_keeps_predicting() {
    let dir = std::env::temp_dir().join(format!("cliff-ros2-zenoh-acl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    tls::certificates(&dir, &["robot-1", "robot-2"]);
    let daemon_cfg = tls::docs_config("cliffd-site.json5", &dir, "cliffd", SERVICE);
    let ep = format!("quic/127.0.0.1:{PORT_NOT_ALLOWED}");
    let map = format!("thor1={}", shared_data("thor1/cliffmap.csv").display());
    let daemon = Daemon::start(
        "acl",
        &[
            "--map",
            &map,
            "--learn",
            "thor1",
            "--learn-every-s",
            "0.3",
            "--zenoh",
            &ep,
            "--zenoh-config",
            daemon_cfg.to_str().unwrap(),
        ],
    );
    // robot-2 may predict but not teach (docs/zenoh/cliffd-site.json5)
    let robot2 = tls::docs_config("robot.json5", &dir, "robot-2", SERVICE);
    let mut remote = node::engine(&parameters(Some((&ep, Some(&robot2))), true)).unwrap();
    let mut local = node::engine(&parameters(None, false)).unwrap();
    let frames = frames();
    let cycles = run_beside(&mut remote, &mut local, &frames[..100]);
    let s = remote.stats();
    assert_eq!(
        (s.predicted, s.unavailable, s.refused),
        (cycles, 0, 0),
        "{s:?}"
    );
    let observer = remote.observer().unwrap();
    let o = observer.stats();
    assert_eq!(
        (o.rows, o.ends, o.failed, o.over_budget),
        (0, 0, 0, 0),
        "{o:?}"
    );
    assert_eq!(o.refused, cycles, "each cycle's rows refused: {o:?}");
    assert_eq!(observer.last_refusal(), Some(Status::NotAllowed));
    // the daemon took none of them
    let closing = daemon.stop();
    assert_eq!(
        closing[..3],
        [0, 0, 0],
        "cliffd learned: rows taken, duplicates, learned"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_node_over_its_observe_budget_sends_less_at_once_and_keeps_predicting() {
    let ep = format!("tcp/127.0.0.1:{PORT_OVER_BUDGET}");
    let map = format!("thor1={}", shared_data("thor1/cliffmap.csv").display());
    // 50 rows a second for this client; no version learned during the run, so the
    // predictions stay the file's
    let daemon = Daemon::start(
        "budget",
        &[
            "--map",
            &map,
            "--learn",
            "thor1",
            "--learn-every-s",
            "3600",
            "--learn-every-rows",
            "1000000",
            "--observe-rate",
            "50",
            "--zenoh",
            &ep,
        ],
    );
    let mut remote = node::engine(&parameters(Some((&ep, None)), true)).unwrap();
    let mut local = node::engine(&parameters(None, false)).unwrap();
    let frames = frames();
    // the tracker's messages (some 8,000 rows) far faster than they were recorded: over
    // the budget
    let cycles = run_beside(&mut remote, &mut local, &frames);
    let s = remote.stats();
    assert_eq!(
        (s.predicted, s.unavailable, s.refused),
        (cycles, 0, 0),
        "{s:?}"
    );
    let observer = remote.observer().unwrap();
    let o = observer.stats();
    assert!(o.over_budget > 0 && o.rows > 0, "{o:?}");
    assert_eq!((o.refused, o.failed), (0, 0), "{o:?}");
    // requests hold at most half of what the budget lets through in a second
    assert_eq!(observer.max_rows(), 25);
    // what the node counts as taken is what the daemon took
    drop(remote);
    let closing = daemon.stop();
    assert_eq!(
        closing[..2],
        [o.rows, o.duplicates],
        "cliffd learned: rows taken, duplicates"
    );
}

#[test]
fn a_zenoh_configuration_file_that_does_not_load_is_named_at_start() {
    let missing = std::env::temp_dir().join("cliff-ros2-no-such-zenoh-config.json5");
    let e = node::engine(&parameters(Some(("tcp/127.0.0.1:1", Some(&missing))), true))
        .err()
        .expect("a missing configuration file is an error");
    let e = format!("{e:#}");
    assert!(e.contains(&missing.display().to_string()), "{e}");
    let bad = std::env::temp_dir().join(format!("cliff-ros2-bad-{}.json5", std::process::id()));
    std::fs::write(&bad, "{ mode: ").unwrap();
    let e = node::engine(&parameters(Some(("tcp/127.0.0.1:1", Some(&bad))), false))
        .err()
        .expect("a configuration file that does not parse is an error");
    let e = format!("{e:#}");
    assert!(e.contains(&bad.display().to_string()), "{e}");
    let _ = std::fs::remove_file(&bad);
}
