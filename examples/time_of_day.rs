//! A time-of-day map set: one map per hour, each smoothed towards its neighbours and the
//! all-day map, and the prediction made on the hour of the observation. Synthetic
//! corridor traffic goes east in the morning and west in the afternoon; a walker who
//! crosses the corridor is pulled east at 10:30 and west at 13:30, and both ways by the
//! all-day map.
//!
//! Run: `cargo run --release --example time_of_day` (builds the set: a few seconds)

use cliff::map::build::{BuildParams, Observation};
use cliff::map::{CliffMap, SliceParams, build_map_set};
use cliff::math::wrap_2pi;
use cliff::motion::State;
use cliff::predict::{Params, TrajectoryBatch, predict};
use glam::DVec2;

const HOUR: f64 = 3600.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Tracks along a corridor (x from -10 to 10 m, y within 3 m of 0), one row a second,
    // with time of day as the timestamp (a dataset in unix time sets a clock offset).
    let (mut obs, mut times) = (Vec::new(), Vec::new());
    for hour in 9..15 {
        let east = hour < 12;
        for person in 0..30 {
            let start = hour as f64 * HOUR + 100.0 * person as f64;
            let y = -3.0 + 6.0 * (person as f64 + 0.5) / 30.0;
            // each walker a little faster or slower, swaying a little
            let speed = 1.0 + 0.4 * ((person * 7) % 10) as f64 / 10.0;
            for i in 0..(20.0 / speed) as usize {
                let along = -10.0 + speed * i as f64;
                let sway = 0.1 * (1.7 * i as f64 + 0.9 * person as f64).sin();
                let heading = if east { 0.0 } else { std::f64::consts::PI };
                obs.push(Observation {
                    position: DVec2::new(if east { along } else { -along }, y),
                    theta: wrap_2pi(heading + sway),
                    rho: speed,
                });
                times.push(start + i as f64);
            }
        }
    }
    let slicing = SliceParams {
        slice_length: HOUR,
        clock_offset: 0.0,
        ..SliceParams::default()
    };
    let set = build_map_set(&obs, &times, &BuildParams::default(), &slicing)?.set;

    for (label, map) in [
        ("10:30", set.at(10.5 * HOUR)),
        ("13:30", set.at(13.5 * HOUR)),
        ("all day", set.all_day()),
    ] {
        let (x, east, west) = crossing(map)?;
        println!(
            "{label:>7}: mean x after 8 s {x:5.2} m; {:3.0} % of the samples east of 2 m, {:3.0} % west of -2 m",
            100.0 * east,
            100.0 * west
        );
    }
    Ok(())
}

/// A walker at the corridor's centre heading north, 8 s ahead (beta 0.1: the heading
/// turns readily to the map's directions): the samples' mean x and the shares east and
/// west.
fn crossing(map: &CliffMap) -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
    let walker = State {
        position: DVec2::ZERO,
        speed: 1.2,
        heading: std::f64::consts::FRAC_PI_2,
        time: 0.0,
    };
    let params = Params {
        k: 200,
        horizon: 8.0,
        dt: 0.4,
        beta: 0.1,
        seed: 5,
        ..Params::default()
    };
    let mut out = TrajectoryBatch::new();
    predict(map, &[walker], &params, &mut out)?;
    let ends: Vec<f32> = (0..params.k)
        .filter_map(|s| {
            let len = out.lens()[s] as usize;
            out.sample(0, s)[..len].last().map(|p| p[0])
        })
        .collect();
    let n = ends.len().max(1) as f64;
    let mean = ends.iter().map(|&x| x as f64).sum::<f64>() / n;
    let share = |f: &dyn Fn(f32) -> bool| ends.iter().filter(|&&x| f(x)).count() as f64 / n;
    Ok((mean, share(&|x| x > 2.0), share(&|x| x < -2.0)))
}
