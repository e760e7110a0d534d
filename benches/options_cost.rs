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
//! Every case runs on the baseline instructions and, where the processor has them, on
//! AVX2 + FMA (`cliff::math::Simd`; the `_avx2` rows), alternating in the same rounds:
//! `vs default` is the ratio to the baseline default case, `vs path's` the ratio to the
//! default case on the same path.
//!
//! Run: `cargo bench --bench options_cost [-- ROUNDS [CALLS_PER_BATCH]] [CASE ...]`
//! (default 200 rounds of 50 calls; the cases named, beside the default one, or all:
//! scores, speed, coast, follow, speed_scores, all, improved (the preset's options),
//! improved_unpruned (the same without [`Options::prune`]); `baseline` runs the
//! baseline path alone, `avx2` the AVX2 + FMA path alone (for profilers); `thor1` or
//! `atc` that person alone).

use std::hint::black_box;
use std::time::Instant;

use cliff::map::CliffMap;
use cliff::math::Simd;
use cliff::motion::State;
use cliff::predict::preset::IMPROVED;
use cliff::predict::{Options, Params, Rollout, TrajectoryBatch};

mod common;
use common::{atc_person, atc_set, thor1_person};

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
    let mut only: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-') && a.parse::<usize>().is_err())
        .collect();
    let baseline_only = only.iter().any(|o| o == "baseline");
    let avx2_only = only.iter().any(|o| o == "avx2");
    // `thor1` or `atc`: that person alone
    let person = only.iter().find(|o| *o == "thor1" || *o == "atc").cloned();
    only.retain(|o| !["baseline", "avx2", "thor1", "atc"].contains(&o.as_str()));
    let paths: Vec<Simd> = if baseline_only || !Simd::Avx2Fma.available() {
        vec![Simd::Baseline]
    } else if avx2_only {
        vec![Simd::Avx2Fma]
    } else {
        vec![Simd::Baseline, Simd::Avx2Fma]
    };

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
        // what the improved preset asks for (its beta 2 costs nothing more)
        ("improved", IMPROVED.options),
        // the same with every candidate rolled to the horizon
        (
            "improved_unpruned",
            Options {
                prune: false,
                ..IMPROVED.options
            },
        ),
    ]
    .into_iter()
    .enumerate()
    .filter(|(i, (name, _))| *i == 0 || only.is_empty() || only.iter().any(|o| o == name))
    .map(|(_, case)| case)
    .collect();

    let thor = thor1_person();
    let atc = atc_person();

    println!("{rounds} rounds of {calls} calls per case, alternating");
    println!(
        "{:<42} {:>10} {:>11} {:>11} {:>10}",
        "case", "median us", "vs default", "vs path's", "positions"
    );
    for (name, map, case, params) in [
        (
            "thor1_person_k20_30steps",
            &thor.map,
            &thor.case,
            thor.params,
        ),
        ("atc_person_k20_50steps", &atc.map, &atc.case, atc.params),
    ] {
        if person.as_deref().is_some_and(|p| !name.starts_with(p)) {
            continue;
        }
        let cases: Vec<(String, Case<'_>)> = paths
            .iter()
            .flat_map(|&simd| {
                options.iter().map(move |(label, opts)| {
                    let path = if simd == Simd::Baseline { "" } else { "_avx2" };
                    (
                        format!("{name}_{label}{path}"),
                        (map, &case.start, params, *opts, simd),
                    )
                })
            })
            .collect();
        alternate(rounds, calls, &cases);
    }

    // Time of day: the ATC person on the benchmark's map, on the all-day map of the ATC
    // set, and on the slice of the person's time of day (picked in every call).
    if only.is_empty() || only.iter().any(|o| o == "slice") {
        let set = atc_set();
        let slice = set.at(atc.case.start.time);
        let o = Options::default();
        let cases = [
            ("atc_person_k20_50steps_csv_map", &atc.map),
            ("atc_person_k20_50steps_set_all_day", set.all_day().as_ref()),
            ("atc_person_k20_50steps_set_slice", slice.as_ref()),
        ]
        .map(|(label, map)| {
            (
                label.to_string(),
                (map, &atc.case.start, atc.params, o, Simd::active()),
            )
        });
        // (the slice case picks its map through the set in every call)
        alternate_with(rounds, calls, &cases, |i, _| match i {
            2 => set.at(black_box(atc.case.start.time)),
            _ => cases[i].1.0,
        });
    }
}

/// One case: the map, the person, the parameters, the options and the path.
type Case<'a> = (&'a CliffMap, &'a State, Params, Options, Simd);

/// Run the cases alternately and print per case the median time per call, the median
/// ratio to the first case's time in the same round, and the positions per call.
fn alternate(rounds: usize, calls: usize, cases: &[(String, Case<'_>)]) {
    alternate_with(rounds, calls, cases, |i, _| cases[i].1.0);
}

/// [`alternate`], the map of case `i` given by `map_of(i, seed)`.
fn alternate_with<'a>(
    rounds: usize,
    calls: usize,
    cases: &[(String, Case<'a>)],
    map_of: impl Fn(usize, u64) -> &'a CliffMap,
) {
    let mut batch = TrajectoryBatch::new();
    let mut scores = Vec::new();
    let mut seed = 0u64;
    let mut times = vec![Vec::with_capacity(rounds); cases.len()];
    // positions predicted per call (samples end where the map has no data)
    let mut positions = vec![0u64; cases.len()];
    for _ in 0..rounds {
        for (i, (_, (_, start, params, opts, simd))) in cases.iter().enumerate() {
            batch.reshape(1, params.k, params.steps());
            scores.resize(params.k, 0.0f32);
            let t0 = Instant::now();
            for _ in 0..calls {
                seed += 1;
                // what `predict_with` does, on the case's path
                let mut rollout = Rollout::new(&Params { seed, ..*params })
                    .unwrap()
                    .with_options(*opts)
                    .unwrap()
                    .with_simd(*simd);
                let scored = rollout.options().scores;
                rollout
                    .predict_agents(
                        map_of(i, seed),
                        black_box(std::slice::from_ref(*start)),
                        batch.as_mut(),
                        scored.then_some(&mut scores[..]),
                    )
                    .unwrap();
                positions[i] += batch.lens().iter().map(|&l| l as u64).sum::<u64>();
            }
            times[i].push(t0.elapsed().as_secs_f64() * 1e6 / calls as f64);
        }
    }
    // each path's default case: the first case of that path
    let path_default = |i: usize| {
        let simd = cases[i].1.4;
        cases.iter().position(|c| c.1.4 == simd).unwrap()
    };
    for (i, (label, _)) in cases.iter().enumerate() {
        let ratio_to = |d: usize| {
            let mut r: Vec<f64> = times[i].iter().zip(&times[d]).map(|(t, d)| t / d).collect();
            median(&mut r)
        };
        println!(
            "{:<42} {:>10.2} {:>11.3} {:>11.3} {:>10.1}",
            label,
            median(&mut times[i].clone()),
            ratio_to(0),
            ratio_to(path_default(i)),
            positions[i] as f64 / (rounds * calls) as f64
        );
    }
}
