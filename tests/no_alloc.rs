//! Once a batch buffer is sized and the map has seen the radius, a prediction call does
//! not allocate (counted by a global allocator that wraps the system one).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::predict::{BatchMut, Method, Params, TrajectoryBatch, predict, predict_into};
use glam::DVec2;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steady_state_predictions_do_not_allocate() {
    let map = CliffMap::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/thor1/cliffmap.csv"
    ))
    .unwrap();
    let agents: Vec<State> = (0..4)
        .map(|i| State {
            position: DVec2::new(-2.0 + i as f64, 0.5),
            speed: 1.0,
            heading: 0.3 * i as f64,
            time: 0.0,
        })
        .collect();
    let params = Params {
        k: 20,
        dt: 0.4,
        horizon: 12.0,
        radius: 0.7071,
        ..Params::default()
    };
    let mut batch = TrajectoryBatch::new();
    // warm-up: sizes the buffer and builds the radius's neighbour table
    predict(&map, &agents, &params, &mut batch).unwrap();
    let mut positions = vec![[0.0f32; 2]; 4 * 20 * 30];
    let mut lens = vec![0u32; 4 * 20];

    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for seed in 0..100 {
        for method in [Method::Cliff, Method::Cvm] {
            predict(
                &map,
                &agents,
                &Params {
                    seed,
                    method,
                    ..params
                },
                &mut batch,
            )
            .unwrap();
            predict(
                &map,
                &agents[..2],
                &Params {
                    seed,
                    method,
                    ..params
                },
                &mut batch,
            )
            .unwrap();
            predict_into(
                &map,
                &agents,
                &Params {
                    seed,
                    method,
                    ..params
                },
                BatchMut {
                    positions: &mut positions,
                    lens: &mut lens,
                },
            )
            .unwrap();
        }
    }
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    assert_eq!(
        after - before,
        0,
        "allocations during 600 steady-state predictions"
    );
    // and the work was real
    assert!(batch.lens().iter().any(|&l| l > 0));
}
