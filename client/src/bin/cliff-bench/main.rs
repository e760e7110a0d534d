//! `cliff-bench`: round-trip latency and throughput of a running `cliffd`, next to the
//! same predictions made in-process, the bare transport's floor, and all of them side by
//! side (`--compare`).
//!
//! `args.rs` holds the command line, `pool.rs` the requests, `client_thread.rs` one
//! thread's timed requests (through a client or in-process), `runs.rs` a run of one way in
//! with N threads, `pace.rs` the `--rate` schedule, `summary.rs` the percentiles,
//! `machine.rs` the machine's facts and the core count, `floor.rs` the echo server of the
//! floor, `compare.rs` and `report.rs` `--compare` and its report; this file runs a
//! single measurement and prints it.

mod args;
mod client_thread;
mod compare;
mod floor;
mod machine;
mod pace;
mod pool;
mod report;
mod runs;
mod summary;

use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use cliff::map::CliffMap;
use cliff_client::WaitMode;

use crate::args::Args;
use crate::machine::{CoreBudget, Machine};
use crate::pool::request_pool;
use crate::runs::{Way, run_way};

fn main() -> ExitCode {
    let a = Args::parse();
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    let result = match a.serve_floor.clone() {
        Some(shape) => floor::serve(&a, &shape).map(|()| ExitCode::SUCCESS),
        None => run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(a: Args) -> Result<ExitCode, String> {
    if a.requests == 0 || a.agents == 0 || a.k == 0 || a.steps == 0 {
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
    let counts = a.client_counts();
    if counts.contains(&0) {
        return Err("--clients, --requests, --agents, --k and --steps must be at least 1".into());
    }
    if counts.len() > 1 && !a.compare {
        return Err(format!(
            "--clients {}: a list of client counts is for --compare; a single run takes one count",
            a.clients
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(",")
        ));
    }
    let pool = Arc::new(request_pool(&map, &a)?);
    let map = Arc::new(map);
    let a = Arc::new(a);
    if a.compare {
        return compare::run(a, map, pool);
    }
    let clients = counts[0];
    let mut machine = Machine::now();
    let daemon = a.daemon_target();
    let budget = CoreBudget::of(
        machine.cores,
        clients,
        if a.remote() { WaitMode::Block } else { a.wait },
        a.agents * a.k * a.steps,
        a.daemon_workers.unwrap_or(machine.cores),
        true,
    );
    if let Some(w) = budget.warning(a.wait) {
        eprintln!("{w}");
    }

    // -- through the daemon, then the same requests in-process
    let full = run_way(&a, &Way::Daemon(daemon), clients, &pool, &map);
    let done = full.completed();
    let (errors, failures, slowest_failure_ms, recovered) = (
        &full.errors,
        full.failures,
        full.slowest_failure_ms,
        full.recovered,
    );
    let mismatches = full.mismatches.unwrap_or(0);
    if done == 0 {
        let first = errors
            .first()
            .map(|s| s.as_str())
            .unwrap_or("no request completed");
        return Err(format!("no request succeeded: {first}"));
    }
    let local = run_way(&a, &Way::InProcess, 1, &pool, &map);
    if let Some(e) = local.errors.first() {
        return Err(e.clone());
    }
    machine.finish();
    let wall = full.wall_s;
    let (s, l) = (full.summary, local.summary);
    let rps = done as f64 / wall;
    let aps = rps * a.agents as f64;
    let cores = machine.cores;

    if a.json {
        let v = serde_json::json!({
            "service": a.service,
            "transport": if a.remote() { "zenoh" } else { "iceoryx2" },
            "clients": clients,
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
            "mismatches": full.mismatches,
            "cpus": cores,
            "machine": machine.json(),
            "cores": budget.json(),
            "warmup_excluded": true,
            "percentiles": "nearest rank over every timed request (all clients)",
        });
        println!("{v}");
    } else {
        println!(
            "cliff-bench: {} client(s) x {} requests (+{} warm-up each, not counted) to cliffd '{}' over {}{}",
            clients,
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
            rps, aps, clients, wall, cores
        );
        println!("  machine: {}", machine.describe());
        if a.verify() {
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
        println!(
            "  percentiles from all {done} timed requests (warm-up excluded); --compare adds the bare transport's floor."
        );
        if budget.oversubscribed() {
            println!(
                "  note: more spinning clients than free cores (see the warning on stderr): latency measures the scheduler."
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
