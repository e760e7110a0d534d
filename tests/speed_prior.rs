//! The speed prior on real data: fitted on ATC's training hours, it predicts the speed
//! ahead of the held-out people of atc/dev better than their observed speed does.

use std::path::{Path, PathBuf};

use cliff::eval::protocol::{Protocol, Settings, prepare_all};
use cliff::motion::SpeedPrior;
use cliff::tracks::{Format, read_many};

fn files(dir: &str) -> Vec<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(dir);
    let mut v: Vec<PathBuf> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    v.sort();
    v
}

#[test]
fn the_prior_from_atc_train_predicts_held_out_speeds_better_than_the_observed_speed() {
    let train = read_many(&files("atc/train"), Format::Atc).unwrap();
    let prior = SpeedPrior::fit(&train, 3.2, 1.0).expect("enough walkers");
    // people walk on at a typical speed: a clear pull, not none and not all
    assert!(prior.keep > 0.4 && prior.keep < 0.9, "{prior:?}");
    assert!(prior.mean > 0.9 && prior.mean < 1.6, "{prior:?}");
    assert!(prior.pairs > 5000, "{prior:?}");

    // held out: the people of atc/dev with 50 s ahead, as `cliff eval` takes them
    let dev = read_many(&files("atc/dev"), Format::Atc).unwrap();
    let s = Settings {
        protocol: Protocol::Seconds,
        obs: 3.2,
        dt: 1.0,
        horizon: 50.0,
        full_horizon_only: true,
        ..Settings::default()
    };
    let cases = prepare_all(&dev, &s);
    assert!(cases.len() > 50, "{} people", cases.len());
    let (mut err_obs, mut err_prior) = (0.0, 0.0);
    for c in &cases {
        // the mean speed along the path over the next 50 s, from the rows
        let mut prev = c.start.position;
        let mut length = 0.0;
        for r in c
            .future
            .iter()
            .filter(|r| r.t > c.start.time && r.t <= c.start.time + 50.0)
        {
            length += r.position.distance(prev);
            prev = r.position;
        }
        let ahead = length / 50.0;
        err_obs += (c.start.speed - ahead).abs();
        err_prior += (prior.apply(c.start.speed) - ahead).abs();
    }
    let n = cases.len() as f64;
    let (err_obs, err_prior) = (err_obs / n, err_prior / n);
    assert!(
        err_prior < 0.97 * err_obs,
        "mean speed error {err_prior:.3} m/s with the prior, {err_obs:.3} m/s observed ({prior:?})"
    );
    eprintln!("{prior:?}: {err_obs:.3} -> {err_prior:.3} m/s on {n} people");
}
