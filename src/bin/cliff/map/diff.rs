//! `cliff map diff`: what changed between two maps of one place (text, a picture).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use cliff::map::CliffMap;
use cliff::map::diff::diff;
use cliff::plot::{Floorplan, MapStyle, plot_diff};

use crate::args::FloorplanArgs;

/// Arguments of `cliff map diff`.
#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The older map (.csv or .cliff), e.g. the map a learning daemon started from.
    pub old: PathBuf,
    /// The newer map, e.g. a learned snapshot.
    pub new: PathBuf,
    /// Locations listed, the furthest moved first.
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// A location counts as moved when its mixture moved more than this (total
    /// variation, 0..1).
    #[arg(long, default_value_t = 0.01)]
    pub moved: f64,
    /// Print one JSON object (every location in both, added and removed) instead.
    #[arg(long)]
    pub json: bool,
    /// Also draw the changes: the new map's arrows over red squares as dark as each
    /// location moved, added locations as green circles, removed ones as black crosses
    /// (.png or .svg).
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// The move drawn opaque [default: the largest].
    #[arg(long, value_name = "TV")]
    pub full_move: Option<f64>,
    #[command(flatten)]
    pub frame: FloorplanArgs,
}

/// Run `cliff map diff`.
pub fn run(a: DiffArgs) -> Result<()> {
    if !(0.0..1.0).contains(&a.moved) {
        anyhow::bail!("--moved {} must be in [0, 1)", a.moved);
    }
    let load =
        |p: &PathBuf| CliffMap::load(p).with_context(|| format!("loading map {}", p.display()));
    let (old, new) = (load(&a.old)?, load(&a.new)?);
    let d = diff(&old, &new);
    if a.json {
        println!("{}", serde_json::to_string(&d)?);
    } else {
        let (oi, ni) = (old.info(), new.info());
        println!(
            "old                 {}: {} locations, {} components",
            a.old.display(),
            oi.locations,
            oi.components
        );
        println!(
            "new                 {}: {} locations, {} components",
            a.new.display(),
            ni.locations,
            ni.components
        );
        println!(
            "locations           {} added, {} removed, {} in both",
            d.added.len(),
            d.removed.len(),
            d.common.len()
        );
        let (c0, c1) = d.components();
        println!("components          {c0} -> {c1} in the locations in both");
        println!(
            "moved               {} of {} by more than {} (total variation); mean {:.4}, largest {:.4}",
            d.moved_more_than(a.moved),
            d.common.len(),
            a.moved,
            d.mean_move(),
            d.largest_move()
        );
        let top = d.largest(a.top);
        if !top.is_empty() {
            println!(
                "furthest moved      x, y (m), moved, components, heaviest component: direction (deg) and weight, observation ratio"
            );
        }
        for c in top {
            println!(
                "  {:8.2} {:8.2}  {:.4}  {} -> {}  {:5.1} {:.2} -> {:5.1} {:.2}  {:.3} -> {:.3}",
                c.position.x,
                c.position.y,
                c.moved,
                c.components.0,
                c.components.1,
                c.main_direction.0.to_degrees(),
                c.main_weight.0,
                c.main_direction.1.to_degrees(),
                c.main_weight.1,
                c.observation_ratio.0,
                c.observation_ratio.1
            );
        }
    }
    if let Some(out) = &a.png {
        let floorplan = match (&a.frame.floorplan, a.frame.extent) {
            (Some(p), Some(e)) => Some(
                Floorplan::load(p, e)
                    .with_context(|| format!("loading floor plan {}", p.display()))?,
            ),
            _ => None,
        };
        let style = MapStyle {
            width: a.frame.width,
            view: a.frame.view,
            floorplan_strength: a.frame.floorplan_strength,
            title: a.frame.title.clone(),
            legend: false,
            ..MapStyle::default()
        };
        let frame = plot_diff(&old, &new, &d, floorplan.as_ref(), &style, a.full_move, out)
            .with_context(|| format!("drawing {}", out.display()))?;
        if !a.json {
            println!(
                "wrote {} ({}x{} px)",
                out.display(),
                frame.size.0,
                frame.size.1
            );
        }
    }
    Ok(())
}
