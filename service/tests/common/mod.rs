//! Helpers for the process tests: a private iceoryx2 namespace per test, a `cliffd`
//! child that is always killed, and requests with known in-process answers.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff::predict::{Method, Params};
use cliff_client::{Client, ClientOptions, Observation, Request, WaitMode};

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

fn remove_matching(dir: &std::path::Path, prefix: &str, depth: usize) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        let path = e.path();
        if name.starts_with(prefix) {
            if path.is_dir() {
                let _ = std::fs::remove_dir_all(&path);
            } else {
                let _ = std::fs::remove_file(&path);
            }
        } else if path.is_dir() && depth < 4 {
            remove_matching(&path, prefix, depth + 1);
        }
    }
}

/// A running `cliffd`, killed (SIGKILL) when dropped unless stopped before.
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
        let stdout = child.stdout.take().expect("stdout");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
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
        let _ = self.child.kill();
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
        let with_velocity = (i as usize + a) % 2 == 0;
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

/// Bit patterns of every position and the lengths: what "the same numbers" means.
pub fn bits(positions: &[[f32; 2]], lens: &[u32]) -> (Vec<u32>, Vec<u32>) {
    (
        positions.iter().flatten().map(|v| v.to_bits()).collect(),
        lens.to_vec(),
    )
}

/// The in-process answer to `request` on `map`.
pub fn local_bits(map: &CliffMap, request: &Request) -> ((usize, usize, usize), (Vec<u32>, Vec<u32>)) {
    let mut lp = cliff_client::LocalPredictor::default();
    let b = lp
        .predict(map, request.header(), request.rows())
        .expect("request is valid in-process");
    (b.shape(), bits(b.positions(), b.lens()))
}
