//! Predictor benchmarks, single thread, on the real data (the people and maps of
//! `benches/common`).
//!
//! * `thor1_person_k20_30steps`: the THÖR1 person, 20 samples, 12 s at 0.4 s (30 steps),
//!   radius 0.7071, on thor1/cliffmap.csv. The published implementation needs about
//!   34 ms for this; the target is 20 us or less.
//! * `atc_person_k20_50steps`: the ATC dev person (hour 13) with 50 s of ground truth,
//!   20 samples, 50 s at 1 s, radius 1, on atc/cliffmap-20121024.csv.
//! * `cvm_thor1_person`: constant velocity on the THÖR1 person, for scale.
//! * `motion_forecast_thor1_person`: the built-in motion model's forecast of the THÖR1
//!   person from their observed path (the inference alone: features and 60 dot
//!   products); `motion_forecast_thor1_person_network`: the same with a network of the
//!   default size (64 units per layer) correcting the linear part;
//!   `motion_thor1_person_k20_30steps`: the method `motion`, 20 samples of
//!   30 steps from the observed path.
//! * Options (suffixes): `_speed` the speed kernel (speed_beta 1); `_coast` coasting
//!   (4 s) where the map has no data; `_scores` a score per sample
//!   ([`Options::scores`]); `_speed_scores` both; `_all` scores, the speed kernel and
//!   coasting (coasting samples run longer, so more steps than the default);
//!   `_improved` the `improved` preset (two candidates per kept sample resampled at
//!   checkpoints, follow, trust, blend, consensus ranking, scores, speed prior).
//! * Time of day: `atc_person_k20_50steps_set_all_day` on the all-day map of the ATC
//!   time-of-day set (one-hour slices built from atc/train), `..._set_slice` on the
//!   slice of the person's time of day, picked in every call (`MapSet::at`).
//!
//! Run: `cargo bench --bench predict` (the first run builds the ATC set, a few seconds).

use std::hint::black_box;

use cliff::motion::network::INPUTS;
use cliff::motion::{MotionModel, Network, NetworkFit};
use cliff::predict::{
    Method, Options, Params, TrajectoryBatch, predict, predict_with, predict_with_histories,
};
use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec2;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

mod common;
use common::{Person, atc_person, atc_set, thor1_person};

/// The option cases, by suffix.
fn option_cases() -> Vec<(&'static str, Options)> {
    let o = Options::default();
    vec![
        (
            "_speed",
            Options {
                speed_beta: 1.0,
                ..o
            },
        ),
        ("_coast", Options { coast: 4.0, ..o }),
        ("_scores", Options { scores: true, ..o }),
        (
            "_speed_scores",
            Options {
                speed_beta: 1.0,
                scores: true,
                ..o
            },
        ),
        (
            "_all",
            Options {
                speed_beta: 1.0,
                coast: 4.0,
                scores: true,
                ..o
            },
        ),
    ]
}

/// The default case, the option cases and the improved preset of one person.
fn person_cases(c: &mut Criterion, name: &str, p: &Person, seed: &mut u64) {
    let mut batch = TrajectoryBatch::new();
    let agents = std::slice::from_ref(&p.case.start);
    c.bench_function(name, |b| {
        b.iter(|| {
            *seed += 1;
            let params = Params {
                seed: *seed,
                ..p.params
            };
            predict(&p.map, black_box(agents), &params, &mut batch).unwrap();
            black_box(batch.lens()[0])
        })
    });
    for (suffix, opts) in option_cases() {
        c.bench_function(&format!("{name}{suffix}"), |b| {
            b.iter(|| {
                *seed += 1;
                let params = Params {
                    seed: *seed,
                    ..p.params
                };
                predict_with(&p.map, black_box(agents), &params, &opts, &mut batch).unwrap();
                black_box(batch.lens()[0])
            })
        });
    }
    c.bench_function(&format!("{name}_improved"), |b| {
        b.iter(|| {
            *seed += 1;
            let params = Params {
                seed: *seed,
                method: Method::Improved,
                ..p.params
            };
            predict(&p.map, black_box(agents), &params, &mut batch).unwrap();
            black_box(batch.lens()[0])
        })
    });
}

fn bench(c: &mut Criterion) {
    let mut seed = 0u64;
    let thor = thor1_person();
    person_cases(c, "thor1_person_k20_30steps", &thor, &mut seed);
    let mut batch = TrajectoryBatch::new();
    c.bench_function("cvm_thor1_person_k20_30steps", |b| {
        b.iter(|| {
            let params = Params {
                method: Method::Cvm,
                ..thor.params
            };
            predict(
                &thor.map,
                black_box(std::slice::from_ref(&thor.case.start)),
                &params,
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });

    let model = MotionModel::builtin();
    let history = thor.case.history();
    c.bench_function("motion_forecast_thor1_person", |b| {
        b.iter(|| {
            let f = model.forecast(black_box(&history));
            black_box(f.position(4.8, DVec2::ZERO))
        })
    });
    // a model with the largest network `cliff motion fit` makes by default (64 units per
    // layer): the cost does not depend on the weights' values
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0);
    let hidden = NetworkFit::default().hidden;
    let mut values =
        |n: usize| -> Vec<f32> { (0..n).map(|_| rng.random_range(-0.1..0.1)).collect() };
    let outputs = 2 * model.steps();
    let network = Network {
        hidden,
        outputs,
        mean: [0.0; INPUTS],
        scale: [1.0; INPUTS],
        w1: values(INPUTS * hidden),
        b1: values(hidden),
        w2: values(hidden * hidden),
        b2: values(hidden),
        w3: values(hidden * outputs),
        b3: values(outputs),
    };
    let with_network = match std::env::var("CLIFF_BENCH_MOTION") {
        Ok(path) => MotionModel::load(std::path::Path::new(&path)).unwrap(),
        Err(_) => model.clone().with_network(network).unwrap(),
    };
    c.bench_function("motion_forecast_thor1_person_network", |b| {
        b.iter(|| {
            let f = with_network.forecast(black_box(&history));
            black_box(f.position(4.8, DVec2::ZERO))
        })
    });
    c.bench_function("motion_thor1_person_k20_30steps", |b| {
        b.iter(|| {
            let params = Params {
                method: Method::Motion,
                ..thor.params
            };
            predict_with_histories(
                &thor.map,
                black_box(std::slice::from_ref(&thor.case.start)),
                std::slice::from_ref(&history),
                &params,
                &Options::default(),
                &mut batch,
            )
            .unwrap();
            black_box(batch.lens()[0])
        })
    });

    let atc = atc_person();
    person_cases(c, "atc_person_k20_50steps", &atc, &mut seed);

    // time of day: the set's all-day map against the slice picked by the person's time
    let set = atc_set();
    let agents = std::slice::from_ref(&atc.case.start);
    let time = atc.case.start.time;
    c.bench_function("atc_person_k20_50steps_set_all_day", |b| {
        b.iter(|| {
            seed += 1;
            let params = Params { seed, ..atc.params };
            predict(set.all_day(), black_box(agents), &params, &mut batch).unwrap();
            black_box(batch.lens()[0])
        })
    });
    c.bench_function("atc_person_k20_50steps_set_slice", |b| {
        b.iter(|| {
            seed += 1;
            let params = Params { seed, ..atc.params };
            let map = set.at(black_box(time));
            predict(map, black_box(agents), &params, &mut batch).unwrap();
            black_box(batch.lens()[0])
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
