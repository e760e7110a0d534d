//! In the steady state our code allocates nothing per request, in the daemon or the
//! client, whatever the method, options and scores: a counting allocator (daemon and client are threads of this process here, so
//! one counter sees both) sees only iceoryx2 0.10's own three small allocations per
//! round trip (it boxes the shared state of every loaned request, received request and
//! loaned response: 48 + 24 + 48 bytes, traced with backtraces when this test was
//! written). Anything our code allocated per request would push the count above that.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use cliff::predict::Method;
use cliff_client::{Client, WaitMode};
use cliff_service::{Daemon, Settings};
use common::*;

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn round_trips_do_not_allocate_in_the_steady_state() {
    let ns = Namespace::new("alloc");
    let stop = Arc::new(AtomicBool::new(false));
    let ready = Arc::new(AtomicBool::new(false));
    let server = {
        let (stop, ready, prefix) = (stop.clone(), ready.clone(), ns.prefix.clone());
        std::thread::spawn(move || {
            let settings = Settings {
                service: SERVICE.into(),
                prefix: Some(prefix),
                idle_spin: Duration::from_micros(200),
                // the once-a-second sweep for dead processes lists directories: not
                // part of a request, kept out of the measured window
                cleanup_interval: Duration::from_secs(3600),
                ..Settings::default()
            };
            let mut daemon = Daemon::new(settings).expect("daemon");
            ready.store(true, Ordering::SeqCst);
            daemon.run(&stop, &AtomicBool::new(false));
            daemon.stats()
        })
    };
    let end = Instant::now() + Duration::from_secs(20);
    while !ready.load(Ordering::SeqCst) {
        assert!(Instant::now() < end, "daemon did not start");
        std::thread::sleep(Duration::from_millis(5));
    }
    // the paper's method, the options with scores, and the improved method (whose
    // candidates need buffers: grown once per request slot, then reused)
    let requests: Vec<_> = (0..12)
        .map(|i| {
            let agents = 1 + i as usize % 3;
            match i % 3 {
                0 => demo_request(i, agents, 10, Method::Cliff),
                1 => demo_request(i, agents, 10, Method::Cliff)
                    .speed_beta(2.0)
                    .coast(4.0)
                    .scores(true),
                // one agent: five times the work per position, and a round trip that
                // outlasts the client's 20 ms liveness check (which lists directories)
                // would count its allocations
                _ => demo_request(i, 1, 10, Method::Improved),
            }
        })
        .collect();
    for wait in [WaitMode::Spin, WaitMode::Hybrid, WaitMode::Block] {
        let mut client: Client = ns.connect(wait);
        // warm up: first connections, listener lookups, buffers grown
        for r in requests.iter().cycle().take(50) {
            client.predict(r).expect("warm-up");
        }
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        let mut points = 0usize;
        for r in requests.iter().cycle().take(400) {
            let p = client.predict(r).expect("served");
            points += p.lens().iter().map(|&l| l as usize).sum::<usize>();
        }
        let allocated = ALLOCATIONS.load(Ordering::SeqCst) - before;
        assert!(points > 0);
        const ICEORYX2_PER_ROUND_TRIP: u64 = 3;
        assert!(
            allocated <= 400 * ICEORYX2_PER_ROUND_TRIP,
            "{wait}: {allocated} allocations in 400 round trips"
        );
    }
    stop.store(true, Ordering::SeqCst);
    let stats = server.join().expect("daemon thread");
    assert!(stats.served >= 3 * 450);
}
