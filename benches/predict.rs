//! Predictor benchmarks, single thread, on the real data.
//!
//! * `thor1_person`: the first THÖR1 person that passes the reference filter, 20 samples,
//!   12 s at 0.4 s (30 steps), radius 0.7071, on thor1/cliffmap.csv. The published
//!   implementation needs about 34 ms for this; the target is 20 us or less.
//! * `atc_person`: the first ATC dev person (hour 13, seconds protocol) with 50 s of
//!   ground truth, 20 samples, 50 s at 1 s, radius 1, on atc/cliffmap-20121024.csv.
//! * `cvm_thor1_person`: constant velocity on the THÖR1 person, for scale.
//! * `..._coast`: the same with coasting (4 s) where the map has no data, no scores;
//!   `..._scores`: with a score per sample ([`Options::scores`]); `..._speed_scores`
//!   also with the speed kernel (speed_beta 1); `..._all`: scores, the speed kernel and
//!   coasting (4 s; coasting samples run longer, so more steps than the default).
//!
//! Run: `cargo bench --bench predict`

use std::hint::black_box;
use std::path::{Path, PathBuf};

use cliff::eval::dataset::{Format, read_tracks};
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::map::CliffMap;
use cliff::predict::{Method, Options, Params, TrajectoryBatch, predict, predict_with};
use criterion::{Criterion, criterion_group, criterion_main};

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(p)
}

fn first_case(tracks: &str, format: Format, settings: &Settings, min_steps: usize) -> Case {
    read_tracks(&data(tracks), format)
        .expect("tracks")
        .iter()
        .filter_map(|t| prepare(t, settings))
        .find(|c| c.steps >= min_steps)
        .expect("a person that passes the filter")
}

fn bench(c: &mut Criterion) {
    let thor_map = CliffMap::load(data("thor1/cliffmap.csv")).unwrap();
    let thor = first_case(
        "thor1/exp-1-run-2.csv",
        Format::Thor,
        &Settings::default(),
        1,
    );
    let thor_params = Params {
        k: 20,
        dt: 0.4,
        horizon: 12.0,
        radius: 0.7071,
        beta: 1.0,
        ..Params::default()
    };
    let mut batch = TrajectoryBatch::new();
    let mut seed = 0u64;
    c.bench_function("thor1_person_k20_30steps", |b| {
        b.iter(|| {
            seed += 1;
            predict(
                &thor_map,
                black_box(std::slice::from_ref(&thor.start)),
                &Params {
                    seed,
                    ..thor_params
                },
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });
    let scores = Options {
        scores: true,
        ..Options::default()
    };
    let speed_scores = Options {
        speed_beta: 1.0,
        scores: true,
        ..Options::default()
    };
    let all = Options {
        speed_beta: 1.0,
        coast: 4.0,
        scores: true,
        ..Options::default()
    };
    let coast = Options {
        coast: 4.0,
        ..Options::default()
    };
    for (name, opts) in [
        ("thor1_person_k20_30steps_coast", coast),
        ("thor1_person_k20_30steps_scores", scores),
        ("thor1_person_k20_30steps_speed_scores", speed_scores),
        ("thor1_person_k20_30steps_all", all),
    ] {
        c.bench_function(name, |b| {
            b.iter(|| {
                seed += 1;
                predict_with(
                    &thor_map,
                    black_box(std::slice::from_ref(&thor.start)),
                    &Params {
                        seed,
                        ..thor_params
                    },
                    &opts,
                    &mut batch,
                )
                .unwrap();
                black_box(batch.lens()[0])
            })
        });
    }
    c.bench_function("cvm_thor1_person_k20_30steps", |b| {
        b.iter(|| {
            predict(
                &thor_map,
                black_box(std::slice::from_ref(&thor.start)),
                &Params {
                    method: Method::Cvm,
                    ..thor_params
                },
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });

    let atc_map = CliffMap::load(data("atc/cliffmap-20121024.csv")).unwrap();
    let atc_settings = Settings {
        protocol: Protocol::Seconds,
        obs: 3.2,
        dt: 1.0,
        horizon: 50.0,
        ..Settings::default()
    };
    let atc = first_case(
        "atc/dev/atc-1024-13_test.csv",
        Format::Atc,
        &atc_settings,
        50,
    );
    let atc_params = Params {
        k: 20,
        dt: 1.0,
        horizon: 50.0,
        radius: 1.0,
        beta: 1.0,
        ..Params::default()
    };
    c.bench_function("atc_person_k20_50steps", |b| {
        b.iter(|| {
            seed += 1;
            predict(
                &atc_map,
                black_box(std::slice::from_ref(&atc.start)),
                &Params { seed, ..atc_params },
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });
    for (name, opts) in [
        ("atc_person_k20_50steps_scores", scores),
        ("atc_person_k20_50steps_speed_scores", speed_scores),
        ("atc_person_k20_50steps_all", all),
    ] {
        c.bench_function(name, |b| {
            b.iter(|| {
                seed += 1;
                predict_with(
                    &atc_map,
                    black_box(std::slice::from_ref(&atc.start)),
                    &Params { seed, ..atc_params },
                    &opts,
                    &mut batch,
                )
                .unwrap();
                black_box(batch.lens()[0])
            })
        });
    }
    // the improved preset: five candidates per kept sample, follow, scores
    c.bench_function("atc_person_k20_50steps_improved", |b| {
        b.iter(|| {
            seed += 1;
            predict_with(
                &atc_map,
                black_box(std::slice::from_ref(&atc.start)),
                &Params {
                    seed,
                    method: Method::Improved,
                    ..atc_params
                },
                &Options::default(),
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
