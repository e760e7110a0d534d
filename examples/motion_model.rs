//! The learned motion model: fitted on a site's first 16 minutes of tracks, it forecasts
//! a person of the next minutes from their last 2.8 s, without a map; `motion` samples
//! spread around the expected path.
//!
//! Run: `cargo run --release --example motion_model` (reads `../shared/data`)

use std::sync::Arc;

use cliff::map::CliffMap;
use cliff::motion::{History, MotionFit, State, fit_motion_model};
use cliff::predict::{Method, Options, Params, Rollout, TrajectoryBatch};
use cliff::tracks::{Format, read_tracks};
use glam::DVec2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let file = "../shared/data/magni/magni-A.csv";
    let mut first = read_tracks(file.as_ref(), Format::Magni)?;
    let later = first.clone();
    for t in &mut first {
        t.rows.retain(|r| r.t < 960.0);
    }
    // ridge regression in the walker's frame: 12 s ahead in 0.4 s steps
    let model = fit_motion_model(&first, &MotionFit::default())?;
    println!(
        "fitted on {} windows: {} steps",
        model.info().windows,
        model.steps()
    );

    // a person of the later minutes: their last 2.8 s of rows
    let track = &later[0];
    let i = track.rows.partition_point(|r| r.t < 1200.0);
    let rows = &track.rows[i - 8..i];
    let history = History::from_rows(rows)?;
    let last = rows[7];
    let forecast = model.forecast(&history);
    let ahead = forecast.position(4.8, DVec2::ZERO);
    println!(
        "person {} at ({:.2}, {:.2}): expected 4.8 s ahead at ({:.2}, {:.2})",
        track.id, last.position.x, last.position.y, ahead.x, ahead.y
    );

    // the same as a prediction: 20 samples, the first the expected path
    let state = State {
        position: last.position,
        speed: last.speed,
        heading: last.angle,
        time: last.t,
    };
    let params = Params {
        method: Method::Motion,
        k: 20,
        horizon: 4.8,
        ..Params::default()
    };
    let options = Options {
        scores: true,
        ..Options::default()
    };
    let mut batch = TrajectoryBatch::new();
    Rollout::new(&params)?
        .with_options(options)?
        .with_motion_model(Arc::new(model))
        .predict_batch(&CliffMap::demo(), &[state], Some(&[history]), &mut batch)?;
    let end = batch
        .sample(0, 0)
        .last()
        .expect("every motion sample reaches the horizon");
    assert!((end[0] as f64 - ahead.x).abs() < 1e-3 && (end[1] as f64 - ahead.y).abs() < 1e-3);
    let spread = (1..20)
        .map(|s| {
            let p = batch.sample(0, s).last().unwrap();
            DVec2::new(p[0] as f64, p[1] as f64).distance(ahead)
        })
        .sum::<f64>()
        / 19.0;
    println!(
        "best-ranked sample {}, the others end {spread:.2} m from it on average",
        batch.best_sample(0).unwrap()
    );
    Ok(())
}
