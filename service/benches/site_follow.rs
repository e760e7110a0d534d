//! A site with many robots on one host (benches/site_follow.sh runs this): a site
//! `cliffd --learn` of the ATC map with `--zenoh` on loopback, and a robot `cliffd
//! --follow` in another iceoryx2 namespace. Prints one JSON line per figure:
//!
//! * `latency quiet`: the robot client's round trips (1 agent, k 20, 30 steps, over
//!   iceoryx2) while the site learns nothing;
//! * `observe`: new observation rows per second that one remote session delivers
//!   (requests of 1,024 new rows: 64 people of 16 rows, each track ended), for
//!   `SECONDS` (default 5);
//! * `follow`: while a teacher session sends 2,000 rows a second and the site learns a
//!   version a second, a local client of the site and one of the robot each ask every
//!   millisecond; the delay from the site's client first seeing a version to the
//!   robot's client first seeing it (median and largest over the versions);
//! * `latency arriving`: the robot client's round trips while versions arrive (the
//!   `follow` phase): p50, p99, max, failures.
//!
//! Settings from the environment: `CLIFFD` (the binary, default
//! target/release/cliffd), `SECONDS` (per phase, default 5; the follow phase takes
//! four times as long), `FOLLOW_EVERY_MS` (default 500).

use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cliff::predict::Params;
use cliff_client::{Client, ClientOptions, Observation, ObserveRequest, Request, WaitMode};

const PORT: u16 = 27_483;
const SERVICE: &str = "cliff/site-bench";

fn env(key: &str, default: &str) -> String {
    std::env::var(key).unwrap_or_else(|_| default.to_string())
}

fn data(rel: &str) -> String {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    root.join(rel).display().to_string()
}

/// A cliffd, stopped with SIGTERM (so that it removes its iceoryx2 files) when dropped,
/// panics included.
struct Daemon(Child);

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = Command::new("kill").arg(self.0.id().to_string()).status();
        let _ = self.0.wait();
    }
}

/// Start a cliffd and wait for its ready line.
fn start(args: &[String], log: &str) -> Daemon {
    let cliffd = env("CLIFFD", "target/release/cliffd");
    let mut child = Command::new(&cliffd)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap_or_else(|e| panic!("run {cliffd}: {e}"));
    let stdout = child.stdout.take().unwrap();
    let daemon = Daemon(child);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(stdout)
            .lines()
            .map_while(Result::ok)
        {
            let _ = tx.send(line);
        }
    });
    loop {
        let line = rx
            .recv_timeout(Duration::from_secs(60))
            .unwrap_or_else(|_| panic!("cliffd did not become ready (log {log})"));
        if line.contains("ready") {
            std::thread::spawn(move || for _ in rx {});
            return daemon;
        }
    }
}

fn local(prefix: &str) -> Client {
    Client::connect_with(
        SERVICE,
        ClientOptions {
            wait: WaitMode::Hybrid,
            deadline: Duration::from_secs(2),
            prefix: Some(prefix.to_string()),
            ..ClientOptions::default()
        },
    )
    .expect("connect")
}

fn remote() -> Client {
    Client::connect_zenoh_with(
        &[format!("tcp/127.0.0.1:{PORT}")],
        None,
        SERVICE,
        ClientOptions {
            // the site's learner competes with zenoh's threads for the cores
            deadline: Duration::from_secs(30),
            ..ClientOptions::default()
        },
    )
    .expect("connect over zenoh")
}

/// 1 agent, k 20, 30 steps (12 s at 0.4 s), walking in ATC's corridor.
fn request() -> Request {
    let params = Params {
        k: 20,
        horizon: 12.0,
        ..Params::default()
    };
    let mut r = Request::new("atc", &params).unwrap();
    r.add_agent((0..4).map(|i| Observation::position(0.4 * i as f64, 10.0 + 0.5 * i as f64, -5.0)));
    r
}

/// Request `n`: 64 people of 16 new rows each, every track ended.
fn observations(o: &mut ObserveRequest, n: u32) {
    o.clear();
    for p in 0..64u32 {
        let y = -10.0 + (p % 20) as f64;
        o.add_track(
            n * 64 + p,
            (0..16).map(|i| Observation::position(0.4 * i as f64, 5.0 + 0.5 * i as f64, y)),
        );
        o.end_track();
    }
}

fn quantiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    (q(0.5), q(0.99), v[v.len() - 1])
}

/// The robot client's round trips (us) and failures until `stop`, and the instants it
/// first saw each version.
fn poll(mut c: Client, stop: &AtomicBool, latencies: bool) -> (Vec<f64>, u64, Vec<(u32, Instant)>) {
    let r = request();
    let (mut lat, mut failed, mut seen) = (Vec::new(), 0, Vec::<(u32, Instant)>::new());
    while !stop.load(Ordering::Relaxed) {
        let t = Instant::now();
        match c.predict(&r) {
            Ok(p) => {
                let v = p.map_version();
                if latencies {
                    lat.push(t.elapsed().as_secs_f64() * 1e6);
                }
                if seen.last().is_none_or(|&(last, _)| last != v) {
                    seen.push((v, Instant::now()));
                }
            }
            Err(_) => failed += 1,
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    (lat, failed, seen)
}

fn main() {
    let secs: f64 = env("SECONDS", "5").parse().unwrap();
    let every = env("FOLLOW_EVERY_MS", "500");
    let dir = std::env::temp_dir().join(format!("cliff-site-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let map = format!("atc={}", data("atc/cliffmap-20121024.csv"));
    let ep = format!("tcp/127.0.0.1:{PORT}");
    let s = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let site_prefix = format!("cliff_sitebench_s{}_", std::process::id());
    let robot_prefix = format!("cliff_sitebench_r{}_", std::process::id());
    let site = start(
        &s(&[
            "--service",
            SERVICE,
            "--prefix",
            &site_prefix,
            "--map",
            &map,
            "--learn",
            "atc",
            "--learn-every-s",
            "1",
            "--learn-every-rows",
            "100000000",
            "--observe-rate",
            "100000000",
            "--observe-tracks",
            "10000000",
            "--track-timeout-s",
            "1",
            "--observe-rows-held",
            "100000000",
            "--zenoh",
            &ep,
        ]),
        &dir.join("site.log").display().to_string(),
    );
    let robot = start(
        &s(&[
            "--service",
            SERVICE,
            "--prefix",
            &robot_prefix,
            "--map",
            &map,
            "--follow",
            &format!("atc={ep}"),
            "--follow-dir",
            &dir.join("follow").display().to_string(),
            "--follow-every-ms",
            &every,
        ]),
        &dir.join("robot.log").display().to_string(),
    );

    // the robot's latency while nothing arrives
    let quiet = Arc::new(AtomicBool::new(false));
    let q = quiet.clone();
    let robot_client = local(&robot_prefix);
    let h = std::thread::spawn(move || poll(robot_client, &q, true));
    std::thread::sleep(Duration::from_secs_f64(secs));
    quiet.store(true, Ordering::Relaxed);
    let (lat, failed, seen) = h.join().unwrap();
    let (p50, p99, max) = quantiles(lat.clone());
    println!(
        "{{\"figure\":\"latency quiet\",\"requests\":{},\"failed\":{failed},\"versions_seen\":{},\"p50_us\":{p50:.1},\"p99_us\":{p99:.1},\"max_us\":{max:.1}}}",
        lat.len(),
        seen.len()
    );

    // observation rows per second, one remote session
    let mut teacher = remote();
    let mut o = ObserveRequest::new("atc").unwrap();
    let (mut rows, mut n, t0) = (0u64, 0u32, Instant::now());
    while t0.elapsed().as_secs_f64() < secs {
        observations(&mut o, n);
        n += 1;
        rows += teacher.observe(&o).expect("observations taken").accepted as u64;
    }
    let took = t0.elapsed().as_secs_f64();
    println!(
        "{{\"figure\":\"observe\",\"rows\":{rows},\"requests\":{n},\"seconds\":{took:.2},\"rows_per_s\":{:.0}}}",
        rows as f64 / took
    );
    // let the site learn what that taught, and the robot catch up
    std::thread::sleep(Duration::from_secs(5));

    // versions arriving: a teacher at 2,000 rows a second, both daemons watched
    let stop_all = Arc::new(AtomicBool::new(false));
    let st = stop_all.clone();
    let teach = std::thread::spawn(move || {
        let mut teacher = remote();
        let mut o = ObserveRequest::new("atc").unwrap();
        let mut n = 1_000_000u32;
        while !st.load(Ordering::Relaxed) {
            observations(&mut o, n);
            n += 1;
            let _ = teacher.observe(&o);
            std::thread::sleep(Duration::from_millis(500));
        }
    });
    let (st1, st2) = (stop_all.clone(), stop_all.clone());
    let site_client = local(&site_prefix);
    let robot_client = local(&robot_prefix);
    let hs = std::thread::spawn(move || poll(site_client, &st1, false));
    let hr = std::thread::spawn(move || poll(robot_client, &st2, true));
    std::thread::sleep(Duration::from_secs_f64(4.0 * secs));
    stop_all.store(true, Ordering::Relaxed);
    let (_, _, site_seen) = hs.join().unwrap();
    let (lat, failed, robot_seen) = hr.join().unwrap();
    teach.join().unwrap();
    let mut delays = Vec::new();
    for &(v, at) in site_seen.iter().skip(1) {
        if let Some(&(_, rat)) = robot_seen.iter().find(|&&(rv, _)| rv == v) {
            delays.push(rat.saturating_duration_since(at).as_secs_f64() * 1e3);
        }
    }
    let versions = delays.len();
    let (d50, _, dmax) = quantiles(delays);
    println!(
        "{{\"figure\":\"follow\",\"follow_every_ms\":{every},\"versions\":{versions},\"delay_median_ms\":{d50:.0},\"delay_max_ms\":{dmax:.0}}}"
    );
    let (p50, p99, max) = quantiles(lat.clone());
    println!(
        "{{\"figure\":\"latency arriving\",\"requests\":{},\"failed\":{failed},\"versions_seen\":{},\"p50_us\":{p50:.1},\"p99_us\":{p99:.1},\"max_us\":{max:.1}}}",
        lat.len(),
        robot_seen.len()
    );
    drop(robot);
    drop(site);
    let _ = std::fs::remove_dir_all(&dir);
}
