//! `cliff predict`: the samples of one person of a trajectory file, as CSV.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use cliff::eval::protocol::prepare;
use cliff::map::timeofday::slice_label;
use cliff::predict::{Method, Rank, TrajectoryBatch};
use cliff::tracks::Format;

use crate::args::{PredictionArgs, ReadArgs};
use crate::clock;
use crate::load::{load_map_set, load_tracks_with};
use crate::person::predict_case;

/// Arguments of `cliff predict`.
#[derive(Args, Debug)]
pub struct PredictArgs {
    /// Map file (.csv or .cliff); omit for the built-in demo scene. With a time-of-day
    /// set, the map of the slice of the person's last observed row's time.
    #[arg(long)]
    pub map: Option<PathBuf>,
    /// Seconds added to the tracks' timestamps to get the local time of day that picks
    /// a set's slice; default: the offset stored in the set.
    #[arg(long, value_name = "DURATION", value_parser = clock::signed_duration, allow_hyphen_values = true)]
    pub clock_offset: Option<f64>,
    /// Trajectory file holding the person.
    #[arg(long)]
    pub tracks: PathBuf,
    /// Trajectory file format: thor, atc, magni (THÖR-MAGNI, header row), csv (header
    /// row, see --columns) or rosbag2 [default: recognised from each file: a bag or
    /// .mcap file, a header row, the time scale of six headerless columns]. MCAP files
    /// are read as recordings whatever the format.
    #[arg(long)]
    pub format: Option<Format>,
    #[command(flatten)]
    pub read: ReadArgs,
    /// Person id.
    #[arg(long)]
    pub person: u64,
    #[command(flatten)]
    pub prediction: PredictionArgs,
    /// Method: cliff, cvm, improved (CLiFF-LHMP with the project's preset: its own
    /// beta and options), motion (the built-in motion model) or cvm-last.
    #[arg(long, default_value = "cliff")]
    pub method: Method,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output CSV (sample, step, t, x, y); omit to print to standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run `cliff predict`.
pub fn run(a: PredictArgs) -> Result<()> {
    let maps = load_map_set(a.map.as_ref(), a.clock_offset)?;
    let tracks = load_tracks_with(std::slice::from_ref(&a.tracks), a.format, &a.read)?;
    let track = tracks
        .iter()
        .find(|t| t.id == a.person)
        .with_context(|| format!("person {} is not in {}", a.person, a.tracks.display()))?;
    let settings = a.prediction.settings();
    let case = prepare(track, &settings).with_context(|| {
        format!(
            "person {} is skipped by the {} protocol (too short, idle, or no future to predict)",
            a.person, settings.protocol
        )
    })?;
    let mut batch = TrajectoryBatch::new();
    let map = maps.at(case.start.time);
    let params = predict_case(map, &case, &a.prediction, a.method, a.seed, &mut batch)?;
    // score: the sample's log-likelihood under the map, or with consensus ranking (and
    // for `improved`) its closeness to the other samples (the same on each of its rows)
    let mut out = String::from("sample,step,t,x,y,score\n");
    for s in 0..params.k {
        let score = batch.score(0, s).unwrap_or(f32::NAN);
        for (j, p) in batch.sample(0, s).iter().enumerate() {
            let t = case.start.time + (j + 1) as f64 * params.dt;
            let _ = writeln!(
                out,
                "{s},{},{t:.3},{:.4},{:.4},{score:.3}",
                j + 1,
                p[0],
                p[1]
            );
        }
    }
    match &a.out {
        Some(path) => {
            std::fs::write(path, out).with_context(|| format!("writing {}", path.display()))?;
            let reached = (0..params.k)
                .filter(|&s| batch.len(0, s) == case.steps)
                .count();
            let slice = match maps.slice_index(case.start.time) {
                Some(k) => format!(
                    " (slice {}{})",
                    slice_label(k, maps.slice_length()),
                    if maps.slices()[k].is_none() {
                        ": the all-day map"
                    } else {
                        ""
                    }
                ),
                None => String::new(),
            };
            println!(
                "person {}: start ({:.2}, {:.2}) at t {:.2}{slice}, speed {:.2} m/s, heading {:.1} deg; {} samples of {} steps ({} reach the end, the {} is sample {}); wrote {}",
                case.id,
                case.start.position.x,
                case.start.position.y,
                case.start.time,
                case.start.speed,
                case.start.heading.to_degrees(),
                params.k,
                case.steps,
                reached,
                if a.method == Method::Improved || a.prediction.rank == Rank::Consensus {
                    "best-ranked"
                } else {
                    "most likely"
                },
                batch.best_sample(0).unwrap_or(0),
                path.display()
            );
        }
        None => print!("{out}"),
    }
    Ok(())
}
