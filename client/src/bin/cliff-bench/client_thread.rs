//! One thread of a run: its requests through a client, timed ([`run_client`]), or the
//! same requests predicted in-process ([`run_local`]).

use std::hint::black_box;
use std::sync::Barrier;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff_client::{Error, LocalPredictor, Request};

use crate::args::{Args, Target};
use crate::pace::Pace;

pub(crate) fn consume<'a>(samples: impl Iterator<Item = &'a [[f32; 2]]>) -> f32 {
    let mut s = 0.0f32;
    for sample in samples {
        for p in sample {
            s += p[0] + p[1];
        }
    }
    s
}

#[derive(Default)]
/// What one client thread measured.
pub(crate) struct ClientResult {
    pub(crate) latencies_ns: Vec<u64>,
    pub(crate) errors: Vec<String>,
    /// Failed requests (all of them, while `errors` keeps the first few messages).
    pub(crate) failures: usize,
    /// The longest time a failed request took to report its failure (ns).
    pub(crate) slowest_failure_ns: u64,
    /// Successful requests after the last failure.
    pub(crate) after_last_failure: usize,
    pub(crate) mismatches: usize,
    pub(crate) finished: Option<Instant>,
}

/// What a thread of a run needs: the settings, the requests, the map and where this
/// thread starts in the requests.
pub(crate) struct Job<'a> {
    pub(crate) a: &'a Args,
    pub(crate) pool: &'a [Request],
    pub(crate) map: &'a CliffMap,
    pub(crate) barrier: &'a Barrier,
    pub(crate) offset: usize,
}

/// One client thread: connect to `target`, warm up, wait at the barrier, then send and
/// time its requests (and compare them with in-process predictions when `verify`).
pub(crate) fn run_client(job: &Job<'_>, target: &Target, verify: bool) -> ClientResult {
    let Job {
        a,
        pool,
        map,
        barrier,
        offset,
    } = *job;
    let mut out = ClientResult::default();
    let client = target.connect(a.client_options());
    let mut client = match client {
        Ok(c) => c,
        Err(e) => {
            out.errors.push(format!("connect: {e}"));
            barrier.wait();
            return out;
        }
    };
    for i in 0..a.warmup {
        if let Err(e) = client.predict(&pool[(offset + i) % pool.len()]) {
            out.errors.push(format!("warm-up: {e}"));
            barrier.wait();
            return out;
        }
    }
    let mut local = LocalPredictor::default();
    out.latencies_ns.reserve(a.requests);
    barrier.wait();
    let mut pace = Pace::new(a.rate);
    let mut last_success = Instant::now();
    let mut i = 0;
    while out.latencies_ns.len() < a.requests && (a.keep_going || i < a.requests) {
        let req = &pool[(offset + i) % pool.len()];
        i += 1;
        pace.wait();
        let t0 = Instant::now();
        let r = client.predict(req);
        match r {
            Ok(p) => {
                last_success = Instant::now();
                out.after_last_failure += 1;
                black_box(consume(p.agents().flat_map(|ag| ag.samples())));
                black_box(p.scores().iter().sum::<f32>());
                out.latencies_ns.push(t0.elapsed().as_nanos() as u64);
                if verify {
                    let same = match local.predict(map, req.header(), req.rows()) {
                        Ok(b) => {
                            b.shape() == p.shape()
                                && b.lens() == p.lens()
                                && b.positions()
                                    .iter()
                                    .flatten()
                                    .zip(p.positions().iter().flatten())
                                    .all(|(x, y)| x.to_bits() == y.to_bits())
                                && b.scores().len() == p.scores().len()
                                && b.scores()
                                    .iter()
                                    .zip(p.scores())
                                    .all(|(x, y)| x.to_bits() == y.to_bits())
                        }
                        Err(_) => false,
                    };
                    if !same {
                        out.mismatches += 1;
                    }
                }
            }
            Err(e) => {
                out.failures += 1;
                out.after_last_failure = 0;
                out.slowest_failure_ns = out.slowest_failure_ns.max(t0.elapsed().as_nanos() as u64);
                let fatal = matches!(e, Error::NoDaemon { .. } | Error::DaemonGone { .. });
                if out.errors.len() < 20 {
                    out.errors.push(e.to_string());
                }
                if a.keep_going {
                    if last_success.elapsed().as_secs_f64() > a.give_up_s {
                        break;
                    }
                    std::thread::sleep(Duration::from_millis(10));
                    continue;
                }
                if fatal {
                    break;
                }
            }
        }
    }
    out.finished = Some(Instant::now());
    out
}

/// One in-process thread: warm up, wait at the barrier, then predict and time the same
/// requests as a client thread with the same offset (and pace).
pub(crate) fn run_local(job: &Job<'_>) -> ClientResult {
    let Job {
        a,
        pool,
        map,
        barrier,
        offset,
    } = *job;
    let mut out = ClientResult::default();
    let mut local = LocalPredictor::default();
    for i in 0..a.warmup {
        let r = &pool[(offset + i) % pool.len()];
        if let Err(e) = local.predict(map, r.header(), r.rows()) {
            out.errors.push(format!("warm-up in-process: {e}"));
            barrier.wait();
            return out;
        }
    }
    out.latencies_ns.reserve(a.requests);
    barrier.wait();
    let mut pace = Pace::new(a.rate);
    for i in 0..a.requests {
        let req = &pool[(offset + i) % pool.len()];
        pace.wait();
        let t0 = Instant::now();
        match local.predict(map, req.header(), req.rows()) {
            Ok(b) => {
                let (_, k, steps) = b.shape();
                black_box(consume((0..b.shape().0 * k).map(|s| {
                    &b.positions()[s * steps..s * steps + b.lens()[s] as usize]
                })));
                black_box(b.scores().iter().sum::<f32>());
                out.latencies_ns.push(t0.elapsed().as_nanos() as u64);
            }
            Err(e) => {
                out.failures += 1;
                out.errors
                    .push(format!("in-process prediction refused the request: {e}"));
                break;
            }
        }
    }
    out.finished = Some(Instant::now());
    out
}
