//! `cliff map update`: a map updated online with a new batch of trajectories.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use cliff::map::CliffMap;
use cliff::map::update::{OnlineMap, UpdateParams};

use crate::args::TrackArgs;
use crate::load::observations;

/// Options of `cliff map update`.
#[derive(Args, Debug)]
pub struct UpdateArgs {
    /// Map to update (.csv or .cliff).
    #[arg(long, value_name = "MAP")]
    pub map: PathBuf,
    #[command(flatten)]
    pub input: TrackArgs,
    /// Output map (.csv or .cliff).
    #[arg(long, value_name = "MAP")]
    pub out: PathBuf,
    /// Moving samples that an observation ratio of 1 stands for in MAP: the busiest
    /// node's count, printed by `cliff map build` and by earlier updates. Without it
    /// the map weighs as much as the busiest node of the new batch.
    #[arg(long)]
    pub count_scale: Option<f64>,
    /// Decay of the map's effective counts before the batch is added, in (0, 1]
    /// (1: all data weigh the same).
    #[arg(long, default_value_t = 0.5)]
    pub decay: f64,
    /// Each node collects the observations within this distance (m) [default: the
    /// map's grid step].
    #[arg(long)]
    pub radius: Option<f64>,
    /// Largest number of components per location.
    #[arg(long, default_value_t = 10)]
    pub max_components: usize,
    /// Damping: the largest move of a location's mixture, as a total-variation
    /// distance in (0, 1] (docs/learning.md); an update moving a location further is
    /// blended with the mixture before it. Default: no damping.
    #[arg(long, value_name = "TV")]
    pub max_move: Option<f64>,
}

/// Run `cliff map update`.
pub fn run(a: UpdateArgs) -> Result<()> {
    let map = CliffMap::load(&a.map).with_context(|| format!("loading map {}", a.map.display()))?;
    let (obs, _) = observations(&a.input)?;
    let params = UpdateParams {
        decay: a.decay,
        radius: a.radius,
        max_components: a.max_components,
        max_move: a.max_move,
        ..UpdateParams::default()
    };
    let mut online = OnlineMap::from_map(&map, a.count_scale.unwrap_or(1.0), params)?;
    let scale = match a.count_scale {
        Some(s) => s,
        None => {
            let s = online.busiest_node(&obs)?.max(1) as f64;
            online.set_count_scale(s)?;
            s
        }
    };
    let t0 = Instant::now();
    let r = online.update(&obs)?;
    let out = online.to_map()?;
    out.save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    println!("wrote {}", a.out.display());
    println!("count scale in      {scale}");
    println!("observations        {}", r.observations);
    println!(
        "locations           {} updated, {} new, {} in all",
        r.updated,
        r.created,
        online.len()
    );
    println!(
        "components          {} added, {} merged, {} pruned, {} in all",
        r.added,
        r.merged,
        r.pruned,
        out.info().components
    );
    if a.max_move.is_some() {
        println!("damped              {} locations", r.damped);
    }
    println!(
        "count scale out     {:.1} (pass --count-scale {:.1} to the next update)",
        online.count_scale(),
        online.count_scale()
    );
    println!("time                {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}
