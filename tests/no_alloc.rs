//! Once a batch buffer is sized and the map has seen the radius, a prediction call does
//! not allocate; once an occupancy buffer has held a call of a size, occupancy calls up
//! to that size do not allocate either (counted per thread by a global allocator that
//! wraps the system one, so tests running side by side do not count each other).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::occupancy::{GridSpec, Occupancy, PlanPoint, Samples, Settings, path_meets};
use cliff::predict::{BatchMut, Method, Params, TrajectoryBatch, predict, predict_into};
use glam::DVec2;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

/// Allocations made by this thread so far.
fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

fn count() {
    // `try_with`: the thread's counter may be gone while the thread ends
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
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

    let before = allocations();
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
    let after = allocations();
    assert_eq!(
        after - before,
        0,
        "allocations during 600 steady-state predictions"
    );
    // and the work was real
    assert!(batch.lens().iter().any(|&l| l > 0));
}

#[test]
fn steady_state_occupancy_does_not_allocate() {
    let map = CliffMap::demo();
    let agents: Vec<State> = (0..30)
        .map(|i| State {
            position: DVec2::new(-9.0 + 0.6 * i as f64, -1.0 + 0.1 * i as f64),
            speed: 1.2,
            heading: 0.2 * i as f64,
            time: 0.0,
        })
        .collect();
    let params = Params::default();
    let mut batch = TrajectoryBatch::new();
    predict(&map, &agents, &params, &mut batch).unwrap();
    let grid = GridSpec::around([0.0, 0.0], [20.0, 20.0], 0.1);
    let times: Vec<f64> = (1..=30).map(|j| j as f64 * 0.4).collect();
    let plan: Vec<PlanPoint> = (0..=12)
        .map(|j| PlanPoint {
            position: [-6.0 + j as f64, 0.0],
            time: j as f64,
        })
        .collect();
    let settings = Settings::default();
    let mut occupancy = Occupancy::new();
    let mut meets = vec![0.0f32; agents.len()];
    let samples = Samples::from_batch(&batch, params.dt).unwrap();
    // warm-up: sizes the buffers
    occupancy
        .compute(&samples, &grid, &times, &settings)
        .unwrap();
    occupancy
        .window(&samples, &grid, 0.4, 12.0, &settings)
        .unwrap();

    let before = allocations();
    let mut occupied = 0.0f32;
    for seed in 0..3 {
        predict(&map, &agents, &Params { seed, ..params }, &mut batch).unwrap();
        let samples = Samples::from_batch(&batch, params.dt).unwrap();
        occupancy
            .compute(&samples, &grid, &times, &settings)
            .unwrap();
        occupied += occupancy.cells().iter().sum::<f32>();
        occupancy
            .compute(&samples, &grid, &times[..5], &settings)
            .unwrap();
        occupancy
            .compute_agent(&samples, 3, &grid, &times[10..12], &settings)
            .unwrap();
        occupancy
            .window(&samples, &grid, 2.0, 6.0, &settings)
            .unwrap();
        path_meets(&samples, &plan, 0.4, &settings, &mut meets).unwrap();
    }
    let after = allocations();
    assert_eq!(
        after - before,
        0,
        "allocations during steady-state occupancy calls"
    );
    // and the work was real
    assert!(occupied > 100.0, "{occupied}");
}
