//! `cliff-bench`: round-trip latency and throughput of a running `cliffd`, next to the
//! same predictions made in-process.
//!
//! `args.rs` holds the command line, `pool.rs` the requests, `client_thread.rs` one
//! client's timed requests, `pace.rs` the `--rate` schedule and `summary.rs` the
//! percentiles; this file runs the clients and the in-process side and reports.

mod args;
mod client_thread;
mod pace;
mod pool;
mod summary;

use std::hint::black_box;
use std::process::ExitCode;
use std::sync::{Arc, Barrier};
use std::time::Instant;

use clap::Parser;
use cliff::map::CliffMap;
use cliff_client::{LocalPredictor, WaitMode};

use crate::args::Args;
use crate::client_thread::{ClientResult, consume, run_client};
use crate::pace::Pace;
use crate::pool::request_pool;
use crate::summary::summarize;

fn main() -> ExitCode {
    let a = Args::parse();
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    match run(a) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(a: Args) -> Result<ExitCode, String> {
    if a.clients == 0 || a.requests == 0 || a.agents == 0 || a.k == 0 || a.steps == 0 {
        return Err("--clients, --requests, --agents, --k and --steps must be at least 1".into());
    }
    if let Some(r) = a.rate
        && !(r.is_finite() && r > 0.0 && r <= 1e6)
    {
        return Err(format!(
            "--rate {r}: expected requests per second, more than 0 and at most 1000000"
        ));
    }
    let map = match (&a.map_file, a.map.as_str()) {
        (Some(p), _) => CliffMap::load(p).map_err(|e| e.to_string())?,
        (None, "demo") => CliffMap::demo(),
        (None, other) => {
            return Err(format!(
                "map '{other}' is not the built-in demo: pass --map-file with the file the daemon serves it from"
            ));
        }
    };
    let pool = Arc::new(request_pool(&map, &a)?);
    let map = Arc::new(map);
    let a = Arc::new(a);

    // -- through the daemon
    let barrier = Arc::new(Barrier::new(a.clients + 1));
    let handles: Vec<_> = (0..a.clients)
        .map(|c| {
            let (a, pool, map, barrier) = (a.clone(), pool.clone(), map.clone(), barrier.clone());
            std::thread::spawn(move || run_client(&a, &pool, &map, &barrier, c * 13))
        })
        .collect();
    barrier.wait();
    let start = Instant::now();
    let results: Vec<ClientResult> = handles
        .into_iter()
        .map(|h| h.join().unwrap_or_default())
        .collect();
    let end = results
        .iter()
        .filter_map(|r| r.finished)
        .max()
        .unwrap_or_else(Instant::now);
    let wall = end.duration_since(start).as_secs_f64();
    let errors: Vec<String> = results.iter().flat_map(|r| r.errors.clone()).collect();
    let failures: usize = results.iter().map(|r| r.failures).sum();
    let slowest_failure_ms = results
        .iter()
        .map(|r| r.slowest_failure_ns)
        .max()
        .unwrap_or(0) as f64
        / 1e6;
    // the client that recovered least: its successful requests after its last failure
    let recovered = results
        .iter()
        .map(|r| r.after_last_failure)
        .min()
        .unwrap_or(0);
    let mismatches: usize = results.iter().map(|r| r.mismatches).sum();
    let mut ipc: Vec<u64> = results.into_iter().flat_map(|r| r.latencies_ns).collect();
    let done = ipc.len();
    if done == 0 {
        let first = errors
            .first()
            .map(|s| s.as_str())
            .unwrap_or("no request completed");
        return Err(format!("no request succeeded: {first}"));
    }

    // -- the same requests in-process
    let mut local = LocalPredictor::default();
    for r in pool.iter().take(a.warmup.min(pool.len())) {
        local
            .predict(&map, r.header(), r.rows())
            .map_err(|e| e.to_string())?;
    }
    let mut inproc = Vec::with_capacity(a.requests);
    let mut pace = Pace::new(a.rate);
    for i in 0..a.requests {
        let req = &pool[i % pool.len()];
        pace.wait();
        let t0 = Instant::now();
        let b = local
            .predict(&map, req.header(), req.rows())
            .map_err(|e| format!("in-process prediction refused the request: {e}"))?;
        let (_, k, steps) = b.shape();
        black_box(consume((0..b.shape().0 * k).map(|s| {
            &b.positions()[s * steps..s * steps + b.lens()[s] as usize]
        })));
        black_box(b.scores().iter().sum::<f32>());
        inproc.push(t0.elapsed().as_nanos() as u64);
    }

    let s = summarize(&mut ipc);
    let l = summarize(&mut inproc);
    let rps = done as f64 / wall;
    let aps = rps * a.agents as f64;
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(0);

    if a.json {
        let v = serde_json::json!({
            "service": a.service,
            "transport": if a.remote() { "zenoh" } else { "iceoryx2" },
            "clients": a.clients,
            "requests_per_client": a.requests,
            "completed": done,
            "agents": a.agents,
            "k": a.k,
            "steps": a.steps,
            "dt": a.dt,
            "method": a.method.name(),
            "scores": a.scores,
            "map": a.map,
            "wait": a.wait.to_string(),
            "rate_hz": a.rate,
            "p50_us": s.p50,
            "p90_us": s.p90,
            "p99_us": s.p99,
            "p999_us": s.p999,
            "max_us": s.max,
            "requests_per_s": rps,
            "agent_predictions_per_s": aps,
            "inprocess_p50_us": l.p50,
            "inprocess_p90_us": l.p90,
            "inprocess_p99_us": l.p99,
            "inprocess_p999_us": l.p999,
            "inprocess_max_us": l.max,
            "overhead_p50_us": s.p50 - l.p50,
            "overhead_p99_us": s.p99 - l.p99,
            "ratio_p50": s.p50 / l.p50,
            "errors": errors.len(),
            "failures": failures,
            "slowest_failure_ms": slowest_failure_ms,
            "min_successes_after_last_failure": recovered,
            "mismatches": if a.verify { Some(mismatches) } else { None },
            "cpus": cores,
        });
        println!("{v}");
    } else {
        println!(
            "cliff-bench: {} client(s) x {} requests (+{} warm-up each) to cliffd '{}' over {}{}",
            a.clients,
            a.requests,
            a.warmup,
            a.service,
            if a.remote() { "zenoh" } else { "iceoryx2" },
            match a.rate {
                Some(r) => format!(", each client paced at {r} requests/s"),
                None => ", back to back".to_string(),
            }
        );
        println!(
            "  each request: {} agent(s) x k {} samples x {} steps (dt {} s, horizon {:.1} s), method {}{}, map {}; client wait: {}",
            a.agents,
            a.k,
            a.steps,
            a.dt,
            a.steps as f64 * a.dt,
            a.method,
            if a.scores { " with scores" } else { "" },
            a.map,
            a.wait
        );
        println!();
        println!(
            "  {:<26} {:>9} {:>9} {:>9} {:>9} {:>9}   (microseconds)",
            "", "p50", "p90", "p99", "p99.9", "max"
        );
        for (name, x) in [
            ("round trip through cliffd", &s),
            ("in-process prediction", &l),
        ] {
            println!(
                "  {:<26} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
                name, x.p50, x.p90, x.p99, x.p999, x.max
            );
        }
        println!();
        println!(
            "  daemon overhead: p50 {:+.1} us, p99 {:+.1} us (round trip / in-process at p50: {:.2}x)",
            s.p50 - l.p50,
            s.p99 - l.p99,
            s.p50 / l.p50
        );
        println!(
            "  throughput: {:.0} requests/s = {:.0} agent-predictions/s ({} clients, {:.2} s, {} CPUs)",
            rps, aps, a.clients, wall, cores
        );
        if a.verify {
            println!(
                "  verified: {} of {} responses identical to the in-process result",
                done - mismatches,
                done
            );
        }
        if a.keep_going && failures > 0 {
            println!(
                "  failures: {failures} requests failed (slowest reported after {slowest_failure_ms:.1} ms); every client then succeeded {recovered}+ times"
            );
        }
        println!();
        println!(
            "  round trip = send the request, cliffd validates it and predicts into shared memory,"
        );
        println!("               the client receives the response and reads every position.");
        println!(
            "  in-process = the same requests decoded and predicted here, one thread, no IPC."
        );
        if a.wait != WaitMode::Block && cores > 0 && a.clients + 1 > cores {
            println!(
                "  note: {} {} clients + cliffd on {} CPUs compete for cores (a {} client busy-polls{}),\n        so latency measures the scheduler; use --wait block for throughput runs.",
                a.clients,
                a.wait,
                cores,
                a.wait,
                if a.wait == WaitMode::Hybrid {
                    format!(" for up to {} us", a.spin_us)
                } else {
                    String::new()
                }
            );
        }
    }
    if !errors.is_empty() {
        eprintln!("{failures} request(s) failed; first errors:");
        for e in errors.iter().take(5) {
            eprintln!("  {e}");
        }
    }
    // with --keep-going, failures are the point of the run: it fails only when a client
    // never recovered
    let failed = if a.keep_going {
        recovered == 0 && failures > 0
    } else {
        !errors.is_empty()
    };
    if failed || mismatches > 0 {
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}
