//! Occupancy from a prediction's samples, single thread, on real people.
//!
//! The scene: the first 30 people of THÖR1's exp-1-run-2 that pass the reference
//! filter, each predicted with the paper's method (k 20, 12 s at 0.4 s, 30 steps,
//! radius 0.7071, seed 0) on thor1/cliffmap.csv; the grid: 20 x 20 m at 0.1 m
//! (200 x 200 cells) centred on the people's mean start. The default
//! [`Settings`] (a person of 0.3 m, Silverman's bandwidth, cut at 3 sigmas).
//!
//! * `occupancy_30people_k20_30times_200x200`: [`Occupancy::compute`] at all 30 step
//!   times (the target is 2 ms or less on one core).
//! * `occupancy_window_30people_0_to_12s_200x200`: [`Occupancy::window`] over the whole
//!   horizon (read at every half step).
//! * `path_meets_30people_13points`: [`path_meets`] for a 12 s plan of 13 points
//!   crossing the room.
//!
//! The buffer is reused, so no call allocates (`tests/no_alloc.rs` checks that).
//!
//! Run: `cargo bench --bench occupancy`. With `OCCUPANCY_CALLS=N` (and
//! `OCCUPANCY_CALL=window` for the window) the bench instead makes N calls of
//! `compute` on the scene and exits, for `perf stat -e task-clock` on the bench's
//! binary; the CPU time per call is the difference from `OCCUPANCY_CALLS=0` over N.

use std::hint::black_box;

use cliff::eval::protocol::{Settings as Protocol, prepare};
use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::occupancy::{GridSpec, Occupancy, PlanPoint, Samples, Settings, path_meets};
use cliff::predict::{Params, TrajectoryBatch, predict};
use cliff::tracks::{Format, read_tracks};
use criterion::{Criterion, criterion_group, criterion_main};

mod common;
use common::data;

fn bench(c: &mut Criterion) {
    let map = CliffMap::load(data("thor1/cliffmap.csv")).expect("THÖR1 map");
    let tracks = read_tracks(&data("thor1/exp-1-run-2.csv"), Format::Thor).expect("tracks");
    let people: Vec<State> = tracks
        .iter()
        .filter_map(|t| prepare(t, &Protocol::default()))
        .map(|c| c.start)
        .take(30)
        .collect();
    assert_eq!(people.len(), 30, "30 people pass the filter");
    let params = Params {
        k: 20,
        dt: 0.4,
        horizon: 12.0,
        radius: 0.7071,
        ..Params::default()
    };
    let mut batch = TrajectoryBatch::new();
    predict(&map, &people, &params, &mut batch).expect("prediction");
    let n = people.len() as f64;
    let centre = people.iter().fold([0.0, 0.0], |a, p| {
        [a[0] + p.position.x / n, a[1] + p.position.y / n]
    });
    let grid = GridSpec::around(centre, [20.0, 20.0], 0.1);
    let times: Vec<f64> = (1..=30).map(|j| j as f64 * 0.4).collect();
    let settings = Settings::default();
    let samples = Samples::from_batch(&batch, params.dt).expect("samples");
    let mut occupancy = Occupancy::new();
    if let Ok(calls) = std::env::var("OCCUPANCY_CALLS") {
        let calls: usize = calls.parse().expect("OCCUPANCY_CALLS is a number of calls");
        let window = std::env::var("OCCUPANCY_CALL").is_ok_and(|c| c == "window");
        for _ in 0..calls {
            if window {
                occupancy.window(black_box(&samples), &grid, 0.4, 12.0, &settings)
            } else {
                occupancy.compute(black_box(&samples), &grid, &times, &settings)
            }
            .unwrap();
            black_box(occupancy.cells()[0]);
        }
        std::process::exit(0);
    }

    c.bench_function("occupancy_30people_k20_30times_200x200", |b| {
        b.iter(|| {
            occupancy
                .compute(black_box(&samples), &grid, &times, &settings)
                .unwrap();
            black_box(occupancy.cells()[0])
        })
    });
    c.bench_function("occupancy_window_30people_0_to_12s_200x200", |b| {
        b.iter(|| {
            occupancy
                .window(black_box(&samples), &grid, 0.4, 12.0, &settings)
                .unwrap();
            black_box(occupancy.cells()[0])
        })
    });
    let plan: Vec<PlanPoint> = (0..=12)
        .map(|j| PlanPoint {
            position: [centre[0] - 6.0 + j as f64, centre[1]],
            time: j as f64,
        })
        .collect();
    let mut meets = vec![0.0f32; people.len()];
    c.bench_function("path_meets_30people_13points", |b| {
        b.iter(|| {
            path_meets(black_box(&samples), &plan, 0.4, &settings, &mut meets).unwrap();
            black_box(meets[0])
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
