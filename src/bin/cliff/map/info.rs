//! `cliff map info`: a map's extent, grid, locations, components and slices.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use cliff::map::timeofday::slice_label;
use cliff::map::{MapInfo, MapSet};

use crate::load::load_map_set;

/// Arguments of `cliff map info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Map file (.csv published format, or .cliff snapshot); omit for the demo scene.
    pub map: Option<PathBuf>,
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

/// Run `cliff map info`.
pub fn run(a: InfoArgs) -> Result<()> {
    let map = a.map;
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
