//! Many people in one in-process call, on one core and on all: `predict_batch` over
//! 1,000 ATC people (the atc/dev people the seconds protocol takes, repeated in order
//! to 1,000; each place in the call draws anew), k 20, 50 s at 1 s, radius 1, the
//! paper's method, in rayon pools of 1 and 2 threads (or the threads named),
//! alternating round by round. Prints per pool the median time per call, people per
//! second, and the median ratio of the 1-thread time to its time in the same round.
//! The results are the same bytes on every pool (checked once).
//!
//! Run: `cargo bench --bench batch [-- ROUNDS [THREADS...]]` (default 20 rounds, pools
//! of 1 and 2 threads; `improved` as a word runs the `improved` method).

use std::time::Instant;

use cliff::eval::protocol::{Protocol, Settings, prepare};
use cliff::motion::State;
use cliff::predict::{Method, Options, TrajectoryBatch, predict_batch};
use cliff::tracks::{Format, read_many};

mod common;
use common::{atc_person, data};

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
    let nums: Vec<usize> = std::env::args().filter_map(|a| a.parse().ok()).collect();
    let rounds = nums.first().copied().unwrap_or(20);
    let mut threads: Vec<usize> = nums.iter().skip(1).copied().collect();
    if threads.is_empty() {
        threads = vec![1, 2];
    }
    let improved = std::env::args().any(|a| a == "improved");
    let atc = atc_person();
    let settings = Settings {
        protocol: Protocol::Seconds,
        obs: 3.2,
        dt: 1.0,
        horizon: 50.0,
        ..Settings::default()
    };
    let files: Vec<_> = std::fs::read_dir(data("atc/dev"))
        .expect("atc/dev")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    let mut files = files;
    files.sort();
    let tracks = read_many(&files, Format::Atc).expect("atc/dev tracks");
    let found: Vec<State> = tracks
        .iter()
        .filter_map(|t| prepare(t, &settings))
        .map(|c| c.start)
        .collect();
    let people: Vec<State> = found.iter().cycle().take(1000).copied().collect();
    let params = cliff::predict::Params {
        method: if improved {
            Method::Improved
        } else {
            Method::Cliff
        },
        ..atc.params
    };
    let pools: Vec<rayon::ThreadPool> = threads
        .iter()
        .map(|&n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        })
        .collect();
    println!(
        "{} people ({} distinct), {} k {} {} steps, {rounds} rounds, pools of {threads:?} threads, {}",
        people.len(),
        found.len(),
        params.method,
        params.k,
        params.steps(),
        cliff::math::Simd::active().name()
    );
    let opts = Options::default();
    let mut reference: Option<Vec<u32>> = None;
    let mut times = vec![Vec::new(); pools.len()];
    let mut batch = TrajectoryBatch::new();
    for r in 0..=rounds {
        for (i, pool) in pools.iter().enumerate() {
            let t0 = Instant::now();
            pool.install(|| predict_batch(&atc.map, &people, &params, &opts, &mut batch))
                .unwrap();
            let t = t0.elapsed().as_secs_f64();
            if r == 0 {
                // warm-up round: check the bytes
                let bits: Vec<u32> = batch
                    .positions()
                    .iter()
                    .flatten()
                    .map(|v| v.to_bits())
                    .collect();
                match &reference {
                    None => reference = Some(bits),
                    Some(b) => assert!(b == &bits, "{} threads: other bytes", threads[i]),
                }
            } else {
                times[i].push(t);
            }
        }
    }
    println!(
        "{:>8} {:>12} {:>14} {:>16}",
        "threads", "median ms", "people/s", "speed-up vs 1st"
    );
    for (i, n) in threads.iter().enumerate() {
        let mut ratio: Vec<f64> = times[0].iter().zip(&times[i]).map(|(a, b)| a / b).collect();
        let m = median(&mut times[i].clone());
        println!(
            "{:>8} {:>12.2} {:>14.0} {:>16.3}",
            n,
            m * 1e3,
            people.len() as f64 / m,
            median(&mut ratio)
        );
    }
}
