//! The `improved` preset and ranked samples: every sample gets a score (the
//! log-likelihood of its steps under the map), and the best-ranked one is the
//! prediction to act on when one trajectory is wanted.
//!
//! Run: `cargo run --release --example ranked_samples`

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::predict::{Method, Options, Params, TrajectoryBatch, predict_with};
use glam::DVec2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let map = CliffMap::demo();
    let walkers = [
        State {
            position: DVec2::new(-10.0, 0.5),
            speed: 1.2,
            heading: 0.0,
            time: 0.0,
        },
        State {
            position: DVec2::new(2.0, -8.0),
            speed: 1.0,
            heading: 1.5,
            time: 0.0,
        },
    ];
    let params = Params {
        k: 10,
        horizon: 8.0,
        seed: 3,
        ..Params::default()
    };

    // The paper's method with scores asked for: the same samples, each with a score.
    let scored = Options {
        scores: true,
        ..Options::default()
    };
    let mut paper = TrajectoryBatch::new();
    predict_with(&map, &walkers, &params, &scored, &mut paper)?;

    // The improved preset (beta 2, follow 4, 5 candidates per kept sample, the map's
    // speed prior when it has one; always scored): its options replace the call's.
    let improved = Params {
        method: Method::Improved,
        ..params
    };
    let mut best = TrajectoryBatch::new();
    predict_with(&map, &walkers, &improved, &Options::default(), &mut best)?;

    for (a, _) in walkers.iter().enumerate() {
        for (name, batch) in [("paper", &paper), ("improved", &best)] {
            let s = batch.best_sample(a).expect("scored");
            let score = batch.scores()[a * params.k + s];
            let len = batch.lens()[a * params.k + s] as usize;
            if let Some([x, y]) = batch.sample(a, s)[..len].last() {
                println!(
                    "walker {a}, {name:8}: best sample {s} (score {score:7.1}), \
                     {len} steps, ends at ({x:6.2}, {y:6.2}) m"
                );
            }
        }
    }
    Ok(())
}
