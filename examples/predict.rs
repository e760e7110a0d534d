//! CLiFF-LHMP as the paper has it: twenty samples of where a walker will be, on the
//! built-in demo map (no files needed).
//!
//! Run: `cargo run --release --example predict`

use cliff::map::CliffMap;
use cliff::motion::State;
use cliff::predict::{Params, TrajectoryBatch, predict};
use glam::DVec2;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // a hall with crossing flows; load a real one with `CliffMap::load("map.csv")`
    let map = CliffMap::demo();
    // a walker at (-10, 0.5) heading east (0 rad) at 1.2 m/s
    let walker = State {
        position: DVec2::new(-10.0, 0.5),
        speed: 1.2,
        heading: 0.0,
        time: 0.0,
    };
    // 20 samples, 12 s ahead in steps of 0.4 s (the paper's THÖR setting)
    let params = Params {
        k: 20,
        horizon: 12.0,
        dt: 0.4,
        seed: 1,
        ..Params::default()
    };
    let mut out = TrajectoryBatch::new();
    predict(&map, &[walker], &params, &mut out)?;

    // A sample stops where the map has no location near (the paper's rule): its
    // length says how far it got; the rest of its positions are NaN.
    for s in 0..params.k {
        let len = out.lens()[s] as usize;
        let track = out.sample(0, s);
        match track[..len].last() {
            Some([x, y]) => println!("sample {s:2}: {len:2} steps, ends at ({x:6.2}, {y:6.2}) m"),
            None => println!("sample {s:2}: no step on the map"),
        }
    }
    Ok(())
}
