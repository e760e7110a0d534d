//! What the options cost relative to the paper's method, measured side by side.
//!
//! The machines these run on are shared: the load changes from second to second, and
//! criterion's separate runs of two cases can differ by more than the difference being
//! measured. This probe alternates the cases within one process: round after round, a
//! batch of calls of each case (the same person, seeds advancing), and reports per case
//! the median over rounds of the time per call, the median over rounds of its ratio
//! to the default case's time in the same round, and the positions predicted per call
//! (samples stop where the map has no data: an option that keeps them going does more
//! work).
//!
//! Cases (as in `benches/predict.rs`): the THÖR1 person (k 20, 30 steps) and the ATC
//! person (k 20, 50 steps), each with the default options, scores, the speed kernel
//! (speed_beta 1), coasting 4 s, follow 4, scores and the speed kernel, the three of
//! scores, speed kernel and coasting, and the `improved` preset's options.
//!
//! Run: `cargo bench --bench options_cost [-- ROUNDS [CALLS_PER_BATCH]] [CASE ...]`
//! (default 200 rounds of 50 calls; the cases named, beside the default one, or all:
//! scores, speed, coast, follow, speed_scores, all, improved).

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use cliff::eval::dataset::{Format, read_tracks};
use cliff::eval::protocol::{Case, Protocol, Settings, prepare};
use cliff::map::CliffMap;
use cliff::predict::{Options, Params, TrajectoryBatch, predict_with};

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

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    // `cargo bench` passes `--bench`; numbers are ours
    let nums: Vec<usize> = std::env::args().filter_map(|a| a.parse().ok()).collect();
    let rounds = nums.first().copied().unwrap_or(200);
    let calls = nums.get(1).copied().unwrap_or(50);
    // other words name the option cases to run (beside the default one)
    let only: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-') && a.parse::<usize>().is_err())
        .collect();

    let options: Vec<(&str, Options)> = [
        ("default", Options::default()),
        (
            "scores",
            Options {
                scores: true,
                ..Options::default()
            },
        ),
        (
            "speed",
            Options {
                speed_beta: 1.0,
                ..Options::default()
            },
        ),
        (
            "coast",
            Options {
                coast: 4.0,
                ..Options::default()
            },
        ),
        (
            "follow",
            Options {
                follow: 4.0,
                ..Options::default()
            },
        ),
        (
            "speed_scores",
            Options {
                speed_beta: 1.0,
                scores: true,
                ..Options::default()
            },
        ),
        (
            "all",
            Options {
                speed_beta: 1.0,
                coast: 4.0,
                scores: true,
                ..Options::default()
            },
        ),
        (
            // what the improved preset asks for (its beta 2 costs nothing more)
            "improved",
            Options {
                follow: 4.0,
                candidates: 5,
                speed_prior: true,
                scores: true,
                ..Options::default()
            },
        ),
    ]
    .into_iter()
    .enumerate()
    .filter(|(i, (name, _))| *i == 0 || only.is_empty() || only.iter().any(|o| o == name))
    .map(|(_, case)| case)
    .collect();

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

    println!("{rounds} rounds of {calls} calls per case, alternating");
    println!(
        "{:<36} {:>12} {:>12} {:>10}",
        "case", "median us", "vs default", "positions"
    );
    for (name, map, case, params) in [
        ("thor1_person_k20_30steps", &thor_map, &thor, thor_params),
        ("atc_person_k20_50steps", &atc_map, &atc, atc_params),
    ] {
        let mut batch = TrajectoryBatch::new();
        let mut seed = 0u64;
        let mut times = vec![Vec::with_capacity(rounds); options.len()];
        // positions predicted per call (samples end where the map has no data)
        let mut positions = vec![0u64; options.len()];
        for _ in 0..rounds {
            for (i, (_, opts)) in options.iter().enumerate() {
                let t0 = Instant::now();
                for _ in 0..calls {
                    seed += 1;
                    predict_with(
                        map,
                        black_box(std::slice::from_ref(&case.start)),
                        &Params { seed, ..params },
                        opts,
                        &mut batch,
                    )
                    .unwrap();
                    positions[i] += batch.lens().iter().map(|&l| l as u64).sum::<u64>();
                }
                times[i].push(t0.elapsed().as_secs_f64() * 1e6 / calls as f64);
            }
        }
        for (i, (label, _)) in options.iter().enumerate() {
            let mut ratios: Vec<f64> = times[i].iter().zip(&times[0]).map(|(t, d)| t / d).collect();
            println!(
                "{:<36} {:>12.2} {:>12.3} {:>10.1}",
                format!("{name}_{label}"),
                median(&mut times[i].clone()),
                median(&mut ratios),
                positions[i] as f64 / (rounds * calls) as f64
            );
        }
    }
}
