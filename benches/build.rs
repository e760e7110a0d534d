//! Map building on real data: all of ATC train (about 555,000 rows, 1 m grid, radius
//! 1 m), one hour of it, and an hourly online update.
//!
//! Run: `cargo bench --bench build` (reads ../shared/data/atc).

use std::path::{Path, PathBuf};
use std::time::Duration;

use cliff::map::build::{BuildParams, Observation, build_map, observations_from_tracks};
use cliff::map::update::{OnlineMap, UpdateParams};
use cliff::tracks::{Format, read_many};
use criterion::{Criterion, criterion_group, criterion_main};

fn train(hours: &[u32]) -> Vec<Observation> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/atc/train");
    let files: Vec<PathBuf> = hours
        .iter()
        .map(|h| dir.join(format!("atc-1024-{h}_train.csv")))
        .collect();
    observations_from_tracks(&read_many(&files, Format::Atc).expect("ATC train data"))
}

fn bench(c: &mut Criterion) {
    let params = BuildParams::default();
    let all = train(&[9, 10, 11, 13, 14, 15, 16, 17, 18, 19, 20]);
    let hour13 = train(&[13]);
    let hour14 = train(&[14]);
    let mut g = c.benchmark_group("build");
    g.sample_size(10).measurement_time(Duration::from_secs(60));
    g.bench_function("atc_train_all_1m", |b| {
        b.iter(|| build_map(&all, &params).unwrap())
    });
    g.bench_function("atc_hour13_1m", |b| {
        b.iter(|| build_map(&hour13, &params).unwrap())
    });
    let start = OnlineMap::build(&hour13, &params, UpdateParams::default()).unwrap();
    g.bench_function("atc_update_hour14", |b| {
        b.iter_batched(
            || start.clone(),
            |mut m| m.update(&hour14).unwrap(),
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
