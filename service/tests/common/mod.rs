//! Helpers for the process tests: a private iceoryx2 namespace per test, a `cliffd`
//! child that is always killed, and requests with known in-process answers.
#![allow(dead_code)]

pub mod proxy;
pub mod tls;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::{Client, ClientOptions, Observation, Request, WaitMode};

/// The lines a child prints on its (piped) standard output, as they come.
fn stdout_lines(child: &mut Child) -> mpsc::Receiver<String> {
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

pub const SERVICE: &str = "cliff/test";

/// A fresh iceoryx2 prefix, unique per test and process; its files are removed on drop.
pub struct Namespace {
    pub prefix: String,
}

impl Namespace {
    pub fn new(tag: &str) -> Namespace {
        static N: AtomicUsize = AtomicUsize::new(0);
        let prefix = format!(
            "clt_{tag}_{}_{}_",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        );
        Namespace { prefix }
    }

    pub fn options(&self, wait: WaitMode) -> ClientOptions {
        ClientOptions {
            wait,
            deadline: Duration::from_secs(5),
            prefix: Some(self.prefix.clone()),
            ..ClientOptions::default()
        }
    }

    pub fn connect(&self, wait: WaitMode) -> Client {
        Client::connect_with(SERVICE, self.options(wait)).expect("connect to the test daemon")
    }

    pub fn log_path(&self, what: &str) -> PathBuf {
        let dir = std::env::temp_dir().join("cliff-service-tests");
        let _ = std::fs::create_dir_all(&dir);
        dir.join(format!("{}{what}.log", self.prefix))
    }
}

impl Drop for Namespace {
    fn drop(&mut self) {
        // best effort: stale files of processes killed with SIGKILL
        for dir in ["/dev/shm", "/tmp/iceoryx2"] {
            remove_matching(std::path::Path::new(dir), &self.prefix, 0);
        }
    }
}

/// Remove the files and directories under `dir` whose names start with `prefix`, and
/// the directories that this leaves empty (iceoryx2 keeps a node's files in a directory
/// named after the node id). Returns whether anything was removed.
fn remove_matching(dir: &std::path::Path, prefix: &str, depth: usize) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    let mut removed = false;
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        let path = e.path();
        if name.starts_with(prefix) {
            removed |= if path.is_dir() {
                std::fs::remove_dir_all(&path).is_ok()
            } else {
                std::fs::remove_file(&path).is_ok()
            };
        } else if path.is_dir() && depth < 4 && remove_matching(&path, prefix, depth + 1) {
            removed = true;
            // only a directory we emptied ourselves (fails harmlessly when not empty)
            let _ = std::fs::remove_dir(&path);
        }
    }
    removed
}

/// A running `cliffd`, stopped when dropped (SIGTERM, then SIGKILL if it has not exited
/// within two seconds) unless stopped before.
pub struct Daemon {
    pub child: Child,
    pub ready_line: String,
    pub log: PathBuf,
}

impl Daemon {
    pub fn start(ns: &Namespace, extra: &[&str]) -> Daemon {
        Self::start_tagged(ns, extra, "daemon")
    }

    pub fn start_tagged(ns: &Namespace, extra: &[&str], tag: &str) -> Daemon {
        let log = ns.log_path(tag);
        let stderr = std::fs::File::create(&log).expect("log file");
        let mut child = Command::new(env!("CARGO_BIN_EXE_cliffd"))
            .args(["--service", SERVICE, "--prefix", &ns.prefix])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .expect("spawn cliffd");
        let rx = stdout_lines(&mut child);
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut d = Daemon {
            child,
            ready_line: String::new(),
            log,
        };
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(line) if line.contains("ready") => {
                    d.ready_line = line;
                    // keep draining stdout so the daemon never blocks on it
                    std::thread::spawn(move || for _ in rx {});
                    return d;
                }
                Ok(_) => continue,
                Err(_) => {
                    let log = std::fs::read_to_string(&d.log).unwrap_or_default();
                    panic!("cliffd did not become ready; its log:\n{log}");
                }
            }
        }
    }

    pub fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    pub fn signal(&self, sig: i32) {
        // SAFETY: kill(2) on our own child's pid
        let r = unsafe { libc_kill(self.pid(), sig) };
        assert_eq!(r, 0, "kill({}, {sig})", self.pid());
    }

    /// Wait for the process to exit by itself (after a signal), within `limit`.
    pub fn wait_exit(&mut self, limit: Duration) -> Option<std::process::ExitStatus> {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        None
    }

    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            // a clean shutdown removes the daemon's iceoryx2 files
            // SAFETY: kill(2) on our own child's pid
            unsafe { libc_kill(self.pid(), 15) };
            if self.wait_exit(Duration::from_secs(2)).is_none() {
                let _ = self.child.kill();
            }
        }
        let _ = self.child.wait();
    }
}

unsafe extern "C" {
    #[link_name = "kill"]
    fn libc_kill(pid: i32, sig: i32) -> i32;
}

pub const SIGKILL: i32 = 9;
pub const SIGTERM: i32 = 15;
pub const SIGINT: i32 = 2;
pub const SIGHUP: i32 = 1;

/// A request of `agents` people walking in the demo hall, varied by `i`.
pub fn demo_request(i: u64, agents: usize, k: usize, method: Method) -> Request {
    let params = Params {
        method,
        k,
        seed: 1000 + i,
        ..Params::default()
    };
    let mut r = Request::new("demo", &params).unwrap();
    for a in 0..agents {
        let y = -2.5 + ((i as usize + a) % 6) as f64;
        let x0 = -12.0 + ((i as usize * 7 + a * 3) % 10) as f64;
        let with_velocity = (i as usize + a).is_multiple_of(2);
        r.add_agent((0..5).map(|j| {
            let t = 100.0 + 0.4 * j as f64;
            let x = x0 + 0.5 * j as f64;
            if with_velocity {
                Observation::with_velocity(t, x, y, 1.25, 0.05)
            } else {
                Observation::position(t, x, y + 0.02 * j as f64)
            }
        }));
    }
    r
}

/// Shape and bit patterns of a batch.
pub type Answer = ((usize, usize, usize), (Vec<u32>, Vec<u32>));

/// Bit patterns of every position and the lengths: what "the same numbers" means.
pub fn bits(positions: &[[f32; 2]], lens: &[u32]) -> (Vec<u32>, Vec<u32>) {
    (
        positions.iter().flatten().map(|v| v.to_bits()).collect(),
        lens.to_vec(),
    )
}

/// The in-process answer to `request` on `map`.
pub fn local_bits(map: &CliffMap, request: &Request) -> Answer {
    let mut lp = cliff_client::LocalPredictor::default();
    let b = lp
        .predict(map, request.header(), request.rows())
        .expect("request is valid in-process");
    (b.shape(), bits(b.positions(), b.lens()))
}

/// The in-process answer to `request` on `map` with its scores' bit patterns (empty
/// when the request asks for none) and each agent's best sample.
pub fn local_scored(map: &CliffMap, request: &Request) -> (Answer, Vec<u32>, Vec<Option<usize>>) {
    let mut lp = cliff_client::LocalPredictor::default();
    let b = lp
        .predict(map, request.header(), request.rows())
        .expect("request is valid in-process");
    let best = (0..b.shape().0).map(|a| b.best_sample(a)).collect();
    (
        (b.shape(), bits(b.positions(), b.lens())),
        score_bits(b.scores()),
        best,
    )
}

/// Bit patterns of scores.
pub fn score_bits(scores: &[f32]) -> Vec<u32> {
    scores.iter().map(|v| v.to_bits()).collect()
}

/// A prediction's answer in the form of [`local_scored`].
pub fn scored(p: &cliff_client::Prediction<'_>) -> (Answer, Vec<u32>, Vec<Option<usize>>) {
    let best = (0..p.shape().0).map(|a| p.best_sample(a)).collect();
    (
        (p.shape(), bits(p.positions(), p.lens())),
        score_bits(p.scores()),
        best,
    )
}

/// Path of a file in the shared data folder beside the checkout.
pub fn shared_data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data")).join(rel)
}

/// A client process: this test binary run again with `CLIFF_TEST_CHILD` set, executing
/// the ignored test `name`. Killed (SIGKILL) when dropped.
pub struct ChildClient {
    pub child: Child,
    lines: mpsc::Receiver<String>,
}

impl ChildClient {
    pub fn spawn(name: &str, spec: &str) -> ChildClient {
        Self::spawn_with(name, "CLIFF_TEST_CHILD", spec)
    }

    /// As [`spawn`](Self::spawn), with the spec in the environment variable `var`.
    pub fn spawn_with(name: &str, var: &str, spec: &str) -> ChildClient {
        let mut child = Command::new(std::env::current_exe().expect("test exe"))
            .args([
                name,
                "--exact",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .env(var, spec)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn child client");
        let rx = stdout_lines(&mut child);
        ChildClient { child, lines: rx }
    }

    /// Wait for a stdout line containing `what`; panics after `limit`.
    pub fn wait_line(&self, what: &str, limit: Duration) -> String {
        let end = Instant::now() + limit;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(l) if l.contains(what) => return l,
                Ok(_) => continue,
                Err(_) => panic!("child client did not print '{what}' within {limit:?}"),
            }
        }
    }

    /// Wait for the exit, within `limit`.
    pub fn wait_exit(&mut self, limit: Duration) -> std::process::ExitStatus {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Ok(Some(s)) = self.child.try_wait() {
                return s;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!("child client did not exit within {limit:?}");
    }

    pub fn kill9(&mut self) {
        // SAFETY: kill(2) on our own child's pid
        let r = unsafe { libc_kill(self.child.id() as i32, SIGKILL) };
        assert_eq!(r, 0);
        let _ = self.child.wait();
    }
}

impl Drop for ChildClient {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The child side: `CLIFF_TEST_CHILD` = `prefix,requests,agents,wait,tag`. Sends the
/// requests, checks each answer against the in-process result and the request ids for
/// being consecutive, prints `CHILD <tag> started` and `CHILD <tag> done <n>`.
pub fn run_child_client() {
    let Ok(spec) = std::env::var("CLIFF_TEST_CHILD") else {
        return;
    };
    let f: Vec<&str> = spec.split(',').collect();
    let (prefix, requests, agents, wait, tag) = (
        f[0].to_string(),
        f[1].parse::<u64>().unwrap(),
        f[2].parse::<usize>().unwrap(),
        f[3].parse::<WaitMode>().unwrap(),
        f[4],
    );
    let ns = Namespace { prefix };
    let mut client = ns.connect(wait);
    std::mem::forget(ns); // the parent owns the namespace's files
    let map = CliffMap::demo();
    let base = tag.bytes().map(u64::from).sum::<u64>() * 1000;
    let mut last_id = None;
    for i in 0..requests {
        let req = demo_request(
            base + i,
            agents,
            10,
            if i % 7 == 3 {
                Method::Cvm
            } else {
                Method::Cliff
            },
        );
        let (shape, want) = local_bits(&map, &req);
        let p = client
            .predict(&req)
            .unwrap_or_else(|e| panic!("child {tag} request {i}: {e}"));
        assert_eq!(p.shape(), shape, "child {tag} request {i}");
        assert_eq!(
            bits(p.positions(), p.lens()),
            want,
            "child {tag} request {i}"
        );
        if let Some(prev) = last_id {
            assert_eq!(
                p.request_id(),
                u64::wrapping_add(prev, 1),
                "child {tag}: request ids"
            );
        }
        last_id = Some(p.request_id());
        if i == 0 {
            println!("CHILD {tag} started");
        }
    }
    println!("CHILD {tag} done {requests}");
}

/// A binary of the workspace beside `cliffd` (`cargo test --workspace` builds them all).
pub fn workspace_exe(name: &str) -> std::path::PathBuf {
    let exe = std::path::PathBuf::from(env!("CARGO_BIN_EXE_cliffd")).with_file_name(name);
    assert!(
        exe.exists(),
        "{} is missing: run the tests with --workspace, or build it first",
        exe.display()
    );
    exe
}

/// Ask `request` until a learned version (above 0) answers, at most `limit`; that version.
pub fn first_learned_version(client: &mut Client, request: &Request, limit: Duration) -> u32 {
    let end = std::time::Instant::now() + limit;
    loop {
        let v = client.predict(request).unwrap().map_version();
        if v > 0 {
            return v;
        }
        assert!(
            std::time::Instant::now() < end,
            "no learned version within {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Send `tracks` as a robot at 2.5 Hz would: at every step of the recording, each person
/// in view with their last `history` rows (so each row is sent up to `history` times), the
/// last row of a track marked as its end. The counts summed over all replies.
pub fn observe_like_a_robot(
    client: &mut Client,
    map: &str,
    tracks: &[cliff::tracks::Track],
    history: usize,
) -> (u64, u64, u32) {
    let mut request = cliff_client::ObserveRequest::new(map).unwrap();
    let (t0, t1) = tracks
        .iter()
        .flat_map(|t| t.rows.iter().map(|r| r.t))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(t), b.max(t))
        });
    let (mut accepted, mut duplicates, mut version) = (0, 0, 0);
    let mut now = t0;
    while now <= t1 + 0.4 {
        request.clear();
        for (id, t) in tracks.iter().enumerate() {
            let seen: Vec<_> = t.rows.iter().filter(|r| r.t <= now).collect();
            if seen.is_empty()
                || t.rows[0].t > now
                || seen.len() == t.rows.len() && seen[seen.len() - 1].t < now - 0.4
            {
                continue;
            }
            let from = seen.len().saturating_sub(history);
            let rows: Vec<_> = seen[from..].iter().map(|r| **r).collect();
            request.add_track_rows(id as u32, &rows);
            if seen.len() == t.rows.len() {
                request.end_track();
            }
        }
        now += 0.4;
        if request.rows().is_empty() {
            continue;
        }
        let r = client.observe(&request).expect("observations taken");
        accepted += r.accepted as u64;
        duplicates += r.duplicates as u64;
        version = r.map_version;
    }
    (accepted, duplicates, version)
}
