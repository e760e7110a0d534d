//! Evaluate predictors on real data with the library: CLiFF-LHMP, the `improved` preset
//! and constant velocity on THÖR1 with its published map, the paper's protocol, 5 seeds.
//! The same as `cliff eval --map ../shared/data/thor1/cliffmap.csv --tracks
//! ../shared/data/thor1/exp-1-run-2.csv --format thor --seeds 5 --methods
//! cliff,improved,cvm`.
//!
//! Run: `cargo run --release --example evaluate` (reads ../shared/data)

use std::path::Path;

use cliff::eval::protocol::Settings;
use cliff::eval::{EvalConfig, evaluate, summary_table};
use cliff::map::CliffMap;
use cliff::predict::{Method, Options, Params};
use cliff::tracks::{Format, read_tracks};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/thor1");
    let map = CliffMap::load(data.join("cliffmap.csv"))?;
    let tracks = read_tracks(&data.join("exp-1-run-2.csv"), Format::Thor)?;
    let cfg = EvalConfig {
        motion_model: None,
        // the reference protocol: 3.2 s observed, 12 s predicted at 0.4 s
        settings: Settings::default(),
        params: Params {
            k: 20,
            radius: 0.7071,
            ..Params::default()
        },
        seeds: 5,
        methods: vec![Method::Cliff, Method::Improved, Method::Cvm],
        options: Options::default(),
    };
    let report = evaluate(&map, &tracks, &cfg, &|| {})?;
    println!(
        "{} people, {} evaluated\n{}",
        report.people_total,
        report.people_evaluated,
        summary_table(&report.summary, &[4.0, 8.0, 12.0])
    );
    Ok(())
}
