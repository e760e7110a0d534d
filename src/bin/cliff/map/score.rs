//! `cliff map score`: how well a map explains held-out trajectories.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use cliff::map::score::{ScoreParams, score as score_map, score_set};

use crate::args::TrackArgs;
use crate::clock;
use crate::load::{load_map_set, observations, timed_observations};

/// Options of `cliff map score`.
#[derive(Args, Debug)]
pub struct ScoreArgs {
    /// Map to score (.csv or .cliff). A time-of-day set scores each observation under
    /// the map of its time's slice.
    #[arg(long, value_name = "MAP")]
    pub map: PathBuf,
    /// Seconds added to the tracks' timestamps to get the local time of day that picks
    /// a set's slice; default: the offset stored in the set.
    #[arg(long, value_name = "DURATION", value_parser = clock::signed_duration, allow_hyphen_values = true)]
    pub clock_offset: Option<f64>,
    #[command(flatten)]
    pub input: TrackArgs,
    /// An observation is scored at the nearest location strictly within this
    /// distance (m) [default: the map's grid step, 1 m for ATC, 0.5 m for THÖR].
    #[arg(long)]
    pub radius: Option<f64>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Run `cliff map score`.
pub fn run(a: ScoreArgs) -> Result<()> {
    let set = load_map_set(Some(&a.map), a.clock_offset)?;
    let params = ScoreParams {
        radius: a.radius.unwrap_or(set.all_day().grid().step()),
        ..ScoreParams::default()
    };
    let r = if set.is_sliced() {
        let (obs, times, _) = timed_observations(&a.input)?;
        score_set(&set, &obs, &times, &params)?
    } else {
        let (obs, _) = observations(&a.input)?;
        score_map(set.all_day(), &obs, &params)?
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!("map                  {}", a.map.display());
        println!(
            "observations         {} moving ({} standing skipped)",
            r.observations, r.standing
        );
        println!(
            "unmatched            {} (no location within {} m)",
            r.unmatched, r.radius
        );
        println!("mean log-likelihood  {:.4}", r.mean_log_likelihood);
        println!("median               {:.4}", r.median_log_likelihood);
        println!(
            "{:<21}{:.2} %",
            format!("below {}", r.bad_below),
            100.0 * r.share_below
        );
    }
    Ok(())
}
