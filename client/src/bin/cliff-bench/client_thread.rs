//! One client thread of the run: its requests through the daemon, timed
//! ([`run_client`]).

use std::hint::black_box;
use std::sync::Barrier;
use std::time::{Duration, Instant};

use cliff::map::CliffMap;
use cliff_client::{ClientOptions, Error, LocalPredictor, Request};

use crate::args::Args;
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

/// One client thread: connect, warm up, wait at the barrier, then send and time its
/// requests (and compare them with in-process predictions under `--verify`).
pub(crate) fn run_client(
    a: &Args,
    pool: &[Request],
    map: &CliffMap,
    barrier: &Barrier,
    offset: usize,
) -> ClientResult {
    let mut out = ClientResult::default();
    let options = ClientOptions {
        wait: a.wait,
        spin: Duration::from_micros(a.spin_us),
        deadline: Duration::from_millis(a.deadline_ms),
        prefix: a.prefix.clone().filter(|p| !p.is_empty()),
    };
    let client = a.connect(options);
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
                if a.verify {
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
