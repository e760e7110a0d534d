//! `cliff map ...`: inspect, convert, build, score and update maps.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Subcommand;
use cliff::map::CliffMap;

use crate::map_build_cmd::{BuildArgs, ScoreArgs, UpdateArgs};

/// Map subcommands.
#[derive(Subcommand)]
pub enum MapCommand {
    /// Print a map's extent, grid step, locations, components and observation ratios.
    ///
    /// Also counts what was fixed at load: covariances clamped to positive
    /// semi-definite and locations whose weights were renormalised.
    Info {
        /// Map file (.csv published format, or .cliff snapshot); omit for the demo scene.
        map: Option<PathBuf>,
    },
    /// Convert a map between formats, chosen by extension (.csv or .cliff).
    ///
    /// Example: cliff map convert ../shared/data/thor1/cliffmap.csv thor1.cliff
    Convert {
        /// Input map (.csv or .cliff).
        input: PathBuf,
        /// Output map (.csv or .cliff).
        output: PathBuf,
    },
    /// Build a CLiFF-map from recorded trajectories (mean shift + EM per grid node).
    ///
    /// Example: cliff map build --tracks ../shared/data/atc/train/*.csv --format atc
    /// --grid 1 --radius 1 --out atc-train.csv
    Build(BuildArgs),
    /// Score a map on held-out trajectories: mean log-likelihood of the observed
    /// velocities at the nearest location.
    ///
    /// Example: cliff map score --map atc-train.csv --tracks ../shared/data/atc/dev/*.csv
    /// --format atc --json
    Score(ScoreArgs),
    /// Update a map with a new batch of trajectories, without the old data.
    ///
    /// Online learning: the map's counts decay, components are updated from their
    /// sufficient statistics, samples the map does not explain get new components,
    /// near-duplicates are merged. The result goes to --out.
    ///
    /// Example: cliff map update --map hour9.csv --count-scale 1523 --tracks
    /// ../shared/data/atc/train/atc-1024-10_train.csv --format atc --out hour10.csv
    Update(UpdateArgs),
}

/// Load the map at `path`, or the built-in demo scene when `None`.
pub fn load_map(path: Option<&PathBuf>) -> Result<CliffMap> {
    match path {
        Some(p) => CliffMap::load(p).with_context(|| format!("loading map {}", p.display())),
        None => Ok(CliffMap::demo()),
    }
}

/// Run a map subcommand.
pub fn run(cmd: MapCommand) -> Result<()> {
    match cmd {
        MapCommand::Info { map } => {
            let m = load_map(map.as_ref())?;
            let i = m.info();
            let name = map.as_ref().map_or("built-in demo scene".to_string(), |p| {
                p.display().to_string()
            });
            println!("map                 {name}");
            println!(
                "extent              x {:.3} .. {:.3}, y {:.3} .. {:.3} m",
                i.extent.0.x, i.extent.1.x, i.extent.0.y, i.extent.1.y
            );
            println!("grid step           {} m", i.grid_step);
            println!("locations           {}", i.locations);
            println!("components          {}", i.components);
            println!(
                "per location        {} .. {} (mean {:.2})",
                i.components_per_location.0,
                i.components_per_location.1,
                i.components as f64 / i.locations as f64
            );
            println!(
                "observation ratio   {:.4} .. {:.4}",
                i.observation_ratio.0, i.observation_ratio.1
            );
            println!(
                "fixed at load       {} covariances clamped to PSD, {} locations' weights renormalised",
                i.report.clamped_covariances, i.report.renormalised_locations
            );
            Ok(())
        }
        MapCommand::Build(a) => crate::map_build_cmd::build(a),
        MapCommand::Score(a) => crate::map_build_cmd::score(a),
        MapCommand::Update(a) => crate::map_build_cmd::update(a),
        MapCommand::Convert { input, output } => {
            let m = load_map(Some(&input))?;
            m.save(&output)
                .with_context(|| format!("writing {}", output.display()))?;
            println!(
                "wrote {} ({} locations, {} components)",
                output.display(),
                m.info().locations,
                m.info().components
            );
            Ok(())
        }
    }
}
