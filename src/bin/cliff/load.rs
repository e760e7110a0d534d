//! Reading what the commands work on: maps and time-of-day sets (or the demo scene),
//! trajectory files (with a column mapping and a time range, or the demo walkers),
//! the observations the learning commands fit, floor plans and evaluation summaries.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use cliff::map::build::{Observation, observations_from_tracks, timed_observations_from_tracks};
use cliff::map::{CliffMap, MapSet};
use cliff::plot::{Floorplan, SummaryRow, read_per_person_spread, read_summary};
use cliff::tracks::scene::{SceneOptions, demo_tracks};
use cliff::tracks::{DatasetError, Format, ReadError, Track, keep_time_range, read_many_as};

use crate::args::{FloorplanArgs, ReadArgs, Spread, TrackArgs};

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

/// Read trajectory files in `format` (none: each file's own, recognised from it), every
/// row.
pub fn load_tracks(paths: &[PathBuf], format: Option<Format>) -> Result<Vec<Track>> {
    load_tracks_with(paths, format, &ReadArgs::default())
}

/// Read trajectory files with a column mapping and time range; a file whose format is
/// not recognised is an error that names the `--format` values to choose from.
pub fn load_tracks_with(
    paths: &[PathBuf],
    format: Option<Format>,
    read: &ReadArgs,
) -> Result<Vec<Track>> {
    for p in paths {
        if !p.exists() {
            bail!("track file {} does not exist", p.display());
        }
    }
    let mut tracks = read_many_as(paths, format, read.columns.as_ref(), read.topic.as_deref())
        .map_err(|e| match &e {
            ReadError::Dataset(DatasetError::Unrecognised {
                file,
                reason,
                choices,
            }) => {
                let give: Vec<String> = choices.iter().map(|c| format!("--format {c}")).collect();
                anyhow!(
                    "{file}: the format is not recognised: {reason}; give {}",
                    or_list(&give)
                )
            }
            _ => e.into(),
        })?;
    if read.time_from.is_some() || read.time_until.is_some() {
        let from = read.time_from.unwrap_or(f64::NEG_INFINITY);
        let until = read.time_until.unwrap_or(f64::INFINITY);
        if from.is_nan() || until.is_nan() || from >= until {
            bail!("--time-from {from} is not before --time-until {until}");
        }
        keep_time_range(&mut tracks, from, until);
    }
    Ok(tracks)
}

/// `a, b or c`.
fn or_list(items: &[String]) -> String {
    match items {
        [init @ .., last] if !init.is_empty() => format!("{} or {last}", init.join(", ")),
        _ => items.join(""),
    }
}

/// The tracks of `plot predict`: the file given, or the demo walkers.
pub fn tracks_or_demo(
    map: Option<&PathBuf>,
    tracks: Option<&PathBuf>,
    format: Option<Format>,
) -> Result<Vec<Track>> {
    match (map, tracks) {
        (_, Some(t)) => load_tracks(std::slice::from_ref(t), format),
        (None, None) => Ok(demo_tracks(&SceneOptions::default())),
        (Some(_), None) => {
            bail!("--tracks is needed with --map (the demo walkers only walk the demo hall)")
        }
    }
}

/// The observations of the trajectory input (and its tracks); an error when the files
/// hold no rows.
pub fn observations(input: &TrackArgs) -> Result<(Vec<Observation>, Vec<Track>)> {
    let tracks = load_tracks_with(&input.tracks, input.format, &input.read)
        .context("reading trajectories")?;
    let obs = observations_from_tracks(&tracks);
    if obs.is_empty() {
        bail!("the trajectory files hold no rows");
    }
    Ok((obs, tracks))
}

/// The observations of the trajectory input with the time of each (and its tracks);
/// an error when the files hold no rows.
pub fn timed_observations(input: &TrackArgs) -> Result<(Vec<Observation>, Vec<f64>, Vec<Track>)> {
    let tracks = load_tracks_with(&input.tracks, input.format, &input.read)
        .context("reading trajectories")?;
    let (obs, times) = timed_observations_from_tracks(&tracks);
    if obs.is_empty() {
        bail!("the trajectory files hold no rows");
    }
    Ok((obs, times, tracks))
}

/// The floor plan: the given image, or the demo hall's floor when no map file is used,
/// or none.
pub fn load_floorplan(
    frame: &FloorplanArgs,
    map_file: Option<&PathBuf>,
) -> Result<Option<Floorplan>> {
    match (&frame.floorplan, frame.extent) {
        (Some(path), Some(extent)) => {
            Ok(Some(Floorplan::load(path, extent).with_context(|| {
                format!("loading floor plan {}", path.display())
            })?))
        }
        (Some(_), None) | (None, Some(_)) => {
            bail!("--floorplan and --extent go together: give both or neither")
        }
        (None, None) if map_file.is_none() => Ok(Some(Floorplan::demo())),
        (None, None) => Ok(None),
    }
}

/// The rows of one run: the summary itself, or its per-person file summarised.
pub fn run_rows(summary: &Path, spread: Spread) -> Result<Vec<SummaryRow>> {
    Ok(match spread {
        Spread::Summary => read_summary(summary)?,
        Spread::People => {
            let pp = summary.with_file_name("per_person.csv");
            if !pp.is_file() {
                bail!(
                    "--spread people needs {} beside {} (written by cliff eval --out)",
                    pp.display(),
                    summary.display()
                );
            }
            read_per_person_spread(&pp)?
        }
    })
}
