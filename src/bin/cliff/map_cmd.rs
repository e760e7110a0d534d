//! `cliff map ...`: inspect, convert, build, score and update maps.

use std::path::PathBuf;

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use cliff::map::timeofday::slice_label;
use cliff::map::{CliffMap, MapFormat, MapInfo, MapSet};

use crate::clock;
use crate::map_build_cmd::{BuildArgs, ScoreArgs, UpdateArgs};

/// Map subcommands.
#[derive(Subcommand)]
pub enum MapCommand {
    /// Print a map's extent, grid step, locations, components and observation ratios.
    ///
    /// Also counts what was fixed at load: covariances clamped to positive
    /// semi-definite and locations whose weights were renormalised. For a time-of-day
    /// set: the all-day map, the slice length, the clock offset, the smoothing and one
    /// line per slice.
    Info {
        /// Map file (.csv published format, or .cliff snapshot); omit for the demo scene.
        map: Option<PathBuf>,
    },
    /// Convert a map between formats, chosen by extension (.csv or .cliff).
    ///
    /// A time-of-day set (.cliff) copies to another .cliff whole; one of its maps is
    /// exported with --slice (to .csv or to a single-map .cliff).
    ///
    /// Example: cliff map convert ../shared/data/thor1/cliffmap.csv thor1.cliff
    ///
    /// Example: cliff map convert atc-set.cliff atc-13h.csv --slice 13
    Convert {
        /// Input map (.csv or .cliff).
        input: PathBuf,
        /// Output map (.csv or .cliff).
        output: PathBuf,
        /// Of a time-of-day set, export the map of the slice holding this local time of
        /// day (HH, HH:MM or HH:MM:SS; the all-day map where the slice has none), or
        /// `all-day`. Without it a set goes whole to a .cliff, its all-day map to a .csv.
        #[arg(long, value_name = "HH[:MM]|all-day")]
        slice: Option<String>,
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

/// Load the map set at `path` (a CSV map or version-1 snapshot is a set without
/// slices), or the built-in demo scene when `None`; `clock_offset` replaces the stored
/// offset.
pub fn load_map_set(path: Option<&PathBuf>, clock_offset: Option<f64>) -> Result<MapSet> {
    let mut set = match path {
        Some(p) => MapSet::load(p).with_context(|| format!("loading map {}", p.display()))?,
        None => MapSet::single(CliffMap::demo()),
    };
    if let Some(o) = clock_offset {
        set.set_clock_offset(o).context("--clock-offset")?;
    }
    Ok(set)
}

fn print_info(i: &MapInfo) {
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
}

fn print_set_info(set: &MapSet) {
    println!(
        "time of day         {} slices of {} s, clock offset {} s",
        set.slices().len(),
        set.slice_length(),
        set.clock_offset()
    );
    if let Some(s) = set.smoothing() {
        println!(
            "smoothing           kernel width {} s, prior {} observations, all-day share {}, merge distance {}, at most {} components",
            s.kernel_width, s.prior_weight, s.all_day_share, s.merge_distance, s.max_components
        );
    }
    println!(
        "{:<13} {:>12} {:>10} {:>11} {:>9}",
        "slice", "observations", "locations", "components", "per loc."
    );
    for (k, m) in set.slices().iter().enumerate() {
        let obs = set
            .observations()
            .get(k)
            .map_or("-".to_string(), |o| o.to_string());
        let label = slice_label(k, set.slice_length());
        match m {
            Some(m) => {
                let i = m.info();
                println!(
                    "{label:<13} {obs:>12} {:>10} {:>11} {:>9}",
                    i.locations,
                    i.components,
                    format!(
                        "{}..{}",
                        i.components_per_location.0, i.components_per_location.1
                    )
                );
            }
            None => println!("{label:<13} {obs:>12}   (all-day map)"),
        }
    }
}

/// The map a `--slice` value names in a set.
fn pick_slice(set: &MapSet, slice: &str) -> Result<Arc<CliffMap>> {
    if slice.trim().eq_ignore_ascii_case("all-day") {
        return Ok(set.all_day().clone());
    }
    let tod = clock::time_of_day(slice).map_err(|e| anyhow::anyhow!("--slice: {e}"))?;
    if !set.is_sliced() {
        bail!("--slice {slice}: the map is not a time-of-day set (it has no slices)");
    }
    let k = set
        .slice_of_time_of_day(tod)
        .expect("a time of day within the day falls in a slice");
    Ok(set.slice_map(k).expect("a slice of the set").clone())
}

/// Run a map subcommand.
pub fn run(cmd: MapCommand) -> Result<()> {
    match cmd {
        MapCommand::Info { map } => {
            let set = load_map_set(map.as_ref(), None)?;
            let name = map.as_ref().map_or("built-in demo scene".to_string(), |p| {
                p.display().to_string()
            });
            println!("map                 {name}");
            if set.is_sliced() {
                println!("all-day map:");
            }
            print_info(&set.all_day().info());
            match set.all_day().speed_prior() {
                Some(p) => println!(
                    "speed prior         v = {:.3} + {:.3} (v0 - {:.3}) m/s, from {} pairs",
                    p.mean, p.keep, p.mean, p.pairs
                ),
                None => println!("speed prior         none (improved keeps the observed speed)"),
            }
            if set.is_sliced() {
                print_set_info(&set);
            }
            Ok(())
        }
        MapCommand::Build(a) => crate::map_build_cmd::build(a),
        MapCommand::Score(a) => crate::map_build_cmd::score(a),
        MapCommand::Update(a) => crate::map_build_cmd::update(a),
        MapCommand::Convert {
            input,
            output,
            slice,
        } => {
            let set = load_map_set(Some(&input), None)?;
            let whole = slice.is_none()
                && set.is_sliced()
                && MapFormat::from_path(&output)? == MapFormat::Snapshot;
            if whole {
                set.save(&output)
                    .with_context(|| format!("writing {}", output.display()))?;
                println!(
                    "wrote {} (a time-of-day set: the all-day map and {} slices)",
                    output.display(),
                    set.slices().len()
                );
                return Ok(());
            }
            let m = match &slice {
                Some(s) => pick_slice(&set, s)?,
                None => set.all_day().clone(),
            };
            m.save(&output)
                .with_context(|| format!("writing {}", output.display()))?;
            println!(
                "wrote {} ({} locations, {} components)",
                output.display(),
                m.info().locations,
                m.info().components
            );
            if slice.is_none() && set.is_sliced() {
                eprintln!(
                    "note: {} holds one map: the set's all-day map was written; --slice HH exports a slice",
                    output.display()
                );
            }
            Ok(())
        }
    }
}
