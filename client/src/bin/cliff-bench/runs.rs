//! A run: one way in ([`Way`]) at one client count, its threads started together and
//! their timings gathered ([`run_way`] gives a [`Run`]).

use std::sync::{Arc, Barrier};
use std::time::Instant;

use cliff::map::CliffMap;
use cliff_client::Request;

use crate::args::{Args, Target};
use crate::client_thread::{ClientResult, Job, run_client, run_local};
use crate::summary::{Summary, summarize};

/// A way in to a prediction.
#[derive(Debug, Clone)]
pub(crate) enum Way {
    /// Predicted in this process (no transport).
    InProcess,
    /// The bare transport: the floor's echo server answers with a response of the same
    /// size, without decoding or predicting.
    Floor(Target),
    /// Through cliffd.
    Daemon(Target),
}

impl Way {
    /// The way's name in tables and legends.
    pub(crate) fn name(&self) -> String {
        match self {
            Way::InProcess => "in-process".into(),
            Way::Floor(t) => format!("{} floor (echo)", t.transport()),
            Way::Daemon(t) => format!("{} via cliffd", t.transport()),
        }
    }

    /// `"none"`, `"iceoryx2"` or `"zenoh"`.
    pub(crate) fn transport(&self) -> &'static str {
        match self {
            Way::InProcess => "none",
            Way::Floor(t) | Way::Daemon(t) => t.transport(),
        }
    }

    /// `"prediction"`, `"floor"` or `"full"`.
    pub(crate) fn kind(&self) -> &'static str {
        match self {
            Way::InProcess => "prediction",
            Way::Floor(_) => "floor",
            Way::Daemon(_) => "full",
        }
    }
}

/// What one run measured, its threads together.
pub(crate) struct Run {
    /// Every timed request's latency (ns), sorted.
    pub(crate) latencies_ns: Vec<u64>,
    pub(crate) summary: Summary,
    /// From the barrier to the last thread's end (s).
    pub(crate) wall_s: f64,
    pub(crate) errors: Vec<String>,
    pub(crate) failures: usize,
    /// The longest a failed request took to report its failure (ms).
    pub(crate) slowest_failure_ms: f64,
    /// The thread that recovered least: its successful requests after its last failure.
    pub(crate) recovered: usize,
    /// Responses that differed from the in-process result (`None`: not checked).
    pub(crate) mismatches: Option<usize>,
}

impl Run {
    /// Timed requests that completed.
    pub(crate) fn completed(&self) -> usize {
        self.latencies_ns.len()
    }

    pub(crate) fn requests_per_s(&self) -> f64 {
        if self.wall_s > 0.0 {
            self.completed() as f64 / self.wall_s
        } else {
            0.0
        }
    }
}

/// Run `way` with `clients` threads, each cycling through `pool` from its own offset
/// (thread `c` at `13 c`, whatever the way, so that every way sends the same requests).
pub(crate) fn run_way(
    a: &Arc<Args>,
    way: &Way,
    clients: usize,
    pool: &Arc<Vec<Request>>,
    map: &Arc<CliffMap>,
) -> Run {
    let verify = a.verify() && matches!(way, Way::Daemon(_));
    let barrier = Arc::new(Barrier::new(clients + 1));
    let handles: Vec<_> = (0..clients)
        .map(|c| {
            let (a, pool, map, barrier, way) = (
                a.clone(),
                pool.clone(),
                map.clone(),
                barrier.clone(),
                way.clone(),
            );
            std::thread::spawn(move || {
                let job = Job {
                    a: &a,
                    pool: &pool,
                    map: &map,
                    barrier: &barrier,
                    offset: c * 13,
                };
                match &way {
                    Way::InProcess => run_local(&job),
                    Way::Floor(t) | Way::Daemon(t) => run_client(&job, t, verify),
                }
            })
        })
        .collect();
    // the clock starts before the barrier lets the clients go: taken after it, a main
    // thread descheduled at the barrier could start it after the clients finished
    let start = Instant::now();
    barrier.wait();
    let results: Vec<ClientResult> = handles
        .into_iter()
        .map(|h| h.join().unwrap_or_default())
        .collect();
    let end = results
        .iter()
        .filter_map(|r| r.finished)
        .max()
        .unwrap_or_else(Instant::now);
    let errors: Vec<String> = results.iter().flat_map(|r| r.errors.clone()).collect();
    let failures = results.iter().map(|r| r.failures).sum();
    let slowest_failure_ms = results
        .iter()
        .map(|r| r.slowest_failure_ns)
        .max()
        .unwrap_or(0) as f64
        / 1e6;
    let recovered = results
        .iter()
        .map(|r| r.after_last_failure)
        .min()
        .unwrap_or(0);
    let mismatches = verify.then(|| results.iter().map(|r| r.mismatches).sum());
    let mut latencies_ns: Vec<u64> = results.into_iter().flat_map(|r| r.latencies_ns).collect();
    let summary = summarize(&mut latencies_ns);
    Run {
        latencies_ns,
        summary,
        wall_s: end.duration_since(start).as_secs_f64(),
        errors,
        failures,
        slowest_failure_ms,
        recovered,
        mismatches,
    }
}
