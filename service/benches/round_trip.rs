//! Criterion: one round trip through a daemon (a thread of this process, over the same
//! iceoryx2 shared memory as between processes) next to the same prediction in-process.
//! The latency tool `cliff-bench` measures across processes with percentiles; this
//! bench tracks regressions.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use cliff::map::CliffMap;
use cliff::predict::Params;
use cliff_client::{Client, ClientOptions, LocalPredictor, Observation, Request, WaitMode};
use cliff_service::{Daemon, Settings};
use criterion::{Criterion, criterion_group, criterion_main};

const SERVICE: &str = "cliff/bench";

fn request(k: usize, steps: usize) -> Request {
    let params = Params {
        k,
        horizon: steps as f64 * 0.4,
        seed: 3,
        ..Params::default()
    };
    let mut r = Request::new("demo", &params).unwrap();
    r.add_agent((0..5).map(|j| Observation::position(0.4 * j as f64, -12.0 + 0.5 * j as f64, 0.5)));
    r
}

fn round_trip(c: &mut Criterion) {
    let prefix = format!("cliff_bench_{}_", std::process::id());
    let stop = Arc::new(AtomicBool::new(false));
    let ready = Arc::new(AtomicBool::new(false));
    let server = {
        let (stop, ready, prefix) = (stop.clone(), ready.clone(), prefix.clone());
        std::thread::spawn(move || {
            let settings = Settings {
                service: SERVICE.into(),
                prefix: Some(prefix),
                idle_spin: Duration::from_secs(1),
                ..Settings::default()
            };
            let mut daemon = Daemon::new(settings).expect("daemon");
            ready.store(true, Ordering::SeqCst);
            daemon.run(&stop, &AtomicBool::new(false));
        })
    };
    while !ready.load(Ordering::SeqCst) {
        std::thread::sleep(Duration::from_millis(5));
    }
    // hybrid: spins 200 us (all of a short request), then sleeps, so a daemon thread
    // sharing a core with the client still gets to run on a busy host
    let options = ClientOptions {
        wait: WaitMode::Hybrid,
        prefix: Some(prefix),
        ..ClientOptions::default()
    };
    let mut client = Client::connect_with(SERVICE, options).expect("connect");
    let map = CliffMap::demo();
    let mut local = LocalPredictor::default();
    let mut g = c.benchmark_group("round_trip");
    for (name, k, steps) in [("k1_steps1", 1, 1), ("k20_steps30", 20, 30)] {
        let req = request(k, steps);
        g.bench_function(format!("daemon_{name}"), |b| {
            b.iter(|| {
                let p = client.predict(&req).unwrap();
                std::hint::black_box(p.lens()[0]);
            })
        });
        g.bench_function(format!("in_process_{name}"), |b| {
            b.iter(|| {
                let batch = local.predict(&map, req.header(), req.rows()).unwrap();
                std::hint::black_box(batch.lens()[0]);
            })
        });
    }
    g.finish();
    drop(client);
    stop.store(true, Ordering::SeqCst);
    let _ = server.join();
}

criterion_group!(benches, round_trip);
criterion_main!(benches);
