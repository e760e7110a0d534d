//! `cliff map convert`: a map (or a time-of-day set, or one of its slices) to another
//! format.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use cliff::map::{CliffMap, MapFormat, MapSet};

use crate::clock;
use crate::load::load_map_set;

/// Arguments of `cliff map convert`.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// Input map (.csv or .cliff).
    pub input: PathBuf,
    /// Output map (.csv or .cliff).
    pub output: PathBuf,
    /// Of a time-of-day set, export the map of the slice holding this local time of
    /// day (HH, HH:MM or HH:MM:SS; the all-day map where the slice has none), or
    /// `all-day`. Without it a set goes whole to a .cliff, its all-day map to a .csv.
    #[arg(long, value_name = "HH[:MM]|all-day")]
    pub slice: Option<String>,
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

/// Run `cliff map convert`.
pub fn run(a: ConvertArgs) -> Result<()> {
    let ConvertArgs {
        input,
        output,
        slice,
    } = a;
    let set = load_map_set(Some(&input), None)?;
    let whole =
        slice.is_none() && set.is_sliced() && MapFormat::from_path(&output)? == MapFormat::Snapshot;
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
